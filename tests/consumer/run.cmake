# Consumer test driver (cmake -P): installs a build tree, then configures, builds and runs
# tests/consumer/app against the installed package only, as an outside project would.
#   -DBUILD_DIR=<imuforge build tree> -DAPP_DIR=<tests/consumer/app> -DWORK=<scratch dir>
#   [-DTOOLCHAIN=<toolchain file> -DQEMU_MACHINE=mps2-an386]   cross: run the ELFs under qemu-system-arm
#   [-DEXTRA_FLAGS="-fsanitize=..."]                            build the consumer like the library
# Pass: consumer_cpp (C++ API) and consumer_c (C11 API) print byte-identical outputs, those outputs
# hold every sample, the lab program (host) passes, and (host) the pkg-config file builds the C program
# and the C example of docs/kernel.md.
cmake_minimum_required(VERSION 3.25)

function(run)
  execute_process(COMMAND ${ARGN} WORKING_DIRECTORY ${WORK} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    list(JOIN ARGN " " cmd)
    message(FATAL_ERROR "consumer: '${cmd}' failed (${rc}):\n${out}\n${err}")
  endif()
  set(out "${out}" PARENT_SCOPE)
endfunction()

file(REMOVE_RECURSE ${WORK})
file(MAKE_DIRECTORY ${WORK})
set(prefix ${WORK}/prefix)
run(${CMAKE_COMMAND} --install ${BUILD_DIR} --prefix ${prefix})
foreach(f lib/cmake/imuforge/imuforgeConfig.cmake lib/pkgconfig/imuforge-fw.pc include/imuforge/firmware/capi/imuforge.h
          include/imuforge/firmware/kernel/compensation.h lib/libimuforge_fw.a)
  if(NOT EXISTS ${prefix}/${f})
    message(FATAL_ERROR "consumer: install lacks ${f}")
  endif()
endforeach()

set(cfg -S ${APP_DIR} -B ${WORK}/build -G Ninja -DCMAKE_BUILD_TYPE=Release -DCMAKE_PREFIX_PATH=${prefix})
if(TOOLCHAIN)
  list(APPEND cfg -DCMAKE_TOOLCHAIN_FILE=${TOOLCHAIN})
endif()
if(EXTRA_FLAGS)
  list(APPEND cfg "-DCMAKE_C_FLAGS=${EXTRA_FLAGS}" "-DCMAKE_CXX_FLAGS=${EXTRA_FLAGS}"
       "-DCMAKE_EXE_LINKER_FLAGS=${EXTRA_FLAGS}")
endif()
run(${CMAKE_COMMAND} ${cfg})
run(${CMAKE_COMMAND} --build ${WORK}/build)

function(run_program name var)
  if(QEMU_MACHINE)
    run(qemu-system-arm -M ${QEMU_MACHINE} -nographic -monitor none -serial none
        -semihosting-config enable=on,target=native -kernel ${WORK}/build/${name}.elf)
  else()
    run(${WORK}/build/${name})
  endif()
  set(${var} "${out}" PARENT_SCOPE)
endfunction()

run_program(consumer_cpp out_cpp)   # also writes table.bin into WORK
run_program(consumer_c out_c)
file(WRITE ${WORK}/out_cpp.txt "${out_cpp}")
file(WRITE ${WORK}/out_c.txt "${out_c}")
string(REGEX MATCHALL "\nf [0-9]+ " f_lines "${out_cpp}")
list(LENGTH f_lines n)
if(NOT out_cpp MATCHES "\nend\n$" OR NOT n EQUAL 3000 OR NOT out_cpp MATCHES "^corrupt -106 ")
  message(FATAL_ERROR "consumer: C++ output incomplete (${n} f32 lines, expected 3000; see ${WORK}/out_cpp.txt)")
endif()
if(NOT out_c STREQUAL out_cpp)
  message(FATAL_ERROR "consumer: the C API output differs from the C++ API output: diff ${WORK}/out_cpp.txt ${WORK}/out_c.txt")
endif()
message(STATUS "consumer: C and C++ API outputs identical (${n} samples x 2 kernels x 2 widths)")

if(NOT TOOLCHAIN)
  run(${WORK}/build/consumer_lab)
  message(STATUS "${out}")
  if(NOT EXISTS ${prefix}/lib/pkgconfig/imuforge.pc)
    message(FATAL_ERROR "consumer: host install lacks lib/pkgconfig/imuforge.pc")
  endif()
  # A Makefile project: the same C program through pkg-config only.
  set(ENV{PKG_CONFIG_PATH} ${prefix}/lib/pkgconfig)
  run(pkg-config --cflags imuforge-fw)
  string(STRIP "${out}" cflags)
  run(pkg-config --libs imuforge-fw)
  string(STRIP "${out}" libs)
  separate_arguments(cflags UNIX_COMMAND "${cflags}")
  separate_arguments(libs UNIX_COMMAND "${libs}")
  separate_arguments(xflags UNIX_COMMAND "${EXTRA_FLAGS}")
  run(cc -std=c11 -Wall -Wextra -Werror -pedantic ${xflags} ${cflags} -I${APP_DIR} ${APP_DIR}/consumer.c ${libs}
      -o ${WORK}/consumer_c_pc)
  run(${WORK}/consumer_c_pc)
  if(NOT out STREQUAL out_cpp)
    message(FATAL_ERROR "consumer: the pkg-config build of consumer.c prints different output")
  endif()
  run(pkg-config --exists --print-errors imuforge)
  # The C firmware example of docs/kernel.md compiles against the install as printed there.
  file(READ ${APP_DIR}/../../../docs/kernel.md doc)
  string(REGEX MATCH "```c\n([^`]*)```" _ "${doc}")
  set(example "${CMAKE_MATCH_1}")
  if(NOT example MATCHES "imuforge_kernel_f32_run")
    message(FATAL_ERROR "consumer: no C example found in docs/kernel.md")
  endif()
  file(WRITE ${WORK}/doc_example.c "${example}")
  run(cc -std=c11 -Wall -Wextra -Werror -pedantic ${cflags} -c ${WORK}/doc_example.c -o ${WORK}/doc_example.o)
  message(STATUS "consumer: pkg-config build identical too")
endif()

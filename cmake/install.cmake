# `cmake --install`: the firmware library (every preset) and the host libraries a lab links (host presets),
# with headers, a CMake package (find_package(imuforge) -> imuforge::fw, imuforge::io, ...) and
# pkg-config files. Layout and per-target prefixes: docs/install.md.
#
#   <prefix>/include/imuforge/{firmware,hal,host}/...   headers, at their repository paths
#   <prefix>/lib/libimuforge_*.a                        static libraries
#   <prefix>/lib/cmake/imuforge/                        imuforgeConfig.cmake, targets, version
#   <prefix>/lib/pkgconfig/imuforge-fw.pc               firmware (every preset)
#   <prefix>/lib/pkgconfig/imuforge.pc                  host libraries (host presets)
#   <prefix>/share/imuforge/mps2/                       qemu mps2 runtime (cross presets, for tests)
include(GNUInstallDirs)
include(CMakePackageConfigHelpers)

set(_inc ${CMAKE_INSTALL_INCLUDEDIR}/imuforge)
set(_cmakedir ${CMAKE_INSTALL_LIBDIR}/cmake/imuforge)

# ---- firmware: library, its headers and the hal seams they include
set_target_properties(imuforge_fw PROPERTIES EXPORT_NAME fw)
install(TARGETS imuforge_fw EXPORT imuforge-targets ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR})
foreach(d ${IMUFORGE_FW_DIRS})
  install(DIRECTORY ${PROJECT_SOURCE_DIR}/firmware/${d}/ DESTINATION ${_inc}/firmware/${d} FILES_MATCHING PATTERN "*.h")
endforeach()
install(FILES ${PROJECT_SOURCE_DIR}/hal/can.h ${PROJECT_SOURCE_DIR}/hal/flash.h ${PROJECT_SOURCE_DIR}/hal/clock.h
              ${PROJECT_SOURCE_DIR}/hal/sensor.h DESTINATION ${_inc}/hal)

# pkg-config: prefix relative to the .pc file, so an installed tree can be moved.
get_target_property(_fw_defs imuforge_fw INTERFACE_COMPILE_DEFINITIONS)
set(_fw_cflags "")
foreach(def ${_fw_defs})
  string(REPLACE "\"" "\\\"" def "${def}")
  string(APPEND _fw_cflags " \"-D${def}\"")
endforeach()
set(IMUFORGE_PC_FW_CFLAGS "${_fw_cflags}")
configure_file(${CMAKE_CURRENT_LIST_DIR}/imuforge-fw.pc.in ${PROJECT_BINARY_DIR}/pkgconfig/imuforge-fw.pc @ONLY)
install(FILES ${PROJECT_BINARY_DIR}/pkgconfig/imuforge-fw.pc DESTINATION ${CMAKE_INSTALL_LIBDIR}/pkgconfig)

# ---- cross presets: the qemu mps2 test runtime (startup, linker script, semihosting), so the consumer
# test can run an ELF built against the installed package under qemu-system-arm. Firmware projects
# bring their own startup code and linker script instead.
set(IMUFORGE_INSTALL_MCU_RT OFF)
if(CMAKE_CROSSCOMPILING AND TARGET imuforge_mcu_test_rt)
  set(IMUFORGE_INSTALL_MCU_RT ON)
  set_target_properties(imuforge_mcu_test_rt PROPERTIES EXPORT_NAME qemu_mps2_rt)
  set_target_properties(imuforge_hal_mcu PROPERTIES EXPORT_NAME hal_mcu)
  install(TARGETS imuforge_mcu_test_rt imuforge_hal_mcu EXPORT imuforge-targets
          ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR} OBJECTS DESTINATION ${CMAKE_INSTALL_LIBDIR}/imuforge-objects)
  install(FILES ${IMUFORGE_MCU_LINKER_SCRIPT} DESTINATION ${CMAKE_INSTALL_DATADIR}/imuforge/mps2)
  install(FILES ${PROJECT_SOURCE_DIR}/hal/mcu/systick_clock.h DESTINATION ${_inc}/hal/mcu)
endif()

# ---- host presets: the libraries a lab links (log reader/writer, table writer, solver, diagnosis,
# navigation impact) and
# every imuforge library they depend on, found by walking their link dependencies (so a library that
# moves or splits needs no change here).
set(IMUFORGE_LAB_LIBS imuforge_io imuforge_table imuforge_solver imuforge_diagnosis)
if(TARGET imuforge_navigate)
  list(APPEND IMUFORGE_LAB_LIBS imuforge_navigate)  # navigation impact of a calibration
endif()
set(IMUFORGE_INSTALLED_HOST_LIBS "")
if(IMUFORGE_HOST)
  get_property(_host_libs GLOBAL PROPERTY IMUFORGE_HOST_LIBS)
  # Depth-first post-order: every library after the ones it depends on; reversed, that is link order.
  set(_order "")
  function(_imuforge_visit t)
    if(t IN_LIST _order)
      return()
    endif()
    get_target_property(_deps ${t} LINK_LIBRARIES)
    foreach(d ${_deps})
      if(d IN_LIST _host_libs)
        _imuforge_visit(${d})
      endif()
    endforeach()
    list(APPEND _order ${t})
    set(_order ${_order} PARENT_SCOPE)
  endfunction()
  foreach(t ${IMUFORGE_LAB_LIBS})
    _imuforge_visit(${t})
  endforeach()
  list(REVERSE _order)
  set(_seen ${_order})
  set(IMUFORGE_INSTALLED_HOST_LIBS ${_seen})
  # Position independent: the Python module (host/python) links them into a shared object, and so may
  # a lab's own shared library built against the installed package.
  set_target_properties(imuforge_fw ${_seen} PROPERTIES POSITION_INDEPENDENT_CODE ON)
  set(_pc_libs "")
  foreach(_t ${_seen})
    string(REGEX REPLACE "^imuforge_" "" _short ${_t})
    set_target_properties(${_t} PROPERTIES EXPORT_NAME ${_short})
    install(TARGETS ${_t} EXPORT imuforge-targets ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR})
    get_target_property(_src ${_t} SOURCE_DIR)
    file(RELATIVE_PATH _rel ${PROJECT_SOURCE_DIR} ${_src})
    install(DIRECTORY ${_src}/ DESTINATION ${_inc}/${_rel} FILES_MATCHING PATTERN "*.h")
    string(APPEND _pc_libs " -l${_t}")
  endforeach()
  set(IMUFORGE_PC_HOST_LIBS "${_pc_libs}")
  configure_file(${CMAKE_CURRENT_LIST_DIR}/imuforge.pc.in ${PROJECT_BINARY_DIR}/pkgconfig/imuforge.pc @ONLY)
  install(FILES ${PROJECT_BINARY_DIR}/pkgconfig/imuforge.pc DESTINATION ${CMAKE_INSTALL_LIBDIR}/pkgconfig)
endif()

# ---- CMake package
install(EXPORT imuforge-targets NAMESPACE imuforge:: DESTINATION ${_cmakedir})
set(IMUFORGE_BUILT_FOR "${IMUFORGE_TARGET_NAME}")
if(NOT IMUFORGE_BUILT_FOR)
  set(IMUFORGE_BUILT_FOR "host")
endif()
configure_package_config_file(${CMAKE_CURRENT_LIST_DIR}/imuforgeConfig.cmake.in
  ${PROJECT_BINARY_DIR}/cmake/imuforgeConfig.cmake INSTALL_DESTINATION ${_cmakedir})
write_basic_package_version_file(${PROJECT_BINARY_DIR}/cmake/imuforgeConfigVersion.cmake
  VERSION ${PROJECT_VERSION} COMPATIBILITY SameMinorVersion)
install(FILES ${PROJECT_BINARY_DIR}/cmake/imuforgeConfig.cmake ${PROJECT_BINARY_DIR}/cmake/imuforgeConfigVersion.cmake
        DESTINATION ${_cmakedir})

# Shared part of the Cortex-M toolchain files. The including file sets IMUFORGE_MCU_FLAGS,
# IMUFORGE_QEMU_MACHINE and IMUFORGE_TARGET_NAME first.
set(CMAKE_SYSTEM_NAME Generic)
set(CMAKE_SYSTEM_PROCESSOR arm)
set(CMAKE_C_COMPILER arm-none-eabi-gcc)
set(CMAKE_CXX_COMPILER arm-none-eabi-g++)
set(CMAKE_ASM_COMPILER arm-none-eabi-gcc)
set(CMAKE_OBJCOPY arm-none-eabi-objcopy CACHE FILEPATH "")
set(CMAKE_SIZE arm-none-eabi-size CACHE FILEPATH "")
# try_compile cannot link without a board's startup code.
set(CMAKE_TRY_COMPILE_TARGET_TYPE STATIC_LIBRARY)

set(CMAKE_C_FLAGS_INIT "${IMUFORGE_MCU_FLAGS} -ffunction-sections -fdata-sections")
set(CMAKE_CXX_FLAGS_INIT "${IMUFORGE_MCU_FLAGS} -ffunction-sections -fdata-sections -fno-exceptions -fno-rtti -fno-threadsafe-statics")
set(CMAKE_ASM_FLAGS_INIT "${IMUFORGE_MCU_FLAGS}")
set(CMAKE_EXE_LINKER_FLAGS_INIT "${IMUFORGE_MCU_FLAGS} -Wl,--gc-sections")
set(CMAKE_C_FLAGS_RELEASE "-O2" CACHE STRING "")
set(CMAKE_CXX_FLAGS_RELEASE "-O2" CACHE STRING "")

set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)
set(CMAKE_FIND_ROOT_PATH_MODE_LIBRARY ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_INCLUDE ONLY)

set(IMUFORGE_QEMU_MACHINE "${IMUFORGE_QEMU_MACHINE}" CACHE STRING "qemu-system-arm -M machine for the unit tests")
set(IMUFORGE_TARGET_NAME "${IMUFORGE_TARGET_NAME}" CACHE STRING "target name printed by benchmarks")

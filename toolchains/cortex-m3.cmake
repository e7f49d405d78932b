# Cortex-M3, no FPU: the integer (fixed-point) kernel path. Tests run on qemu mps2-an385.
set(IMUFORGE_MCU_FLAGS "-mcpu=cortex-m3 -mthumb -mfloat-abi=soft")
set(IMUFORGE_QEMU_MACHINE mps2-an385)
set(IMUFORGE_TARGET_NAME cortex-m3)
set(IMUFORGE_HAS_FPU OFF CACHE BOOL "")
include(${CMAKE_CURRENT_LIST_DIR}/arm-none-eabi-common.cmake)

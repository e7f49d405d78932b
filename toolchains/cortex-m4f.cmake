# Cortex-M4F with single-precision FPU, hard-float ABI: the f32 kernel path. Tests run on qemu mps2-an386.
set(IMUFORGE_MCU_FLAGS "-mcpu=cortex-m4 -mthumb -mfpu=fpv4-sp-d16 -mfloat-abi=hard")
set(IMUFORGE_QEMU_MACHINE mps2-an386)
set(IMUFORGE_TARGET_NAME cortex-m4f)
set(IMUFORGE_HAS_FPU ON CACHE BOOL "")
include(${CMAKE_CURRENT_LIST_DIR}/arm-none-eabi-common.cmake)

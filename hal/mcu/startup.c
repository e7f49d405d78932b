/* Cortex-M startup for imuforge: vector table at address 0 (initial SP + reset handler + faults),
 * .data copy, .bss clear, FPU enable on parts that have one, static constructors, main().
 * Built twice (hal/mcu/CMakeLists.txt): with IMUFORGE_SEMIHOSTING for the unit-test runtime
 * (newlib rdimon: printf and the exit code reach the host through semihosting) and without it for the
 * firmware image (no semihosting, no stdio; main must not return, a return parks the core). */
#include <stdint.h>

extern uint32_t _stack_top, _data_load, _data_start, _data_end, _bss_start, _bss_end;
extern int main(void);
extern void __libc_init_array(void);

#ifdef IMUFORGE_SEMIHOSTING
extern void initialise_monitor_handles(void);
extern void exit(int status) __attribute__((noreturn));
#endif

void Reset_Handler(void) __attribute__((noreturn));
void Default_Handler(void);
void SysTick_Handler(void) __attribute__((weak, alias("Default_Handler")));
void NMI_Handler(void) __attribute__((weak, alias("Default_Handler")));
void HardFault_Handler(void) __attribute__((weak, alias("Default_Handler")));
void MemManage_Handler(void) __attribute__((weak, alias("Default_Handler")));
void BusFault_Handler(void) __attribute__((weak, alias("Default_Handler")));
void UsageFault_Handler(void) __attribute__((weak, alias("Default_Handler")));
void SVC_Handler(void) __attribute__((weak, alias("Default_Handler")));
void PendSV_Handler(void) __attribute__((weak, alias("Default_Handler")));

/* crti/crtn/crtbegin are not linked (-nostartfiles): __libc_init_array calls _init/_fini, and
 * __cxa_atexit registrations name the module by __dso_handle. */
void* __dso_handle = &__dso_handle;
void _init(void) {}
void _fini(void) {}

typedef void (*vector_fn)(void);
__attribute__((section(".isr_vector"), used)) const vector_fn imuforge_vectors[16] = {
    (vector_fn)(uintptr_t)&_stack_top,
    Reset_Handler,
    NMI_Handler,
    HardFault_Handler,
    MemManage_Handler,
    BusFault_Handler,
    UsageFault_Handler,
    0, 0, 0, 0,
    SVC_Handler,
    0,
    0,
    PendSV_Handler,
    SysTick_Handler,
};

void Reset_Handler(void) {
  const uint32_t* src = &_data_load;
  for (uint32_t* dst = &_data_start; dst < &_data_end;) *dst++ = *src++;
  for (uint32_t* dst = &_bss_start; dst < &_bss_end;) *dst++ = 0;
#if defined(__ARM_FP)
  /* CPACR: full access to CP10/CP11 before any float instruction runs. */
  *(volatile uint32_t*)0xE000ED88u |= (0xFu << 20);
  __asm volatile("dsb\n\tisb" ::: "memory");
#endif
#ifdef IMUFORGE_SEMIHOSTING
  initialise_monitor_handles();
  __libc_init_array();
  exit(main());
#else
  __libc_init_array();
  (void)main();
  for (;;) __asm volatile("wfi");
#endif
}

#ifdef IMUFORGE_SEMIHOSTING
/* A fault in a test must end the qemu run with a failure, not hang until the ctest timeout. */
void Default_Handler(void) { exit(99); }
#else
void Default_Handler(void) {
  for (;;) {
  }
}
#endif

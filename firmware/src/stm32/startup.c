/* Vector table and reset handler of the STM32F405 images (no vendor start-up code). */
#include <stdint.h>
#include <string.h>

extern uint32_t _sidata, _sdata, _edata, _sbss, _ebss, _estack;
extern int main(void);
void stm32_systick_handler(void);

void reset_handler(void);
static void default_handler(void)
{
    for (;;) { }                 /* a fault: the independent watchdog restarts the MCU */
}

__attribute__((section(".isr_vector"), used))
const void *const vector_table[16 + 82] = {
    [0] = &_estack,
    [1] = (const void *)reset_handler,
    [2] = (const void *)default_handler,          /* NMI */
    [3] = (const void *)default_handler,          /* HardFault */
    [4] = (const void *)default_handler,          /* MemManage */
    [5] = (const void *)default_handler,          /* BusFault */
    [6] = (const void *)default_handler,          /* UsageFault */
    [11] = (const void *)default_handler,         /* SVCall */
    [14] = (const void *)default_handler,         /* PendSV */
    [15] = (const void *)stm32_systick_handler,   /* SysTick */
};

void reset_handler(void)
{
    uint32_t *src = &_sidata;
    for (uint32_t *dst = &_sdata; dst < &_edata;) *dst++ = *src++;
    for (uint32_t *dst = &_sbss; dst < &_ebss;) *dst++ = 0;
    main();
    for (;;) { }
}

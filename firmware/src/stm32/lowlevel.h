/* The STM32F405 parts both MCU images share (lowlevel.c). */
#ifndef THERMOCUE_LOWLEVEL_H
#define THERMOCUE_LOWLEVEL_H

#include <stdbool.h>
#include <stdint.h>

void stm32_init(void);
uint32_t stm32_core_hz(void);
uint64_t stm32_time_us(void);
uint64_t stm32_systick_us(void);
int stm32_uart_read(void);
bool stm32_uart_tx_ready(void);
void stm32_uart_write(uint8_t b);
void stm32_iwdg_start(void);
void stm32_iwdg_feed(void);
uint32_t stm32_boot_entropy(void);
/* The image's GNU build id in hex (40 characters; "none" without one), for HELLO. */
const char *stm32_image_id(void);
void stm32_reset(void) __attribute__((noreturn));

#endif

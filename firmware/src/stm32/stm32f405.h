/* The few STM32F405 registers the firmware uses (RM0090), as plain addresses: no vendor
 * headers, nothing downloaded. */
#ifndef THERMOCUE_STM32F405_H
#define THERMOCUE_STM32F405_H

#include <stdint.h>

#define REG32(addr) (*(volatile uint32_t *)(uintptr_t)(addr))

/* RCC */
#define RCC_BASE        0x40023800u
#define RCC_CR          REG32(RCC_BASE + 0x00u)
#define RCC_PLLCFGR     REG32(RCC_BASE + 0x04u)
#define RCC_CFGR        REG32(RCC_BASE + 0x08u)
#define RCC_AHB1ENR     REG32(RCC_BASE + 0x30u)
#define RCC_APB1ENR     REG32(RCC_BASE + 0x40u)
#define RCC_APB2ENR     REG32(RCC_BASE + 0x44u)
#define RCC_CSR         REG32(RCC_BASE + 0x74u)
#define FLASH_ACR       REG32(0x40023C00u)

/* GPIO ports A, B, C */
#define GPIOA_BASE      0x40020000u
#define GPIOB_BASE      0x40020400u
#define GPIOC_BASE      0x40020800u
#define GPIO_MODER(b)   REG32((b) + 0x00u)
#define GPIO_OTYPER(b)  REG32((b) + 0x04u)
#define GPIO_OSPEEDR(b) REG32((b) + 0x08u)
#define GPIO_PUPDR(b)   REG32((b) + 0x0Cu)
#define GPIO_IDR(b)     REG32((b) + 0x10u)
#define GPIO_ODR(b)     REG32((b) + 0x14u)
#define GPIO_BSRR(b)    REG32((b) + 0x18u)
#define GPIO_AFRL(b)    REG32((b) + 0x20u)
#define GPIO_AFRH(b)    REG32((b) + 0x24u)

/* USART1 (APB2) */
#define USART1_BASE     0x40011000u
#define USART_SR(b)     REG32((b) + 0x00u)
#define USART_DR(b)     REG32((b) + 0x04u)
#define USART_BRR(b)    REG32((b) + 0x08u)
#define USART_CR1(b)    REG32((b) + 0x0Cu)
#define USART_SR_RXNE   (1u << 5)
#define USART_SR_TXE    (1u << 7)
#define USART_SR_ORE    (1u << 3)
#define USART_CR1_UE    (1u << 13)
#define USART_CR1_TE    (1u << 3)
#define USART_CR1_RE    (1u << 2)

/* ADC1 (APB2) */
#define ADC1_BASE       0x40012000u
#define ADC_SR          REG32(ADC1_BASE + 0x00u)
#define ADC_CR1         REG32(ADC1_BASE + 0x04u)
#define ADC_CR2         REG32(ADC1_BASE + 0x08u)
#define ADC_SMPR1       REG32(ADC1_BASE + 0x0Cu)
#define ADC_SMPR2       REG32(ADC1_BASE + 0x10u)
#define ADC_SQR1        REG32(ADC1_BASE + 0x2Cu)
#define ADC_SQR3        REG32(ADC1_BASE + 0x34u)
#define ADC_DR          REG32(ADC1_BASE + 0x4Cu)
#define ADC_CCR         REG32(0x40012304u)   /* common: ADCPRE bits 17:16 */
#define ADC_SR_EOC      (1u << 1)
#define ADC_CR2_ADON    (1u << 0)
#define ADC_CR2_SWSTART (1u << 30)

/* TIM1 (APB2): the H-bridge PWM on CH1 (PA8) */
#define TIM1_BASE       0x40010000u
#define TIM_CR1(b)      REG32((b) + 0x00u)
#define TIM_EGR(b)      REG32((b) + 0x14u)
#define TIM_CCMR1(b)    REG32((b) + 0x18u)
#define TIM_CCER(b)     REG32((b) + 0x20u)
#define TIM_PSC(b)      REG32((b) + 0x28u)
#define TIM_ARR(b)      REG32((b) + 0x2Cu)
#define TIM_CCR1(b)     REG32((b) + 0x34u)
#define TIM_BDTR(b)     REG32((b) + 0x44u)

/* TIM2 (APB1, 32 bits): the free-running microsecond time base */
#define TIM2_BASE       0x40000000u
#define TIM_CNT(b)      REG32((b) + 0x24u)

/* Independent watchdog */
#define IWDG_KR         REG32(0x40003000u)
#define IWDG_PR         REG32(0x40003004u)
#define IWDG_RLR        REG32(0x40003008u)

/* Random number generator (AHB2), unique device id */
#define RNG_CR          REG32(0x50060800u)
#define RNG_SR          REG32(0x50060804u)
#define RNG_DR          REG32(0x50060808u)
#define RCC_AHB2ENR     REG32(RCC_BASE + 0x34u)
#define UID_BASE        0x1FFF7A10u

/* Cortex-M4 core */
#define SYST_CSR        REG32(0xE000E010u)
#define SYST_RVR        REG32(0xE000E014u)
#define SYST_CVR        REG32(0xE000E018u)
#define SCB_ICSR        REG32(0xE000ED04u)
#define SCB_AIRCR       REG32(0xE000ED0Cu)
#define SCB_ICSR_PENDSTSET (1u << 26)

#endif

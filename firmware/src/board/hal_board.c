/* The board HAL: an STM32F405 board (e.g. Olimex STM32-H405) wired as firmware/README.md and
 * firmware/wiring.png show.
 *
 *   PA0  ADC1_IN0  contact thermistor (10 kΩ NTC, B 3950, 10 kΩ to 3.3 V)
 *   PA1  ADC1_IN1  ambient thermistor (same divider)
 *   PA2  ADC1_IN2  IR thermometer, analog output 0..3.3 V = 0..50 °C
 *   PA3  ADC1_IN3  heat-sink thermistor (same divider)
 *   PA4  ADC1_IN4  sample thermometer (record mode; same divider)
 *   PA5, PA6, PA7, PB0  ADC1_IN5..IN8  force sensors 1..4 (load cell + INA125, 0..3.3 V = 0..10 N)
 *   PA8  TIM1_CH1  H-bridge PWM (20 kHz), PB1 direction (high = heating), PB2 relay (high =
 *        closed), PB10 fan (high = on). Every output resets low: a reset opens the relay.
 *   PA9/PA10 USART1 TX/RX to a 3.3 V USB-serial adapter, 115200 8N1. */
#include <math.h>

#include "hal.h"
#include "lowlevel.h"
#include "stm32f405.h"

#define PWM_ARR 4199u                /* 84 MHz (TIM1 on APB2 x2 = 168 MHz) / 2 / 4200 = 20 kHz */
#define OVERSAMPLE 16u               /* 16 conversions summed: 16-bit codes with dither */
#define FULL_SCALE (4095.0f * OVERSAMPLE)

static void gpio_output(uint32_t base, unsigned pin)
{
    GPIO_BSRR(base) = 1u << (pin + 16u);
    GPIO_MODER(base) = (GPIO_MODER(base) & ~(3u << (2u * pin))) | (1u << (2u * pin));
}

static void gpio_write(uint32_t base, unsigned pin, bool high)
{
    GPIO_BSRR(base) = high ? 1u << pin : 1u << (pin + 16u);
}

void hal_init(void)
{
    stm32_init();
    gpio_output(GPIOB_BASE, 1);
    gpio_output(GPIOB_BASE, 2);
    gpio_output(GPIOB_BASE, 10);
    /* analog inputs PA0..PA7, PB0 */
    GPIO_MODER(GPIOA_BASE) |= 0xFFFFu;
    GPIO_MODER(GPIOB_BASE) |= 3u;
    RCC_APB2ENR |= (1u << 8) | (1u << 0);        /* ADC1, TIM1 */
    ADC_CCR = 1u << 16;                          /* ADC clock APB2 / 4 = 21 MHz (max 36) */
    ADC_CR1 = 0;
    ADC_SMPR2 = 0x3FFFFFFFu;                     /* 480 cycles on IN0..IN9 */
    ADC_SQR1 = 0;                                /* one conversion */
    ADC_CR2 = ADC_CR2_ADON;
    /* TIM1 CH1 PWM mode 1 on PA8 (AF1) */
    GPIO_MODER(GPIOA_BASE) = (GPIO_MODER(GPIOA_BASE) & ~(3u << 16)) | (2u << 16);
    GPIO_AFRH(GPIOA_BASE) = (GPIO_AFRH(GPIOA_BASE) & ~0xFu) | 1u;
    TIM_PSC(TIM1_BASE) = 1u;
    TIM_ARR(TIM1_BASE) = PWM_ARR;
    TIM_CCR1(TIM1_BASE) = 0;
    TIM_CCMR1(TIM1_BASE) = (6u << 4) | (1u << 3);
    TIM_CCER(TIM1_BASE) = 1u;
    TIM_BDTR(TIM1_BASE) = 1u << 15;              /* main output enable */
    TIM_EGR(TIM1_BASE) = 1u;
    TIM_CR1(TIM1_BASE) = 1u;
}

uint64_t hal_time_us(void) { return stm32_time_us(); }
int hal_uart_read(void) { return stm32_uart_read(); }
bool hal_uart_tx_ready(void) { return stm32_uart_tx_ready(); }
void hal_uart_write(uint8_t b) { stm32_uart_write(b); }

/* One channel, OVERSAMPLE conversions summed. A conversion that never ends marks the ADC dead:
 * every channel then reads 0, which the core takes as a sensor failure (latched), without
 * waiting for the ADC again (QEMU's model of this ADC never ends a conversion). */
static bool adc_dead;

static uint32_t adc_read(unsigned ch)
{
    uint32_t sum = 0;
    if (adc_dead) return 0;
    ADC_SQR3 = ch;
    for (unsigned k = 0; k < OVERSAMPLE; k++) {
        ADC_SR = 0;
        ADC_CR2 |= ADC_CR2_SWSTART;
        uint32_t i = 0;
        while (!(ADC_SR & ADC_SR_EOC) && i < 10000u) i++;
        if (i >= 10000u) {
            adc_dead = true;
            return 0;
        }
        sum += ADC_DR & 0xFFFu;
    }
    return sum;
}

/* NTC in a divider (10 kΩ to 3.3 V, NTC to ground): B-parameter equation. */
static float ntc_C(uint32_t code)
{
    if (code == 0 || code >= (uint32_t)FULL_SCALE) return -273.15f;   /* short or open */
    float r = 10000.0f * (float)code / (FULL_SCALE - (float)code);
    return 1.0f / (1.0f / 298.15f + logf(r / 10000.0f) / 3950.0f) - 273.15f;
}

void hal_read_sensors(hal_sensors_t *out)
{
    uint32_t raw = adc_read(0);
    out->contact_raw = raw;
    out->contact_C = ntc_C(raw);
    out->ambient_C = ntc_C(adc_read(1));
    out->finger_C = 50.0f * (float)adc_read(2) / FULL_SCALE;
    out->heatsink_C = ntc_C(adc_read(3));
    out->sample_C = ntc_C(adc_read(4));
    for (unsigned i = 0; i < 4; i++)
        out->force_N[i] = 10.0f * (float)adc_read(5u + i) / FULL_SCALE;
}

void hal_set_peltier(float drive)
{
    float d = drive < 0.0f ? -drive : drive;
    if (d > 1.0f) d = 1.0f;
    gpio_write(GPIOB_BASE, 1, drive > 0.0f);
    TIM_CCR1(TIM1_BASE) = (uint32_t)(d * (float)PWM_ARR);
}

void hal_set_relay(bool closed) { gpio_write(GPIOB_BASE, 2, closed); }
void hal_set_fan(bool on) { gpio_write(GPIOB_BASE, 10, on); }
void hal_iwdg_start(void) { stm32_iwdg_start(); }
void hal_iwdg_feed(void) { stm32_iwdg_feed(); }
uint32_t hal_boot_entropy(void) { return stm32_boot_entropy(); }
void hal_reset(void) { stm32_reset(); }

int hal_board_command(uint8_t type, const uint8_t *payload, size_t len, uint8_t *reply,
                      size_t cap, int core_state, bool ready)
{
    (void)type; (void)payload; (void)len; (void)core_state; (void)ready;
    const char *t = "not an emulator";
    size_t n = 0;
    while (t[n] && n + 1 < cap) { reply[n] = (uint8_t)t[n]; n++; }
    reply[n] = 0;
    return -8;                                   /* NOT_SUPPORTED */
}

const char *hal_capabilities(void) { return ""; }
const char *hal_device_id(void) { return "THERMOCUE-F405"; }
const char *hal_image_id(void) { return stm32_image_id(); }
void hal_on_ready(void) { }
void hal_on_arm(int mode) { (void)mode; }

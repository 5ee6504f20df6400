/* STM32F405 parts both images share: clock, SysTick time base, USART1, independent watchdog,
 * reset, boot entropy. */
#include "lowlevel.h"

#include "stm32f405.h"

static volatile uint64_t systick_ms;
static uint32_t reload;
static uint32_t tim2_last;       /* the time base's last reading, and its wraps */
static uint64_t tim2_high;
static uint32_t timer_entropy;
static uint32_t core_hz;
static bool emulated;            /* no clock controller answers: QEMU's netduinoplus2 */
__attribute__((section(".noinit"))) static uint32_t boot_counter;

void stm32_systick_handler(void)
{
    systick_ms++;
}

/* 168 MHz from an 8 MHz crystal (HSE -> PLL), APB1 42 MHz, APB2 84 MHz. An emulator without a
 * clock controller (QEMU's netduinoplus2: RCC reads 0) runs its SysTick at its own 168 MHz. */
static void clock_init(void)
{
    core_hz = 168000000u;
    emulated = RCC_CR == 0u;                     /* a real RCC resets with HSION, HSIRDY set */
    if (emulated)
        return;                                  /* emulated: the clocks are what QEMU gives */
    RCC_CR |= 1u << 16;                          /* HSEON */
    for (uint32_t i = 0; i < 1000000u && !(RCC_CR & (1u << 17)); i++) { }
    if (!(RCC_CR & (1u << 17))) {
        core_hz = 16000000u;                     /* no crystal: stay on the 16 MHz HSI */
        return;
    }
    /* PLL: M 8, N 336, P 2, Q 7, source HSE */
    RCC_PLLCFGR = 8u | (336u << 6) | (0u << 16) | (1u << 22) | (7u << 24);
    RCC_CR |= 1u << 24;                          /* PLLON */
    for (uint32_t i = 0; i < 1000000u && !(RCC_CR & (1u << 25)); i++) { }
    if (!(RCC_CR & (1u << 25))) {
        core_hz = 16000000u;
        return;
    }
    FLASH_ACR = 5u | (1u << 8) | (1u << 9) | (1u << 10);   /* 5 wait states, caches */
    RCC_CFGR = (RCC_CFGR & ~0xFCF3u) | (5u << 10) | (4u << 13) | 2u;  /* APB1 /4, APB2 /2, PLL */
    for (uint32_t i = 0; i < 1000000u && ((RCC_CFGR >> 2) & 3u) != 2u; i++) { }
}

uint32_t stm32_core_hz(void) { return core_hz; }

void stm32_init(void)
{
    clock_init();
    boot_counter++;
    /* SysTick: 1 ms from the core clock */
    reload = core_hz / 1000u - 1u;
    SYST_RVR = reload;
    SYST_CVR = 0;
    SYST_CSR = 7u;                               /* core clock, interrupt, enable */
    /* TIM2: a free-running 32-bit count of microseconds, the firmware's clock. Its count is
     * read, never interrupted for, so a late or lost interrupt cannot slow the clock (QEMU's
     * SysTick loses periods when its host thread is held off). Timer clock: 84 MHz on the
     * board (APB1 42 MHz x 2); QEMU's model clocks its timers at 1 GHz. */
    RCC_APB1ENR |= 1u;                           /* TIM2 */
    /* entropy first: the undivided count sampled across a busy loop (the phase of the crystal
     * against the core on a board; the host's scheduling under QEMU) */
    TIM_PSC(TIM2_BASE) = 0u;
    TIM_ARR(TIM2_BASE) = 0xFFFFFFFFu;
    TIM_EGR(TIM2_BASE) = 1u;
    TIM_CR1(TIM2_BASE) = 1u;
    for (uint32_t i = 0; i < 20000u; i++)
        timer_entropy = (timer_entropy << 5 | timer_entropy >> 27) ^ TIM_CNT(TIM2_BASE);
    TIM_CR1(TIM2_BASE) = 0u;
    TIM_CNT(TIM2_BASE) = 0u;
    TIM_PSC(TIM2_BASE) = emulated ? 999u : (core_hz == 168000000u ? 83u : 15u);
    TIM_ARR(TIM2_BASE) = 0xFFFFFFFFu;
    TIM_EGR(TIM2_BASE) = 1u;                     /* load the prescaler */
    TIM_CR1(TIM2_BASE) = 1u;
    tim2_last = TIM_CNT(TIM2_BASE);
    /* USART1 on PA9 (TX) / PA10 (RX), AF7, 115200 8N1 */
    RCC_AHB1ENR |= 1u | 2u | 4u;                 /* GPIOA, GPIOB, GPIOC */
    RCC_APB2ENR |= 1u << 4;                      /* USART1 */
    GPIO_MODER(GPIOA_BASE) = (GPIO_MODER(GPIOA_BASE) & ~(0xFu << 18)) | (0xAu << 18);
    GPIO_AFRH(GPIOA_BASE) = (GPIO_AFRH(GPIOA_BASE) & ~(0xFFu << 4)) | (0x77u << 4);
    uint32_t apb2 = core_hz == 168000000u ? 84000000u : core_hz;
    USART_BRR(USART1_BASE) = (apb2 + 57600u) / 115200u;
    USART_CR1(USART1_BASE) = USART_CR1_UE | USART_CR1_TE | USART_CR1_RE;
}

uint64_t stm32_time_us(void)
{
    uint32_t c = TIM_CNT(TIM2_BASE);
    if (c < tim2_last) tim2_high += 1ull << 32;  /* read far more often than every 71 min */
    tim2_last = c;
    return tim2_high | c;
}

/* SysTick's millisecond count (kept for the loop's jitter figure, see README). */
uint64_t stm32_systick_us(void)
{
    uint64_t ms;
    uint32_t val;
    __asm volatile("cpsid i" ::: "memory");
    ms = systick_ms;
    val = SYST_CVR;
    if (SCB_ICSR & SCB_ICSR_PENDSTSET) {         /* wrapped, interrupt not yet taken */
        val = SYST_CVR;
        ms++;
    }
    __asm volatile("cpsie i" ::: "memory");
    uint32_t sub = (uint32_t)(((uint64_t)(reload - val) * 1000u) / (reload + 1u));
    return ms * 1000u + sub;
}

int stm32_uart_read(void)
{
    uint32_t sr = USART_SR(USART1_BASE);
    if (sr & USART_SR_RXNE)
        return (int)(USART_DR(USART1_BASE) & 0xFFu);
    if (sr & USART_SR_ORE)
        (void)USART_DR(USART1_BASE);             /* clear an overrun (the CRC catches the loss) */
    return -1;
}

bool stm32_uart_tx_ready(void) { return (USART_SR(USART1_BASE) & USART_SR_TXE) != 0; }
void stm32_uart_write(uint8_t b) { USART_DR(USART1_BASE) = b; }

/* IWDG: LSI ~32 kHz / 4 = 8 kHz, reload 400: ~50 ms without a feed restarts the MCU (and
 * a restart opens the relay: its GPIO resets low). */
void stm32_iwdg_start(void)
{
    IWDG_KR = 0x5555u;
    IWDG_PR = 0u;
    IWDG_RLR = 400u;
    IWDG_KR = 0xCCCCu;
    IWDG_KR = 0xAAAAu;
}

void stm32_iwdg_feed(void) { IWDG_KR = 0xAAAAu; }

uint32_t stm32_boot_entropy(void)
{
    static uint32_t calls;
    uint32_t e = boot_counter * 0x9E3779B9u ^ SYST_CVR ^ (calls++ << 16) ^ timer_entropy;
    if (emulated)                                /* QEMU maps neither the unique id nor */
        return e;                                /* the RNG (a bus fault): SysTick's phase */
    e ^= REG32(UID_BASE) ^ REG32(UID_BASE + 4u) ^ REG32(UID_BASE + 8u);
    RCC_AHB2ENR |= 1u << 6;                      /* the hardware RNG */
    RNG_CR = 1u << 2;
    for (uint32_t i = 0; i < 1000u && !(RNG_SR & 1u); i++) { }
    if (RNG_SR & 1u) e ^= RNG_DR;
    return e;
}

void stm32_reset(void)
{
    SCB_AIRCR = (0x5FAu << 16) | (1u << 2);      /* SYSRESETREQ */
    for (;;) { }
}

/* The linker's build-id note: namesz u32, descsz u32, type u32, "GNU\0", then the id's bytes. */
extern const uint8_t _build_id_note[];

const char *stm32_image_id(void)
{
    static char hex[2 * 32 + 1];
    static const char digits[] = "0123456789abcdef";
    const uint32_t *w = (const uint32_t *)(const void *)_build_id_note;
    uint32_t namesz = w[0], descsz = w[1];
    if (w[2] != 3u || namesz != 4u || descsz == 0u || descsz > 32u) {
        return "none";
    }
    const uint8_t *id = _build_id_note + 12 + 4;
    for (uint32_t i = 0; i < descsz; i++) {
        hex[2 * i] = digits[id[i] >> 4];
        hex[2 * i + 1] = digits[id[i] & 15u];
    }
    hex[2 * descsz] = 0;
    return hex;
}

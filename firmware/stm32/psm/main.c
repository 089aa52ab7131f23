/* PSM 16x16 on the BluePill (docs/spec.md §5): the TIM2 IRQ scans and sends (Code 2.4), the main
 * loop feeds host bytes to the command parser. */
#include "adc.h"
#include "clock.h"
#include "hal.h"
#include "link.h"
#include "micros.h"
#include "mux.h"
#include "psm_core.h"
#include "regs.h"
#include "tick.h"
#include "uid.h"

/* The scan timer sits between the two links (README "Pins and links"): below the USART
 * (0x40), whose 1-byte data register must be served every 10 us even mid-scan, and above
 * the USB (0xC0), whose endpoints NAK the host until served, so USB never stretches a scan. */
#define TICK_IRQ_PRIORITY 0x80u
#define LED_PIN 13u             /* PC13, toggled per scan as in Code 2.4 */

static psm_core core;

void tick_irq(void)
{
    GPIOC->ODR ^= 1u << LED_PIN;
    psm_on_tick(&core);
}

/* Sleeps unless a byte arrived after link_read looked (PRIMASK closes that window; WFI
 * still wakes on the pending interrupt). */
static void sleep_until_rx(void)
{
    __asm volatile("cpsid i" ::: "memory");
    if (!link_rx_pending())
        __asm volatile("wfi");
    __asm volatile("cpsie i" ::: "memory");
}

int main(void)
{
    char serial[9];
    uint8_t rx[32];

    clock_init();
    micros_init();
    RCC->APB2ENR |= RCC_APB2_IOPC;
    gpio_config(GPIOC, LED_PIN, GPIO_OUT_PP_2MHZ);
    mux_init();
    adc_init();
    uid_serial(serial);
    link_init("psmat PSM 16x16", serial);
    psm_init(&core, &bluepill_psm_hal, 16, 16, PM_PROTO_V2, serial);
    tick_init(PSM_DEFAULT_RATE_HZ, TICK_IRQ_PRIORITY);

    for (;;) {
        size_t n = link_read(rx, sizeof rx);
        if (!n) {
            sleep_until_rx();
            continue;
        }
        /* keep the scan IRQ out while a command changes the core's state (this also holds
         * off the USB interrupt, which is below it; a command takes microseconds) */
        set_basepri(TICK_IRQ_PRIORITY);
        psm_on_rx(&core, rx, n);
        set_basepri(0);
    }
}

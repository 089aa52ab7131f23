/* Spine IMU DAQ on the BluePill (docs/spec.md §5): TIM2 at 10 Hz raises a flag; the main loop reads
 * the sensors (I2C is too slow for an IRQ) and handles host commands. */
#include "clock.h"
#include "hal.h"
#include "imu_core.h"
#include "link.h"
#include "micros.h"
#include "tick.h"
#include "uid.h"

#define TICK_IRQ_PRIORITY 0x80u

static imu_core core;
static volatile uint8_t tick_due;

void tick_irq(void) { tick_due = 1; }

int main(void)
{
    uint8_t rx[32];
    char serial[9];
    clock_init();
    micros_init();
    uid_serial(serial);
    link_init("psmat IMU 5xBNO055", serial);
    hal_sensors_init();
    imu_init(&core, &bluepill_imu_hal, PM_PROTO_V2, serial);
    tick_init(IMU_DEFAULT_RATE_HZ, TICK_IRQ_PRIORITY);

    for (;;) {
        size_t n = link_read(rx, sizeof rx);
        if (n)
            imu_on_rx(&core, rx, n);
        if (tick_due) {
            tick_due = 0;
            imu_on_tick(&core);
        }
        /* sleep unless work arrived meanwhile (PRIMASK closes the window, WFI still wakes) */
        __asm volatile("cpsid i" ::: "memory");
        if (!link_rx_pending() && !tick_due)
            __asm volatile("wfi");
        __asm volatile("cpsie i" ::: "memory");
    }
}

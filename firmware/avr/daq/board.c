/* Nano Every peripherals for the material DAQ (thesis §2.4.1). */
#include "board.h"

#include "regs.h"

/* Sensors 0..9 -> analog inputs: A0-A7 (PD3 PD2 PD1 PD0 PF2 PF3 PD4 PD5), D11 (PE0), D12 (PE1) */
static const uint8_t ain[10] = {3, 2, 1, 0, 12, 13, 4, 5, 8, 9};
static volatile uint8_t tick_due;

void __vector_4(void) __attribute__((signal, used)); /* RTC_PIT */
void VECTOR_RTC_PIT(void)
{
    RTC_PITINTFLAGS = RTC_PI;
    tick_due = 1;
}

static void clock_init(void)
{
    /* protected write (CCP): main clock prescaler off, 16 MHz instead of 16/6 */
    __asm volatile("sts %0, %1\n\tsts %2, __zero_reg__"
                   :
                   : "n"(0x0034), "r"((uint8_t)CCP_IOREG), "n"(CLKCTRL_MCLKCTRLB_ADDR));
}

static void usart_init(void)
{
    PORTMUX_USARTROUTEA = PORTMUX_USART3_ALT1;
    PORT_DIRSET(PORTB) = 1u << 4;                              /* TX */
    USART_BAUD = (uint16_t)((4ul * F_CPU_HZ + DAQ_BAUD / 2) / DAQ_BAUD); /* 64 f / (16 baud) */
    USART_CTRLB = USART_RXEN | USART_TXEN;                     /* 8N1 is the reset state */
}

static void adc_init(void)
{
    for (uint8_t n = 0; n <= 5; n++)
        PORT_PINCTRL(PORTD, n) = PORT_ISC_INPUT_DISABLE;
    PORT_PINCTRL(PORTF, 2) = PORT_ISC_INPUT_DISABLE;
    PORT_PINCTRL(PORTF, 3) = PORT_ISC_INPUT_DISABLE;
    PORT_PINCTRL(PORTE, 0) = PORT_ISC_INPUT_DISABLE;
    PORT_PINCTRL(PORTE, 1) = PORT_ISC_INPUT_DISABLE;
    ADC_CTRLC = ADC_SAMPCAP | ADC_REFSEL_VDD | ADC_PRESC_DIV16; /* 1 MHz ADC clock */
    ADC_CTRLA = ADC_ENABLE;                                     /* 10-bit */
}

static void tick_init(void)
{
    RTC_CLKSEL = 0; /* internal 32.768 kHz */
    while (RTC_PITSTATUS) {
    }
    RTC_PITINTCTRL = RTC_PI;
    RTC_PITCTRLA = RTC_PIT_CYC16384 | RTC_PITEN;
}

void board_init(void)
{
    clock_init();
    usart_init();
    adc_init();
    tick_init();
    __asm volatile("sei");
}

void usart_put(uint8_t byte)
{
    while (!(USART_STATUS & USART_DREIF)) {
    }
    USART_TXDATAL = byte;
}

int usart_get(uint8_t *byte)
{
    if (!(USART_STATUS & USART_RXCIF))
        return 0;
    *byte = USART_RXDATAL;
    return 1;
}

uint16_t adc_read_sensor(uint8_t sensor)
{
    ADC_MUXPOS = ain[sensor];
    ADC_COMMAND = ADC_STCONV;
    while (!(ADC_INTFLAGS & ADC_RESRDY)) {
    }
    return ADC_RES; /* reading RES clears RESRDY */
}

uint8_t tick_take(void)
{
    uint8_t due;
    __asm volatile("cli" ::: "memory");
    due = tick_due;
    tick_due = 0;
    __asm volatile("sei" ::: "memory");
    return due;
}

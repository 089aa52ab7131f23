/* STM32F103 register definitions, written from RM0008 (rev 21) for the peripherals this
 * firmware uses; no vendor headers. Offsets are in the struct layouts. */
#ifndef PSMAT_STM32_REGS_H
#define PSMAT_STM32_REGS_H

#include <stdint.h>

#define REG volatile uint32_t

typedef struct { REG CR, CFGR, CIR, APB2RSTR, APB1RSTR, AHBENR, APB2ENR, APB1ENR, BDCR, CSR; } rcc_regs;
typedef struct { REG ACR; } flash_regs;
typedef struct { REG CRL, CRH, IDR, ODR, BSRR, BRR, LCKR; } gpio_regs;
typedef struct { REG EVCR, MAPR; } afio_regs;
typedef struct {
    REG CR1, CR2, SMCR, DIER, SR, EGR, CCMR1, CCMR2, CCER, CNT, PSC, ARR;
} tim_regs;
typedef struct {
    REG SR, CR1, CR2, SMPR1, SMPR2, JOFR[4], HTR, LTR, SQR1, SQR2, SQR3, JSQR, JDR[4], DR;
} adc_regs;
typedef struct { REG SR, DR, BRR, CR1, CR2, CR3, GTPR; } usart_regs;

#define RCC ((rcc_regs *)0x40021000u)
#define FLASH ((flash_regs *)0x40022000u)
#define AFIO ((afio_regs *)0x40010000u)
#define GPIOA ((gpio_regs *)0x40010800u)
#define GPIOB ((gpio_regs *)0x40010C00u)
#define GPIOC ((gpio_regs *)0x40011000u)
#define TIM2 ((tim_regs *)0x40000000u)
#define TIM3 ((tim_regs *)0x40000400u)
#define TIM4 ((tim_regs *)0x40000800u)
#define ADC1 ((adc_regs *)0x40012400u)
#define USART1 ((usart_regs *)0x40013800u)
#define UID ((volatile const uint32_t *)0x1FFFF7E8u) /* 96-bit unique device ID */

/* RCC bits */
#define RCC_CR_HSEON (1u << 16)
#define RCC_CR_HSERDY (1u << 17)
#define RCC_CR_PLLON (1u << 24)
#define RCC_CR_PLLRDY (1u << 25)
#define RCC_APB2_AFIO (1u << 0)
#define RCC_APB2_IOPA (1u << 2)
#define RCC_APB2_IOPB (1u << 3)
#define RCC_APB2_IOPC (1u << 4)
#define RCC_APB2_ADC1 (1u << 9)
#define RCC_APB2_USART1 (1u << 14)
#define RCC_APB1_TIM2 (1u << 0)
#define RCC_APB1_TIM3 (1u << 1)
#define RCC_APB1_TIM4 (1u << 2)

/* TIMx */
#define TIM_CR1_CEN (1u << 0)
#define TIM_CR1_URS (1u << 2)
#define TIM_DIER_UIE (1u << 0)
#define TIM_SR_UIF (1u << 0)
#define TIM_EGR_UG (1u << 0)

/* ADC */
#define ADC_SR_EOC (1u << 1)
#define ADC_CR2_ADON (1u << 0)
#define ADC_CR2_CAL (1u << 2)
#define ADC_CR2_RSTCAL (1u << 3)
#define ADC_CR2_EXTSEL_SWSTART (7u << 17)
#define ADC_CR2_EXTTRIG (1u << 20)
#define ADC_CR2_SWSTART (1u << 22)

/* USART */
#define USART_SR_ORE (1u << 3)
#define USART_SR_RXNE (1u << 5)
#define USART_SR_TXE (1u << 7)
#define USART_CR1_RE (1u << 2)
#define USART_CR1_TE (1u << 3)
#define USART_CR1_RXNEIE (1u << 5)
#define USART_CR1_TXEIE (1u << 7)
#define USART_CR1_UE (1u << 13)

/* GPIO CRL/CRH nibbles (MODE | CNF << 2) */
#define GPIO_ANALOG 0x0u
#define GPIO_IN_FLOAT 0x4u
#define GPIO_IN_PULL 0x8u
#define GPIO_OUT_PP_2MHZ 0x2u
#define GPIO_OUT_OD_2MHZ 0x6u
#define GPIO_AF_PP_50MHZ 0xBu

/* NVIC (Cortex-M3) */
#define NVIC_ISER ((volatile uint32_t *)0xE000E100u)
#define NVIC_IPR ((volatile uint8_t *)0xE000E400u)
#define IRQ_TIM2 28u
#define IRQ_USART1 37u

/* Sets the 4-bit configuration nibble of one pin (0..15) of a port. */
static inline void gpio_config(gpio_regs *port, unsigned pin, uint32_t nibble)
{
    volatile uint32_t *cr = pin < 8u ? &port->CRL : &port->CRH;
    unsigned shift = 4u * (pin & 7u);
    *cr = (*cr & ~(0xFu << shift)) | (nibble << shift);
}

static inline void nvic_enable(unsigned irq, uint8_t priority)
{
    NVIC_IPR[irq] = priority;
    NVIC_ISER[irq / 32u] = 1u << (irq % 32u);
}

/* Masks interrupts of priority value >= level (0 unmasks all). */
static inline void set_basepri(uint32_t level)
{
    __asm volatile("msr basepri, %0" : : "r"(level) : "memory");
}

#endif

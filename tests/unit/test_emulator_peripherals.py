"""The STM32F103 peripheral models, driven register by register without a CPU.

A small stand-in machine (emulated time set by hand, recorded interrupts) holds the real models;
the sequences are those of firmware/stm32/common (clock.c, micros.c, tick.c, uart.c) and
firmware/stm32/psm (adc.c, mux.c). Expected values are worked by hand from RM0008: HSE 8 MHz ×
6 = SYSCLK 48 MHz, APB1 /2 = 24 MHz (timers × 2 = 48 MHz), APB2 /1 = 48 MHz, ADC /4 = 12 MHz.
"""

from __future__ import annotations

import pytest

from psmat.emulator import PERIPHERAL_CLASSES, Misuse, UnmodelledAccess

US = 1e-6


class StandIn:
    """The machine services the models use: now_s, pc, fail, nvic, rcc, peripheral, hse_hz, uid."""

    def __init__(self) -> None:
        self.now_s = 0.0
        self.pc = 0x08000200
        self.hse_hz = 8e6
        self.uid = (0x12345678, 0x9ABCDEF0, 0x0F1E2D3C)
        self.pending: list[int] = []
        self.nvic = self
        self.models = {}
        for cls in PERIPHERAL_CLASSES:
            model = cls(self)
            self.models[model.name] = model
        self.rcc = self.models["RCC"]

    def set_pending(self, irq: int) -> None:
        self.pending.append(irq)

    def fail(self, cls: type[Exception], text: str) -> None:
        raise cls(f"{text} at PC 0x{self.pc:08X}")

    def peripheral(self, name: str):
        return self.models[name]

    def at(self, t_s: float) -> None:
        """Emulated time jumps to ``t_s``; every model is brought up to it."""
        self.now_s = t_s
        for model in self.models.values():
            model.advance(t_s)

    def r(self, name: str, offset: int) -> int:
        return self.models[name].read(offset, 4)

    def w(self, name: str, offset: int, value: int) -> None:
        self.models[name].write(offset, 4, value)

    def set_bits(self, name: str, offset: int, bits: int) -> None:
        self.w(name, offset, self.r(name, offset) | bits)


# RM0008 register offsets and bits, written out here (not taken from the models).
RCC_CR, RCC_CFGR, RCC_APB2ENR, RCC_APB1ENR = 0x00, 0x04, 0x18, 0x1C
HSEON, HSERDY, PLLON, PLLRDY = 1 << 16, 1 << 17, 1 << 24, 1 << 25
CLOCK_C_CFGR = (1 << 22) | (4 << 18) | (1 << 16) | (1 << 14) | (4 << 8)
TIM_CR1, TIM_CR2, TIM_SMCR, TIM_DIER, TIM_SR, TIM_EGR, TIM_CNT, TIM_PSC, TIM_ARR = (
    0x00, 0x04, 0x08, 0x0C, 0x10, 0x14, 0x24, 0x28, 0x2C)
ADC_SR, ADC_CR2, ADC_SMPR2, ADC_SQR1, ADC_SQR3, ADC_DR = 0x00, 0x08, 0x10, 0x2C, 0x34, 0x4C
ADON, CAL, RSTCAL, EXTSEL_SW, EXTTRIG, SWSTART = 1, 1 << 2, 1 << 3, 7 << 17, 1 << 20, 1 << 22
U_SR, U_DR, U_BRR, U_CR1 = 0x00, 0x04, 0x08, 0x0C
UE, TE, RE, RXNEIE, TXEIE = 1 << 13, 1 << 3, 1 << 2, 1 << 5, 1 << 7
TXE, TC, RXNE, ORE = 1 << 7, 1 << 6, 1 << 5, 1 << 3
GPIO_CRL, GPIO_CRH, GPIO_IDR, GPIO_ODR, GPIO_BSRR, GPIO_BRR = 0x00, 0x04, 0x08, 0x0C, 0x10, 0x14


def clock_init(m: StandIn, *, latency: int = 1, cfgr: int = CLOCK_C_CFGR) -> None:
    """firmware/stm32/common/clock.c, step by step."""
    m.set_bits("RCC", RCC_CR, HSEON)
    assert m.r("RCC", RCC_CR) & HSERDY
    m.w("FLASH", 0x00, (1 << 4) | latency)
    m.w("RCC", RCC_CFGR, cfgr)
    m.set_bits("RCC", RCC_CR, PLLON)
    assert m.r("RCC", RCC_CR) & PLLRDY
    m.set_bits("RCC", RCC_CFGR, 2)
    assert (m.r("RCC", RCC_CFGR) >> 2) & 3 == 2


@pytest.fixture
def m() -> StandIn:
    machine = StandIn()
    clock_init(machine)
    return machine


# -- RCC and FLASH -----------------------------------------------------------------------------


def test_reset_clock_tree_is_hsi_8_mhz() -> None:
    rcc = StandIn().rcc
    assert rcc.clock_hz("SYSCLK") == 8e6
    assert rcc.read(RCC_CR, 4) & 0b11 == 0b11  # HSION, HSIRDY


def test_clock_c_gives_the_documented_tree(m: StandIn) -> None:
    expected = {"SYSCLK": 48e6, "HCLK": 48e6, "PCLK1": 24e6, "TIMCLK1": 48e6, "PCLK2": 48e6,
                "ADCCLK": 12e6, "USBCLK": 48e6}
    assert {k: m.rcc.clock_hz(k) for k in expected} == expected


def test_72_mhz_with_two_wait_states_is_accepted() -> None:
    m = StandIn()
    cfgr = (7 << 18) | (1 << 16) | (2 << 14) | (4 << 8)  # HSE × 9, ADC /6, APB1 /2
    clock_init(m, latency=2, cfgr=cfgr)
    assert (m.rcc.clock_hz("SYSCLK"), m.rcc.clock_hz("PCLK1"), m.rcc.clock_hz("ADCCLK")) == (
        72e6, 36e6, 12e6)


def test_pll_with_too_little_flash_latency_is_misuse() -> None:
    with pytest.raises(Misuse, match=r"SYSCLK 48 MHz needs 1 flash wait states.*LATENCY = 0.*at PC"):
        clock_init(StandIn(), latency=0)


@pytest.mark.parametrize(("pllmul_code", "latency", "needed"), [
    (1, 0, None),  # HSE × 3 = 24 MHz: 0 wait states
    (2, 0, 1),     # × 4 = 32 MHz: 1
    (4, 1, None),  # × 6 = 48 MHz: 1
    (5, 1, 2),     # × 7 = 56 MHz: 2
])
def test_flash_wait_state_boundaries(pllmul_code: int, latency: int, needed: int | None) -> None:
    cfgr = (pllmul_code << 18) | (1 << 16) | (4 << 8)
    if needed is None:
        clock_init(StandIn(), latency=latency, cfgr=cfgr)
    else:
        with pytest.raises(Misuse, match=rf"needs {needed} flash wait states"):
            clock_init(StandIn(), latency=latency, cfgr=cfgr)


def test_pll_above_72_mhz_is_misuse() -> None:
    cfgr = (14 << 18) | (1 << 16) | (4 << 8)  # HSE × 16 = 128 MHz
    with pytest.raises(Misuse, match=r"PLL output 128 MHz exceeds 72 MHz"):
        clock_init(StandIn(), latency=2, cfgr=cfgr)


def test_apb1_above_36_mhz_is_misuse() -> None:
    cfgr = CLOCK_C_CFGR & ~(7 << 8)  # APB1 /1: PCLK1 = 48 MHz
    with pytest.raises(Misuse, match=r"PCLK1 48 MHz exceeds 36 MHz"):
        clock_init(StandIn(), cfgr=cfgr)


def test_switching_to_a_pll_that_is_off_is_misuse() -> None:
    m = StandIn()
    m.w("FLASH", 0, 0x11)
    with pytest.raises(Misuse, match=r"SW selects PLL while it is not ready"):
        m.w("RCC", RCC_CFGR, CLOCK_C_CFGR | 2)


def test_lowering_flash_latency_under_a_fast_sysclk_is_misuse(m: StandIn) -> None:
    with pytest.raises(Misuse, match=r"FLASH: ACR.LATENCY = 0 too low for SYSCLK 48 MHz"):
        m.w("FLASH", 0, 0x10)


def test_pll_config_change_while_pll_on_is_misuse(m: StandIn) -> None:
    with pytest.raises(Misuse, match=r"PLLMUL changed while the PLL is on"):
        m.w("RCC", RCC_CFGR, (m.r("RCC", RCC_CFGR) & ~(0xF << 18)) | (3 << 18))


def test_unmodelled_rcc_register_fails_loudly() -> None:
    with pytest.raises(UnmodelledAccess, match=r"0x40021008.*RCC.CIR not modelled"):
        StandIn().r("RCC", 0x08)


def test_clock_tree_change_while_a_timer_is_clocked_fails_loudly(m: StandIn) -> None:
    m.set_bits("RCC", RCC_APB1ENR, 1)
    with pytest.raises(UnmodelledAccess, match=r"changing PCLK1.*TIM2"):
        m.w("RCC", RCC_CFGR, m.r("RCC", RCC_CFGR) | (1 << 8))  # APB1 /2 -> /4


# -- clocks of every model -------------------------------------------------------------------

# RM0008 §7.3.7, §7.3.8: the enable of each modelled peripheral.
ENABLES = [("AFIO", "APB2ENR", 0), ("GPIOA", "APB2ENR", 2), ("GPIOB", "APB2ENR", 3),
           ("GPIOC", "APB2ENR", 4), ("ADC1", "APB2ENR", 9), ("USART1", "APB2ENR", 14),
           ("TIM2", "APB1ENR", 0), ("TIM3", "APB1ENR", 1), ("TIM4", "APB1ENR", 2)]


@pytest.mark.parametrize(("name", "reg", "bit"), ENABLES)
def test_register_access_with_the_clock_off_is_misuse(m: StandIn, name: str, reg: str, bit: int) -> None:
    with pytest.raises(Misuse, match=rf"^{name}: register read while its clock is off "
                                     rf"\(RCC.{reg} bit {bit}\) at PC 0x08000200$"):
        m.r(name, 0x04)
    m.set_bits("RCC", RCC_APB2ENR if reg == "APB2ENR" else RCC_APB1ENR, 1 << bit)
    m.r(name, 0x04)  # now allowed


# -- AFIO and GPIO -------------------------------------------------------------------------------


def _gpio_config(m: StandIn, port: str, pin: int, nibble: int) -> None:
    """regs.h gpio_config: read-modify-write of CRL/CRH."""
    off = GPIO_CRL if pin < 8 else GPIO_CRH
    shift = 4 * (pin & 7)
    m.w(port, off, (m.r(port, off) & ~(0xF << shift)) | (nibble << shift))


@pytest.mark.parametrize(("port", "pin"), [("GPIOA", 15), ("GPIOB", 3), ("GPIOB", 4)])
def test_jtag_pins_as_outputs_before_swj_cfg_is_misuse(m: StandIn, port: str, pin: int) -> None:
    m.w("RCC", RCC_APB2ENR, 0b11101)
    with pytest.raises(Misuse, match=rf"P{port[-1]}{pin} configured as an output while AFIO MAPR "
                                     r"SWJ_CFG = 000"):
        _gpio_config(m, port, pin, 0x2)


def test_mux_init_frees_the_jtag_pins(m: StandIn) -> None:
    m.w("RCC", RCC_APB2ENR, 0b01101)  # AFIO, IOPA, IOPB
    mapr = m.r("AFIO", 0x04)
    m.w("AFIO", 0x04, (mapr & ~(7 << 24)) | (2 << 24))
    assert m.r("AFIO", 0x04) == 0  # SWJ_CFG is write-only
    for port, pin in (("GPIOA", 15), ("GPIOB", 3), ("GPIOB", 4), ("GPIOB", 12)):
        _gpio_config(m, port, pin, 0x2)
    assert m.models["GPIOA"].pin_mode(15) == "output push-pull"


def test_swj_without_njtrst_frees_pb4_only(m: StandIn) -> None:
    m.w("RCC", RCC_APB2ENR, 0b01101)
    m.w("AFIO", 0x04, 1 << 24)
    _gpio_config(m, "GPIOB", 4, 0x2)
    with pytest.raises(Misuse, match=r"PB3 configured as an output"):
        _gpio_config(m, "GPIOB", 3, 0x2)


def test_bsrr_sets_and_resets_in_one_write_and_calls_the_hooks(m: StandIn) -> None:
    m.w("RCC", RCC_APB2ENR, 0b01000)
    seen = []
    m.models["GPIOB"].on_write.append(lambda *args: seen.append(args))
    m.now_s = 5 * US
    a = 0b1010  # mux_set_row(10)
    m.w("GPIOB", GPIO_BSRR, (a << 12) | ((~a & 0xF) << 28))
    assert m.r("GPIOB", GPIO_ODR) == 0xA000
    a = 0b0101
    m.w("GPIOB", GPIO_BSRR, (a << 12) | ((~a & 0xF) << 28))
    assert m.r("GPIOB", GPIO_ODR) == 0x5000
    m.w("GPIOB", GPIO_BSRR, (1 << 3) | (1 << 19))  # set and reset of PB3: set wins
    m.w("GPIOB", GPIO_BRR, 1 << 12)
    assert m.r("GPIOB", GPIO_ODR) == 0x4008
    assert m.r("GPIOB", GPIO_BSRR) == 0
    assert seen == [("GPIOB", 0, 0xA000, 5 * US), ("GPIOB", 0xA000, 0x5000, 5 * US),
                    ("GPIOB", 0x5000, 0x5008, 5 * US), ("GPIOB", 0x5008, 0x4008, 5 * US)]


def test_idr_follows_configuration_and_board(m: StandIn) -> None:
    m.w("RCC", RCC_APB2ENR, 0b01000)
    gpio = m.models["GPIOB"]
    _gpio_config(m, "GPIOB", 6, 0x6)   # open drain (i2c_soft SCL)
    _gpio_config(m, "GPIOB", 7, 0x6)   # open drain (SDA)
    _gpio_config(m, "GPIOB", 8, 0x8)   # input with pull
    _gpio_config(m, "GPIOB", 9, 0x2)   # push-pull
    _gpio_config(m, "GPIOB", 10, 0x0)  # analog
    m.w("GPIOB", GPIO_BSRR, (1 << 6) | (1 << 7) | (1 << 8) | (1 << 10))
    gpio.set_input(6, 1)  # bus pull-up
    gpio.set_input(7, 0)  # a slave holds SDA low
    gpio.set_input(10, 1)
    idr = m.r("GPIOB", GPIO_IDR)
    assert [idr >> p & 1 for p in (6, 7, 8, 9, 10)] == [1, 0, 1, 0, 0]
    gpio.set_input(8, 0)
    m.w("GPIOB", GPIO_BSRR, 1 << 9)
    idr = m.r("GPIOB", GPIO_IDR)
    assert [idr >> p & 1 for p in (8, 9)] == [0, 1]


def test_unmodelled_alternate_function_fails_loudly(m: StandIn) -> None:
    m.w("RCC", RCC_APB2ENR, 0b01000)
    with pytest.raises(UnmodelledAccess, match=r"PB6 alternate-function push-pull output not modelled"):
        _gpio_config(m, "GPIOB", 6, 0xB)


def test_gpio_lckr_and_reserved_offsets_fail_loudly(m: StandIn) -> None:
    m.w("RCC", RCC_APB2ENR, 0b00100)
    with pytest.raises(UnmodelledAccess, match=r"GPIOA.LCKR not modelled"):
        m.r("GPIOA", 0x18)
    with pytest.raises(UnmodelledAccess, match=r"0x40010820.*reserved offset"):
        m.r("GPIOA", 0x20)


# -- timers -------------------------------------------------------------------------------------


def tick_init(m: StandIn, hz: int) -> None:
    """tick.c: tick_init(hz) with PCLK1 = 24 MHz."""
    m.set_bits("RCC", RCC_APB1ENR, 1)
    m.w("TIM2", TIM_CR1, 1 << 2)  # URS
    count_hz = 1_000_000 if hz >= 16 else 10_000
    m.w("TIM2", TIM_PSC, 2 * 24_000_000 // count_hz - 1)
    m.w("TIM2", TIM_ARR, count_hz // hz - 1)
    m.w("TIM2", TIM_EGR, 1)
    m.w("TIM2", TIM_SR, 0)
    m.w("TIM2", TIM_DIER, 1)
    m.w("TIM2", TIM_CR1, (1 << 2) | 1)


def test_tim2_at_psc_47_arr_9999_updates_every_10_ms(m: StandIn) -> None:
    t0 = 1e-3
    m.at(t0)
    tick_init(m, 100)
    tim = m.models["TIM2"]
    assert m.r("TIM2", TIM_PSC) == 47 and m.r("TIM2", TIM_ARR) == 9999
    assert m.r("TIM2", TIM_SR) & 1 == 0 and m.pending == []  # UG with URS: no UIF
    assert tim.next_event_s() == pytest.approx(t0 + 10_000 * US, abs=1e-12)
    m.at(t0 + 2_500 * US)
    assert m.r("TIM2", TIM_CNT) == 2500
    m.at(t0 + 9_999.9 * US)
    assert m.r("TIM2", TIM_SR) & 1 == 0
    m.at(tim.next_event_s())
    assert m.r("TIM2", TIM_SR) & 1 == 1 and m.pending == [28]
    assert m.r("TIM2", TIM_CNT) == 0
    m.w("TIM2", TIM_SR, ~1 & 0xFFFF)  # TIM2_IRQHandler: rc_w0
    assert m.r("TIM2", TIM_SR) & 1 == 0
    assert tim.next_event_s() == pytest.approx(t0 + 20_000 * US, abs=1e-12)
    m.at(t0 + 1.0)  # 1 s after CEN: 100 overflows, after the UG of tick_set_rate
    assert tim.updates == 1 + 100 and m.r("TIM2", TIM_SR) & 1 == 1
    assert set(m.pending) == {28}


def test_ug_without_urs_sets_uif(m: StandIn) -> None:
    m.set_bits("RCC", RCC_APB1ENR, 1)
    m.w("TIM2", TIM_CNT, 1234)
    m.w("TIM2", TIM_EGR, 1)
    assert m.r("TIM2", TIM_SR) & 1 == 1 and m.r("TIM2", TIM_CNT) == 0
    assert m.pending == []  # UIE off
    m.w("TIM2", TIM_DIER, 1)  # UIE with UIF already set
    assert m.pending == [28]


def test_psc_is_preloaded_until_the_update(m: StandIn) -> None:
    tick_init(m, 100)  # 1 MHz count, 10 ms period, from t = 0
    tim = m.models["TIM2"]
    m.at(3_000 * US)
    m.w("TIM2", TIM_PSC, 95)  # 500 kHz from the next update on
    m.at(5_000 * US)
    assert m.r("TIM2", TIM_CNT) == 5000  # still counting at 1 MHz
    m.at(tim.next_event_s())
    assert m.now_s == pytest.approx(10_000 * US, abs=1e-12)
    assert tim.next_event_s() == pytest.approx(30_000 * US, abs=1e-12)  # 10 000 counts of 2 µs
    m.at(14_000 * US)
    assert m.r("TIM2", TIM_CNT) == 2000


def micros_init(m: StandIn) -> None:
    """micros.c: micros_init()."""
    m.set_bits("RCC", RCC_APB1ENR, 0b110)
    m.w("TIM3", TIM_PSC, 2 * 24_000_000 // 1_000_000 - 1)
    m.w("TIM3", TIM_ARR, 0xFFFF)
    m.w("TIM3", TIM_CR2, 2 << 4)
    m.w("TIM3", TIM_EGR, 1)
    m.w("TIM4", TIM_ARR, 0xFFFF)
    m.w("TIM4", TIM_SMCR, (2 << 4) | 7)
    m.w("TIM4", TIM_CR1, 1)
    m.w("TIM3", TIM_CR1, 1)


def micros(m: StandIn) -> int:
    while True:
        hi = m.r("TIM4", TIM_CNT)
        lo = m.r("TIM3", TIM_CNT)
        if hi == m.r("TIM4", TIM_CNT):
            return (hi << 16) | lo


def test_tim3_tim4_count_microseconds_with_a_carry_at_65536(m: StandIn) -> None:
    t0 = 2e-3
    m.at(t0)
    micros_init(m)
    assert micros(m) == 0  # the UG before TIM4 was a slave is not counted
    m.at(t0 + 65_535 * US)
    assert (m.r("TIM4", TIM_CNT), m.r("TIM3", TIM_CNT)) == (0, 65_535)
    m.at(t0 + 65_541 * US)
    assert (m.r("TIM4", TIM_CNT), m.r("TIM3", TIM_CNT)) == (1, 5)
    m.at(t0 + 1.0)  # 1 000 000 µs = 15 × 65 536 + 16 960
    assert (m.r("TIM4", TIM_CNT), m.r("TIM3", TIM_CNT)) == (15, 16_960)
    assert micros(m) == 1_000_000
    assert m.models["TIM3"].next_event_s() == pytest.approx(t0 + 16 * 65_536 * US, abs=1e-12)
    # TIM4 overflows after 65 536 carries: 2^32 µs
    assert m.models["TIM4"].next_event_s() == pytest.approx(t0 + 4294.967296, abs=1e-9)
    assert m.pending == []


@pytest.mark.parametrize(("offset", "value", "what"), [
    (TIM_CR1, 1 << 4, r"CR1.DIR \(down-counting\) not modelled"),
    (TIM_CR1, 1 << 3, r"CR1.OPM"),
    (TIM_SMCR, 4, r"SMCR = 0x0004 not modelled"),
    (TIM_SMCR, (5 << 4) | 7, r"SMCR.TS = 101 not modelled"),
    (TIM_DIER, 1 << 1, r"DIER = 0x0002 not modelled"),
    (0x34, 0, r"TIM2.CCR1 not modelled"),
    (0x30, 0, r"reserved offset"),
])
def test_unsupported_timer_modes_fail_loudly(m: StandIn, offset: int, value: int, what: str) -> None:
    m.set_bits("RCC", RCC_APB1ENR, 1)
    with pytest.raises(UnmodelledAccess, match=what):
        m.w("TIM2", offset, value)


# -- ADC1 ---------------------------------------------------------------------------------------


def adc_power_up(m: StandIn, t0: float = 10 * US) -> None:
    m.at(t0)
    m.set_bits("RCC", RCC_APB2ENR, (1 << 2) | (1 << 9))
    m.w("ADC1", ADC_SMPR2, 2)
    m.w("ADC1", ADC_SQR1, 0)
    m.w("ADC1", ADC_SQR3, 0)
    m.w("ADC1", ADC_CR2, ADON | EXTSEL_SW | EXTTRIG)


def adc_init(m: StandIn, t0: float = 10 * US) -> float:
    """adc.c adc_init(), returning the time calibration completed."""
    adc = m.models["ADC1"]
    adc_power_up(m, t0)
    m.at(t0 + 2 * US)  # delay_us(2)
    m.set_bits("ADC1", ADC_CR2, RSTCAL)
    while m.r("ADC1", ADC_CR2) & RSTCAL:
        m.at(adc.next_event_s())
    m.set_bits("ADC1", ADC_CR2, CAL)
    t_cal = m.now_s
    assert m.r("ADC1", ADC_CR2) & CAL
    m.at(t_cal + 83 / 12e6 - 1e-9)
    assert m.r("ADC1", ADC_CR2) & CAL  # t_CAL = 83 ADC cycles = 6.917 µs
    m.at(t_cal + 83 / 12e6)
    assert not m.r("ADC1", ADC_CR2) & CAL
    return m.now_s


def test_conversion_at_13_5_cycles_takes_2_1667_us(m: StandIn) -> None:
    adc = m.models["ADC1"]
    adc.source = lambda ch: 1000 + ch
    t = adc_init(m) + 5 * US
    m.at(t)
    m.set_bits("ADC1", ADC_CR2, SWSTART)
    assert not m.r("ADC1", ADC_CR2) & SWSTART  # cleared when the conversion starts
    assert adc.next_event_s() == pytest.approx(t + 2.1667 * US, abs=1e-10)
    m.at(t + 2.16 * US)
    assert not m.r("ADC1", ADC_SR) & 2
    m.at(adc.next_event_s())
    assert m.r("ADC1", ADC_SR) & 2  # EOC
    assert m.r("ADC1", ADC_DR) == 1000
    assert not m.r("ADC1", ADC_SR) & 2  # reading DR cleared EOC
    assert adc.conversions == [(t, 0)]


def test_adcclk_above_14_mhz_is_misuse() -> None:
    m = StandIn()
    clock_init(m, cfgr=CLOCK_C_CFGR & ~(3 << 14))  # ADC /2: 24 MHz
    with pytest.raises(Misuse, match=r"ADON set with ADCCLK 24 MHz above 14 MHz"):
        adc_power_up(m)


def test_calibration_before_t_stab_is_misuse(m: StandIn) -> None:
    adc_power_up(m, 10 * US)
    m.at(10.5 * US)
    with pytest.raises(Misuse, match=r"CAL 0.5 µs after ADON was set, before t_STAB = 1 µs"):
        m.set_bits("ADC1", ADC_CR2, CAL)


def test_calibration_during_rstcal_is_misuse(m: StandIn) -> None:
    adc_power_up(m, 10 * US)
    m.at(12 * US)
    m.set_bits("ADC1", ADC_CR2, RSTCAL)
    with pytest.raises(Misuse, match=r"CAL while the calibration reset \(RSTCAL\) is still running"):
        m.set_bits("ADC1", ADC_CR2, CAL)


def test_conversion_before_calibration_is_misuse(m: StandIn) -> None:
    m.models["ADC1"].source = lambda ch: 0
    adc_power_up(m, 10 * US)
    m.at(20 * US)
    with pytest.raises(Misuse, match=r"conversion \(SWSTART\) before calibration"):
        m.set_bits("ADC1", ADC_CR2, SWSTART)


def test_swstart_without_exttrig_is_misuse(m: StandIn) -> None:
    m.models["ADC1"].source = lambda ch: 0
    adc_init(m)
    m.w("ADC1", ADC_CR2, ADON | EXTSEL_SW)  # EXTTRIG off
    with pytest.raises(Misuse, match=r"SWSTART without CR2.EXTTRIG = 1 and EXTSEL = 111"):
        m.set_bits("ADC1", ADC_CR2, SWSTART)


# -- USART1 ------------------------------------------------------------------------------------


def uart_init(m: StandIn, brr: int = 48) -> None:
    """uart.c uart_init(1 000 000) at PCLK2 = 48 MHz: BRR = 48."""
    m.set_bits("RCC", RCC_APB2ENR, (1 << 2) | (1 << 14))
    _gpio_config(m, "GPIOA", 9, 0xB)
    _gpio_config(m, "GPIOA", 10, 0x8)
    m.w("GPIOA", GPIO_BSRR, 1 << 10)
    m.w("USART1", U_BRR, brr)
    m.w("USART1", U_CR1, UE | TE | RE | RXNEIE)


def test_usart_brr_48_sends_a_byte_every_10_us(m: StandIn) -> None:
    uart_init(m)
    usart = m.models["USART1"]
    assert usart.baud() == pytest.approx(1e6)
    m.at(usart.next_event_s())  # the idle frame that TE sends first: 10 µs
    assert m.now_s == pytest.approx(10 * US, abs=1e-12)
    t1 = 20 * US
    m.at(t1)
    data = b"PSM"
    queue = list(data)
    m.set_bits("USART1", U_CR1, TXEIE)  # uart_write
    assert m.pending[-1] == 37
    while queue or usart.next_event_s() is not None:  # USART1_IRQHandler when TXE
        if queue and m.r("USART1", U_SR) & TXE:
            m.w("USART1", U_DR, queue.pop(0))
            continue
        m.at(usart.next_event_s())
    assert bytes(usart.tx) == data
    assert usart.tx_times_s == pytest.approx([t1 + 10 * US, t1 + 20 * US, t1 + 30 * US], abs=1e-12)
    assert m.r("USART1", U_SR) & (TXE | TC) == TXE | TC


def test_usart_brr_mantissa_and_fraction(m: StandIn) -> None:
    # 115 200 baud at 48 MHz: USARTDIV = 26.0417 -> mantissa 26, fraction 1 (1/16): BRR 0x1A1
    uart_init(m, brr=(26 << 4) | 1)
    assert m.models["USART1"].baud() == pytest.approx(48e6 / (16 * (26 + 1 / 16)))
    assert m.models["USART1"].frame_time_s() == pytest.approx(10 * 417 / 48e6)


def test_usart_receive_and_overrun(m: StandIn) -> None:
    uart_init(m)
    usart = m.models["USART1"]
    m.at(50 * US)
    m.pending.clear()
    usart.feed(b"ab")
    m.at(59.9 * US)
    assert not m.r("USART1", U_SR) & RXNE
    m.at(60 * US)
    assert m.r("USART1", U_SR) & RXNE and m.pending == [37]
    m.at(70 * US)  # 'b' arrives with RXNE still set: lost
    assert m.r("USART1", U_SR) & ORE and usart.overruns == 1
    assert m.r("USART1", U_DR) == ord("a")
    assert m.r("USART1", U_SR) & (RXNE | ORE) == 0


def test_usart_dr_write_with_te_off_is_misuse(m: StandIn) -> None:
    m.set_bits("RCC", RCC_APB2ENR, 1 << 14)
    m.w("USART1", U_BRR, 48)
    m.w("USART1", U_CR1, UE | RE)
    with pytest.raises(Misuse, match=r"USART1: DR written while CR1.TE = 0"):
        m.w("USART1", U_DR, 0x55)
    m.w("USART1", U_CR1, TE)
    with pytest.raises(Misuse, match=r"USART1: DR written while CR1.UE = 0"):
        m.w("USART1", U_DR, 0x55)


def test_usart_dr_write_while_txe_clear_is_misuse(m: StandIn) -> None:
    uart_init(m)
    m.w("USART1", U_DR, 1)  # waits behind the idle frame
    with pytest.raises(Misuse, match=r"DR written while TXE = 0: byte 0x01"):
        m.w("USART1", U_DR, 2)


# -- UID ----------------------------------------------------------------------------------------


def test_uid_is_readable_by_words_and_bytes_and_read_only() -> None:
    m = StandIn()
    uid = m.models["UID"]
    assert [uid.read(k, 4) for k in (0, 4, 8)] == [0x12345678, 0x9ABCDEF0, 0x0F1E2D3C]
    assert uid.read(1, 1) == 0x56 and uid.read(10, 2) == 0x0F1E
    with pytest.raises(Misuse, match=r"read-only unique ID at 0x1FFFF7E8"):
        uid.write(0, 4, 0)

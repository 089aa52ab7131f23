"""RCC and FLASH.ACR of the STM32F103: the clock tree (RM0008 §7.2, §7.3; §3.3.3 for ACR).

The oscillators and the PLL are ready as soon as they are switched on (their start-up and lock
times, at most a few hundred microseconds, are not modelled: the firmware polls the ready
flags). The system clock switches as soon as SW is written. Misuse caught here:

* SW selecting a clock that is not ready, or the reserved SW = 11;
* a SYSCLK above what the flash latency allows (RM0008 §3.3.3: 0 wait states up to 24 MHz,
  1 up to 48 MHz, 2 up to 72 MHz), whether by switching SYSCLK or by lowering LATENCY;
* a PLL output above 72 MHz, or switching the PLL on while its source is not ready;
* PLLSRC, PLLXTPRE or PLLMUL changed while the PLL is on (RM0008: written only when it is off);
* PCLK1 above 36 MHz (the APB1 limit);
* changing the clock tree, or switching a modelled peripheral's clock off, once a peripheral that
  keeps time (TIM2-4, ADC1, USART1) is clocked: not modelled, so it fails loudly.
"""

from __future__ import annotations

from ._errors import Misuse, UnmodelledAccess
from ._registers import RegisterModel

__all__ = ["Flash", "Rcc"]

HSI_HZ = 8e6
SYSCLK_MAX_HZ = 72e6
PCLK1_MAX_HZ = 36e6
# RM0008 §3.3.3: the highest SYSCLK (Hz) for 0, 1 and 2 flash wait states.
FLASH_WS_MAX_HZ = (24e6, 48e6, 72e6)

CR, CFGR, CIR, APB2RSTR, APB1RSTR, AHBENR, APB2ENR, APB1ENR, BDCR, CSR = range(0, 0x28, 4)
_UNMODELLED = {CIR: "CIR", APB2RSTR: "APB2RSTR", APB1RSTR: "APB1RSTR", BDCR: "BDCR", CSR: "CSR"}

# CR bits
HSION, HSIRDY, HSEON, HSERDY, HSEBYP, CSSON, PLLON, PLLRDY = (
    1 << 0, 1 << 1, 1 << 16, 1 << 17, 1 << 18, 1 << 19, 1 << 24, 1 << 25)
_CR_RESET = HSION | HSIRDY | (16 << 3)  # HSITRIM = 16; HSICAL (factory) reads as 0
_CR_WRITABLE = HSION | (0x1F << 3) | HSEON | HSEBYP | CSSON | PLLON
# CFGR fields
_PLL_CONFIG = (1 << 16) | (1 << 17) | (0xF << 18)  # PLLSRC, PLLXTPRE, PLLMUL
_CFGR_MCO = 7 << 24
_CFGR_RESERVED = 0xF8800000  # bits 31:27 and 23

# Clock enable bits: name -> (register, bit) (RM0008 §7.3.6-7.3.8).
ENABLE_BITS: dict[str, tuple[str, int]] = {
    **{n: ("AHBENR", b) for n, b in (("DMA1", 0), ("SRAM", 2), ("FLITF", 4), ("CRC", 6))},
    **{n: ("APB2ENR", b) for n, b in (
        ("AFIO", 0), ("GPIOA", 2), ("GPIOB", 3), ("GPIOC", 4), ("GPIOD", 5), ("GPIOE", 6),
        ("ADC1", 9), ("ADC2", 10), ("TIM1", 11), ("SPI1", 12), ("USART1", 14))},
    **{n: ("APB1ENR", b) for n, b in (
        ("TIM2", 0), ("TIM3", 1), ("TIM4", 2), ("WWDG", 11), ("SPI2", 14), ("USART2", 17),
        ("USART3", 18), ("I2C1", 21), ("I2C2", 22), ("USB", 23), ("CAN", 25), ("BKP", 27),
        ("PWR", 28))},
}
# Peripherals with a model here (their clock may not be switched off again), and those of
# them that keep time from the clock tree (the tree may not change once they are clocked).
MODELLED = ("AFIO", "GPIOA", "GPIOB", "GPIOC", "TIM2", "TIM3", "TIM4", "ADC1", "USART1")
TIMEKEEPERS = ("TIM2", "TIM3", "TIM4", "ADC1", "USART1")
CLOCKS = ("HSI", "HSE", "PLL", "SYSCLK", "HCLK", "PCLK1", "PCLK2", "TIMCLK1", "TIMCLK2",
          "ADCCLK", "USBCLK")

_AHB_DIV = {8: 2, 9: 4, 10: 8, 11: 16, 12: 64, 13: 128, 14: 256, 15: 512}
_APB_DIV = {4: 2, 5: 4, 6: 8, 7: 16}


def flash_wait_states(sysclk_hz: float) -> int:
    """Fewest flash wait states (RM0008 §3.3.3) for a SYSCLK of ``sysclk_hz`` (Hz)."""
    for ws, top in enumerate(FLASH_WS_MAX_HZ):
        if sysclk_hz <= top:
            return ws
    return len(FLASH_WS_MAX_HZ)


class Rcc(RegisterModel):
    """Reset and clock control at 0x40021000, holding FLASH.ACR for :class:`Flash` as well.

    The HSE frequency is the machine's ``hse_hz`` (8 MHz on the BluePill when absent).
    """

    name = "RCC"
    base = 0x40021000
    size = 0x400

    def reset(self) -> None:
        """Registers at their RM0008 reset values; SYSCLK = HSI."""
        self.cr = _CR_RESET
        self.cfgr = 0
        self.ahbenr = 0x14  # SRAMEN, FLITFEN
        self.apb2enr = 0
        self.apb1enr = 0
        self.flash_acr = 0x30  # PRFTBE, PRFTBS; LATENCY 0
        self._tree: dict[str, float] | None = None  # clock_hz cache, dropped on CR/CFGR writes

    # -- services for the other models ----------------------------------------------------------

    def enable_bit(self, name: str) -> tuple[str, int]:
        """(register, bit) of the clock enable of peripheral ``name`` (e.g. ("APB1ENR", 0))."""
        try:
            return ENABLE_BITS[name]
        except KeyError:
            raise ValueError(f"RCC: no clock enable for {name!r}; known: "
                             f"{', '.join(sorted(ENABLE_BITS))}") from None

    def enabled(self, name: str) -> bool:
        """True when the clock of peripheral ``name`` (e.g. "TIM2", "GPIOA") is enabled."""
        reg, bit = self.enable_bit(name)
        return bool(self._enable_reg(reg) >> bit & 1)

    def _enable_reg(self, reg: str) -> int:
        return {"AHBENR": self.ahbenr, "APB2ENR": self.apb2enr, "APB1ENR": self.apb1enr}[reg]

    def clock_hz(self, name: str) -> float:
        """Frequency (Hz) of clock ``name``: one of :data:`CLOCKS`.

        TIMCLK1/TIMCLK2 are the APB1/APB2 timer clocks: PCLK × 2 when that APB prescaler is not 1
        (RM0008 §7.2). PLL is the PLL output, whether or not the PLL is on.
        """
        if name not in CLOCKS:
            raise ValueError(f"RCC: no clock {name!r}; known: {', '.join(CLOCKS)}")
        if self._tree is None:
            self._tree = self._clocks(self.cr, self.cfgr)
        return self._tree[name]

    def _clocks(self, cr: int, cfgr: int) -> dict[str, float]:
        hse = float(getattr(self.machine, "hse_hz", 8e6))
        pll_in = (hse / (2 if cfgr >> 17 & 1 else 1)) if cfgr >> 16 & 1 else HSI_HZ / 2
        mul = min((cfgr >> 18 & 0xF) + 2, 16)
        pll = pll_in * mul
        sysclk = (HSI_HZ, hse, pll, HSI_HZ)[cfgr >> 2 & 3]
        hclk = sysclk / _AHB_DIV.get(cfgr >> 4 & 0xF, 1)
        div1, div2 = _APB_DIV.get(cfgr >> 8 & 7, 1), _APB_DIV.get(cfgr >> 11 & 7, 1)
        pclk1, pclk2 = hclk / div1, hclk / div2
        return {
            "HSI": HSI_HZ, "HSE": hse, "PLL": pll, "SYSCLK": sysclk, "HCLK": hclk,
            "PCLK1": pclk1, "PCLK2": pclk2,
            "TIMCLK1": pclk1 * (1 if div1 == 1 else 2), "TIMCLK2": pclk2 * (1 if div2 == 1 else 2),
            "ADCCLK": pclk2 / (2, 4, 6, 8)[cfgr >> 14 & 3],
            "USBCLK": pll / (1.0 if cfgr >> 22 & 1 else 1.5),
        }

    # -- registers --------------------------------------------------------------------------

    def read_register(self, offset: int) -> int:
        """CR, CFGR, AHBENR, APB2ENR, APB1ENR; the other RCC registers fail as unmodelled."""
        regs = {CR: self.cr, CFGR: self.cfgr, AHBENR: self.ahbenr, APB2ENR: self.apb2enr,
                APB1ENR: self.apb1enr}
        if offset in regs:
            return regs[offset]
        self._no_register(offset)

    def write_register(self, offset: int, value: int) -> None:
        """Writes CR, CFGR or a clock enable register, with the checks of the module docstring."""
        try:
            if offset == CR:
                self._write_cr(value)
            elif offset == CFGR:
                self._write_cfgr(value)
            elif offset in (AHBENR, APB2ENR, APB1ENR):
                self._write_enable(offset, value)
            else:
                self._no_register(offset)
        finally:
            self._tree = None

    def _no_register(self, offset: int) -> None:
        what = (f"RCC.{_UNMODELLED[offset]} not modelled" if offset in _UNMODELLED
                else "reserved offset")
        self.unmodelled(offset, what)

    def _write_cr(self, value: int) -> None:
        if value & HSEBYP:
            self.unmodelled(CR, "CR.HSEBYP (external clock bypass) not modelled")
        if value & CSSON:
            self.unmodelled(CR, "CR.CSSON (clock security system) not modelled")
        new = (self.cr & ~_CR_WRITABLE) | (value & _CR_WRITABLE)
        sw = self.cfgr >> 2 & 3
        pll_src_hse = bool(self.cfgr >> 16 & 1)
        pll_in_use = sw == 2
        # RM0008 §7.3.1: an oscillator or the PLL in use by SYSCLK cannot be switched off.
        if not new & HSION and (sw == 0 or (pll_in_use and not pll_src_hse)):
            new |= HSION
        if not new & HSEON and (sw == 1 or (pll_in_use and pll_src_hse)):
            new |= HSEON
        if not new & PLLON and pll_in_use:
            new |= PLLON
        new = (new | HSIRDY) if new & HSION else (new & ~HSIRDY)
        new = (new | HSERDY) if new & HSEON else (new & ~HSERDY)
        if new & PLLON and not self.cr & PLLON:
            ready = new & HSERDY if pll_src_hse else new & HSIRDY
            if not ready:
                self.misuse(f"CR.PLLON set while the PLL source ({'HSE' if pll_src_hse else 'HSI'}) "
                            f"is not ready")
            pll = self.clock_hz("PLL")
            if pll > SYSCLK_MAX_HZ:
                self.misuse(f"PLL output {pll / 1e6:g} MHz exceeds {SYSCLK_MAX_HZ / 1e6:g} MHz "
                            f"(CFGR.PLLMUL/PLLSRC)")
        new = (new | PLLRDY) if new & PLLON else (new & ~PLLRDY)
        self.cr = new

    def _write_cfgr(self, value: int) -> None:
        if value & _CFGR_RESERVED:
            self.misuse(f"CFGR reserved bits written: 0x{value & _CFGR_RESERVED:08X}")
        if value & _CFGR_MCO:
            self.unmodelled(CFGR, "CFGR.MCO (clock output) not modelled")
        if self.cr & PLLON and (value ^ self.cfgr) & _PLL_CONFIG:
            self.misuse("CFGR.PLLSRC/PLLXTPRE/PLLMUL changed while the PLL is on (RM0008 §7.3.2: "
                        "written only when the PLL is disabled)")
        sw = value & 3
        if sw == 3:
            self.misuse("CFGR.SW = 11 is not allowed")
        ready = {0: self.cr & HSIRDY, 1: self.cr & HSERDY, 2: self.cr & PLLRDY}[sw]
        if not ready:
            source = ("HSI", "HSE", "PLL")[sw]
            self.misuse(f"CFGR.SW selects {source} while it is not ready (CR.{source}RDY = 0)")
        new = (value & ~0xC) | (sw << 2)  # SWS follows SW at once
        before, after = self._clocks(self.cr, self.cfgr), self._clocks(self.cr, new)
        self._check_tree(after)
        changed = [k for k in ("SYSCLK", "HCLK", "PCLK1", "PCLK2", "ADCCLK") if before[k] != after[k]]
        clocked = [n for n in TIMEKEEPERS if self.enabled(n)]
        if changed and clocked:
            self.unmodelled(CFGR, f"changing {', '.join(changed)} while {', '.join(clocked)} "
                                  f"is clocked is not modelled")
        self.cfgr = new

    def _check_tree(self, clocks: dict[str, float]) -> None:
        sysclk = clocks["SYSCLK"]
        latency = self.flash_acr & 7
        if flash_wait_states(sysclk) > latency:
            self.misuse(f"SYSCLK {sysclk / 1e6:g} MHz needs {flash_wait_states(sysclk)} flash wait "
                        f"states but FLASH.ACR.LATENCY = {latency} (RM0008 §3.3.3)")
        if clocks["PCLK1"] > PCLK1_MAX_HZ:
            self.misuse(f"PCLK1 {clocks['PCLK1'] / 1e6:g} MHz exceeds {PCLK1_MAX_HZ / 1e6:g} MHz "
                        f"(CFGR.PPRE1)")

    def _write_enable(self, offset: int, value: int) -> None:
        reg = {AHBENR: "AHBENR", APB2ENR: "APB2ENR", APB1ENR: "APB1ENR"}[offset]
        old = self._enable_reg(reg)
        for name in MODELLED:
            r, bit = ENABLE_BITS[name]
            if r == reg and old >> bit & 1 and not value >> bit & 1:
                self.unmodelled(offset, f"switching the clock of {name} off is not modelled")
        setattr(self, reg.lower(), value)

    # -- FLASH.ACR, for Flash --------------------------------------------------------------------

    def write_flash_acr(self, value: int) -> None:
        """FLASH.ACR write: LATENCY (0-2), PRFTBE; HLFCYA fails as unmodelled."""
        latency = value & 7
        if latency > 2:
            self.fail_flash(f"ACR.LATENCY = {latency} is reserved (0, 1 or 2)")
        if value & 1 << 3:
            self.fail_flash("ACR.HLFCYA (half-cycle access) not modelled", unmodelled=True)
        sysclk = self.clock_hz("SYSCLK")
        if flash_wait_states(sysclk) > latency:
            self.fail_flash(f"ACR.LATENCY = {latency} too low for SYSCLK {sysclk / 1e6:g} MHz "
                            f"(needs {flash_wait_states(sysclk)}, RM0008 §3.3.3)")
        prftbe = value >> 4 & 1
        if prftbe != self.flash_acr >> 4 & 1 and (sysclk >= 24e6 or self.cfgr >> 4 & 0x8):
            self.fail_flash("ACR.PRFTBE switched while SYSCLK >= 24 MHz or the AHB prescaler is "
                            "not 1 (RM0008 §3.3.3)")
        self.flash_acr = latency | prftbe << 4 | prftbe << 5  # PRFTBS follows PRFTBE

    def fail_flash(self, text: str, *, unmodelled: bool = False) -> None:
        """Fails a FLASH.ACR access with a message naming FLASH."""
        self.fail(UnmodelledAccess if unmodelled else Misuse, f"FLASH: {text}")


class Flash(RegisterModel):
    """The flash interface at 0x40022000: ACR only (its state lives in :class:`Rcc`)."""

    name = "FLASH"
    base = 0x40022000
    size = 0x400

    def read_register(self, offset: int) -> int:
        """ACR; the programming registers fail as unmodelled."""
        if offset == 0:
            return self.machine.rcc.flash_acr
        self.unmodelled(offset)

    def write_register(self, offset: int, value: int) -> None:
        """ACR (see :meth:`Rcc.write_flash_acr`)."""
        if offset != 0:
            self.unmodelled(offset)
        self.machine.rcc.write_flash_acr(value)

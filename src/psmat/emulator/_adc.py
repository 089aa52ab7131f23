"""ADC1 of the STM32F103: single regular conversions started by software (RM0008 §11).

Modelled: SR (EOC, STRT; rc_w0), CR2 (ADON, CAL, RSTCAL, ALIGN, EXTSEL, EXTTRIG, SWSTART,
TSVREFE), SMPR1/SMPR2, SQR1 (L = 0: one conversion), SQR2, SQR3 (SQ1: the channel), DR (reading
it clears EOC). A conversion takes (sample time + 12.5) ADC clock cycles (RM0008 §11.6); its
result is ``source(channel)``, asked at the start of the conversion (the end of the sampling is
not modelled apart); calibration takes 83 ADC clock cycles (datasheet t_CAL), a reset of the
calibration :data:`RSTCAL_CYCLES`. Scan, continuous, discontinuous, injected, DMA, the analog
watchdog and the interrupts fail as unmodelled.

Misuse caught here: ADCCLK above 14 MHz when ADON is set; CAL or RSTCAL while ADON = 0; CAL
before ADON has been on for t_STAB = 1 µs, or while a calibration reset is running; a conversion
started while ADON = 0, before t_STAB, before calibration has completed, during a calibration
or another conversion, or by SWSTART without EXTTRIG = 1 and EXTSEL = 111 (SWSTART).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING

from ._registers import RegisterModel, due

if TYPE_CHECKING:  # pragma: no cover - typing only
    from ._machine import Machine

__all__ = ["Adc1", "ChannelSource"]

SR, CR1, CR2, SMPR1, SMPR2 = 0x00, 0x04, 0x08, 0x0C, 0x10
SQR1, SQR2, SQR3, DR = 0x2C, 0x30, 0x34, 0x4C
_UNMODELLED = {0x14: "JOFR1", 0x18: "JOFR2", 0x1C: "JOFR3", 0x20: "JOFR4", 0x24: "HTR",
               0x28: "LTR", 0x38: "JSQR", 0x3C: "JDR1", 0x40: "JDR2", 0x44: "JDR3", 0x48: "JDR4"}
EOC, STRT = 1 << 1, 1 << 4
ADON, CONT, CAL, RSTCAL = 1 << 0, 1 << 1, 1 << 2, 1 << 3
ALIGN, EXTTRIG, SWSTART, TSVREFE = 1 << 11, 1 << 20, 1 << 22, 1 << 23
EXTSEL_SWSTART = 7 << 17
_CR2_MODELLED = ADON | CAL | RSTCAL | ALIGN | (7 << 17) | EXTTRIG | SWSTART | TSVREFE

ADCCLK_MAX_HZ = 14e6
T_STAB_S = 1e-6          # power-up time (datasheet t_STAB, max)
CAL_CYCLES = 83          # calibration time in ADC clock cycles (datasheet t_CAL)
RSTCAL_CYCLES = 2        # calibration reset: not specified by RM0008; a stated assumption
CONVERSION_CYCLES = 12.5  # successive approximation (RM0008 §11.6)
SAMPLE_CYCLES = (1.5, 7.5, 13.5, 28.5, 41.5, 55.5, 71.5, 239.5)  # SMPx codes 000..111

ChannelSource = Callable[[int], int]
"""``source(channel) -> count``: the 12-bit result (0..4095) of a conversion of ``channel``."""


class Adc1(RegisterModel):
    """ADC1 at 0x40012400 (clock RCC.APB2ENR.ADC1EN).

    Attributes
    ----------
    source : ChannelSource or None
        The board's analog side; a conversion without one fails.
    conversions : list of (float, int)
        (emulated time of the start in s, channel) of every conversion since power-up.
    """

    name = clock = "ADC1"
    base = 0x40012400

    def __init__(self, machine: Machine) -> None:
        self.source: ChannelSource | None = None
        self.conversions: list[tuple[float, int]] = []
        super().__init__(machine)

    def reset(self) -> None:
        """Powered down, uncalibrated, every register 0."""
        self.sr = self.cr2 = self.smpr1 = self.smpr2 = self.sqr1 = self.sqr2 = self.sqr3 = 0
        self.dr = 0
        self.on_since_s: float | None = None     # time ADON went 0 -> 1
        self.calibrated = False
        self.rstcal_end_s: float | None = None
        self.cal_end_s: float | None = None
        self.conversion_end_s: float | None = None
        self._result = 0

    # -- time --------------------------------------------------------------------------------

    def _adcclk(self) -> float:
        return self.machine.rcc.clock_hz("ADCCLK")

    def conversion_time_s(self, channel: int) -> float:
        """Duration (s) of one conversion of ``channel`` at its SMPR sample time and ADCCLK."""
        smpr = self.smpr2 >> 3 * channel if channel < 10 else self.smpr1 >> 3 * (channel - 10)
        return (SAMPLE_CYCLES[smpr & 7] + CONVERSION_CYCLES) / self._adcclk()

    def next_event_s(self) -> float | None:
        """The earliest end of a calibration reset, a calibration or a conversion."""
        ends = [t for t in (self.rstcal_end_s, self.cal_end_s, self.conversion_end_s) if t is not None]
        return min(ends) if ends else None

    def advance(self, now_s: float) -> None:
        """Ends whatever calibration or conversion has run its time by ``now_s``."""
        if due(self.rstcal_end_s, now_s):
            self.rstcal_end_s = None
            self.cr2 &= ~RSTCAL
        if due(self.cal_end_s, now_s):
            self.cal_end_s = None
            self.cr2 &= ~CAL
            self.calibrated = True
        if due(self.conversion_end_s, now_s):
            self.conversion_end_s = None
            self.dr = self._result << 4 if self.cr2 & ALIGN else self._result
            self.sr |= EOC

    # -- registers --------------------------------------------------------------------------

    def read_register(self, offset: int) -> int:
        """SR, CR1 (0), CR2, SMPR1/2, SQR1-3; DR (clears EOC)."""
        if offset == DR:
            self.sr &= ~EOC
            return self.dr
        regs = {SR: self.sr, CR1: 0, CR2: self.cr2, SMPR1: self.smpr1, SMPR2: self.smpr2,
                SQR1: self.sqr1, SQR2: self.sqr2, SQR3: self.sqr3}
        if offset in regs:
            return regs[offset]
        self._no_register(offset)

    def write_register(self, offset: int, value: int) -> None:
        """Writes one register with the checks of the module docstring."""
        if offset == SR:
            self.sr &= value | ~(EOC | STRT)  # rc_w0 (AWD, JEOC, JSTRT are never set here)
        elif offset == CR1:
            if value:
                self.unmodelled(CR1, f"CR1 = 0x{value:08X} not modelled (scan, discontinuous, "
                                     f"interrupts, watchdog, dual mode)")
        elif offset == CR2:
            self._write_cr2(value)
        elif offset == SMPR1:
            self.smpr1 = value & 0x00FFFFFF
        elif offset == SMPR2:
            self.smpr2 = value & 0x3FFFFFFF
        elif offset == SQR1:
            if value >> 20 & 0xF:
                self.unmodelled(SQR1, f"SQR1.L = {value >> 20 & 0xF}: sequences of more than one "
                                      f"conversion not modelled")
            self.sqr1 = value & 0x00FFFFFF
        elif offset == SQR2:
            self.sqr2 = value & 0x3FFFFFFF
        elif offset == SQR3:
            self.sqr3 = value & 0x3FFFFFFF
        elif offset == DR:
            self.misuse("DR is read-only")
        else:
            self._no_register(offset)

    def _no_register(self, offset: int) -> None:
        what = (f"ADC1.{_UNMODELLED[offset]} not modelled (injected channels, analog watchdog)"
                if offset in _UNMODELLED else "reserved offset")
        self.unmodelled(offset, what)

    def _write_cr2(self, value: int) -> None:
        if value & ~_CR2_MODELLED:
            self.unmodelled(CR2, f"CR2 bits 0x{value & ~_CR2_MODELLED:08X} not modelled "
                                 f"(continuous, DMA, injected channels)")
        now = self.machine.now_s
        old = self.cr2
        # RM0008 §11.12.3: ADON written 1 again, no other bit changed, starts a conversion.
        adon_restart = bool(old & ADON and value == old)
        if value & ADON and not old & ADON:
            adcclk = self._adcclk()
            if adcclk > ADCCLK_MAX_HZ:
                self.misuse(f"ADON set with ADCCLK {adcclk / 1e6:g} MHz above "
                            f"{ADCCLK_MAX_HZ / 1e6:g} MHz (RCC.CFGR.ADCPRE)")
            self.on_since_s = now
        if not value & ADON:
            if self.cal_end_s is not None or self.conversion_end_s is not None:
                self.unmodelled(CR2, "ADON cleared during a calibration or a conversion")
            self.on_since_s = None
        # CAL, RSTCAL and SWSTART are set by software, cleared by hardware: a 1 starts, a 0 keeps.
        self.cr2 = (value & ~(CAL | RSTCAL | SWSTART)) | (old & (CAL | RSTCAL))
        if value & RSTCAL and not old & RSTCAL:
            self._start_rstcal(now)
        if value & CAL and not old & CAL:
            self._start_cal(now)
        if value & SWSTART:
            if not (value & EXTTRIG and value & (7 << 17) == EXTSEL_SWSTART):
                self.misuse("SWSTART without CR2.EXTTRIG = 1 and EXTSEL = 111 (SWSTART): no "
                            "conversion would start (RM0008 §11.12.3)")
            self._start_conversion(now, "SWSTART")
        elif adon_restart:
            self._start_conversion(now, "ADON written again")

    def _powered(self, what: str, now: float) -> None:
        if self.on_since_s is None:
            self.misuse(f"{what} while ADON = 0")
        if now - self.on_since_s < T_STAB_S - 1e-12:
            self.misuse(f"{what} {(now - self.on_since_s) * 1e6:.3g} µs after ADON was set, "
                        f"before t_STAB = {T_STAB_S * 1e6:g} µs")

    def _start_rstcal(self, now: float) -> None:
        if self.on_since_s is None:
            self.misuse("RSTCAL while ADON = 0")
        self.calibrated = False
        self.rstcal_end_s = now + RSTCAL_CYCLES / self._adcclk()
        self.cr2 |= RSTCAL

    def _start_cal(self, now: float) -> None:
        self._powered("CAL", now)
        if self.rstcal_end_s is not None:
            self.misuse("CAL while the calibration reset (RSTCAL) is still running")
        if self.conversion_end_s is not None:
            self.misuse("CAL during a conversion")
        self.calibrated = False
        self.cal_end_s = now + CAL_CYCLES / self._adcclk()
        self.cr2 |= CAL

    def _start_conversion(self, now: float, how: str) -> None:
        self._powered(f"conversion ({how})", now)
        if self.cal_end_s is not None or self.rstcal_end_s is not None:
            self.misuse(f"conversion ({how}) during calibration")
        if not self.calibrated:
            self.misuse(f"conversion ({how}) before calibration (CR2.CAL) has completed")
        if self.conversion_end_s is not None:
            self.misuse(f"conversion ({how}) while the previous one is running")
        channel = self.sqr3 & 0x1F
        if channel > 17:
            self.misuse(f"SQR3.SQ1 = {channel}: no such channel (0..17)")
        if self.source is None:
            self.misuse(f"conversion of channel {channel} with no source attached (Adc1.source)")
        value = int(self.source(channel))
        if not 0 <= value <= 0xFFF:
            raise ValueError(f"ADC1: source({channel}) gave {value}, outside 0..4095")
        self.conversions.append((now, channel))
        self._result = value
        self.sr |= STRT
        self.conversion_end_s = now + self.conversion_time_s(channel)

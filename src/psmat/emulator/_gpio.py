"""GPIOA/B/C of the STM32F103: CRL, CRH, IDR, ODR, BSRR, BRR (RM0008 §9.2).

A pin's input level (IDR) comes from its configuration and the board:

* analog input: 0 (the Schmitt trigger is off);
* floating input: the level the board drives (:meth:`Gpio.set_input`), 0 when undriven;
* pull-up/pull-down input: the board's level, or the pull (the ODR bit) when undriven;
* push-pull output: the ODR bit; open-drain output: the ODR bit AND the board's level (a
  released line with nothing on it reads 0: a bus pull-up is the board's to drive);
* alternate-function push-pull output: only USART1_TX on PA9 is modelled; it reads as the
  line's idle level, 1.

Misuse caught here: an output configured on a pin the debug port still owns (AFIO MAPR.SWJ_CFG;
PA15, PB3 and PB4 after reset, PA13 and PA14 unless SWJ is off), the reserved input CNF = 11,
reserved bits written, IDR written. Every write of ODR, BSRR or BRR calls the ``on_write`` hooks
with ``(port, odr_before, odr_after, now_s)``: ``port`` is the model's name ("GPIOB").
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING

from ._registers import RegisterModel

if TYPE_CHECKING:  # pragma: no cover - typing only
    from ._machine import Machine

__all__ = ["Gpio", "GpioA", "GpioB", "GpioC", "OdrHook"]

CRL, CRH, IDR, ODR, BSRR, BRR, LCKR = range(0, 0x1C, 4)
# Pins with a modelled alternate function (port letter, pin) -> function.
ALTERNATE_FUNCTIONS = {("A", 9): "USART1_TX"}

OdrHook = Callable[[str, int, int, float], None]
"""``hook(port, odr_before, odr_after, now_s)``: a write of ODR, BSRR or BRR at ``now_s`` (s)."""


class Gpio(RegisterModel):
    """One GPIO port; the subclasses :class:`GpioA`, :class:`GpioB`, :class:`GpioC` place it.

    Attributes
    ----------
    on_write : list of OdrHook
        Called after every write of ODR, BSRR or BRR.
    external : list of int or None
        The level (0 or 1) the board drives on each of the 16 pins, None where undriven.
    """

    port = ""

    def __init__(self, machine: Machine) -> None:
        self.on_write: list[OdrHook] = []
        self.external: list[int | None] = [None] * 16
        super().__init__(machine)

    def reset(self) -> None:
        """CRL = CRH = 0x44444444 (floating inputs), ODR = 0."""
        self.crl = 0x44444444
        self.crh = 0x44444444
        self.odr = 0

    # -- the board's side ------------------------------------------------------------------------

    def set_input(self, pin: int, level: int | None) -> None:
        """Drives ``pin`` (0-15) from the board: 0 or 1, or None to let it go."""
        if not 0 <= pin < 16:
            raise ValueError(f"{self.name}: pin {pin} out of 0..15")
        if level not in (0, 1, None):
            raise ValueError(f"{self.name}: level {level!r} must be 0, 1 or None")
        self.external[pin] = level

    def nibble(self, pin: int) -> int:
        """The pin's 4-bit configuration MODE | CNF << 2."""
        return (self.crl if pin < 8 else self.crh) >> 4 * (pin & 7) & 0xF

    def pin_mode(self, pin: int) -> str:
        """The pin's configuration in words, e.g. "input pull", "output push-pull"."""
        nib = self.nibble(pin)
        mode, cnf = nib & 3, nib >> 2
        if mode == 0:
            return ("analog", "input floating", "input pull", "reserved")[cnf]
        return ("output push-pull", "output open-drain", "alternate push-pull",
                "alternate open-drain")[cnf]

    def pin_level(self, pin: int) -> int:
        """The level IDR reads on ``pin`` (see the module docstring)."""
        nib = self.nibble(pin)
        mode, cnf = nib & 3, nib >> 2
        odr = self.odr >> pin & 1
        ext = self.external[pin]
        if mode == 0:
            if cnf == 0:
                return 0
            if cnf == 1:
                return ext or 0
            return odr if ext is None else ext
        if cnf == 0:
            return odr
        if cnf == 1:
            return odr & (ext or 0)
        return 1  # USART1_TX idle

    # -- registers ---------------------------------------------------------------------------

    def read_register(self, offset: int) -> int:
        """CRL, CRH, IDR, ODR; BSRR and BRR read 0 (write-only); LCKR fails as unmodelled."""
        if offset == CRL:
            return self.crl
        if offset == CRH:
            return self.crh
        if offset == IDR:
            return sum(self.pin_level(p) << p for p in range(16))
        if offset == ODR:
            return self.odr
        if offset in (BSRR, BRR):
            return 0
        self._no_register(offset)

    def write_register(self, offset: int, value: int) -> None:
        """CRL/CRH (checked pin by pin), ODR, BSRR (set wins over reset), BRR."""
        if offset in (CRL, CRH):
            self._write_cr(offset, value)
        elif offset == ODR:
            self._reserved_high(value, "ODR")
            self._set_odr(value)
        elif offset == BSRR:
            self._set_odr((self.odr & ~(value >> 16)) | (value & 0xFFFF))
        elif offset == BRR:
            self._reserved_high(value, "BRR")
            self._set_odr(self.odr & ~value)
        elif offset == IDR:
            self.misuse("IDR is read-only")
        else:
            self._no_register(offset)

    def _no_register(self, offset: int) -> None:
        self.unmodelled(offset, f"{self.name}.LCKR not modelled" if offset == LCKR else "reserved offset")

    def _reserved_high(self, value: int, reg: str) -> None:
        if value >> 16:
            self.misuse(f"{reg} reserved bits 31:16 written: 0x{value:08X}")

    def _set_odr(self, value: int) -> None:
        before, self.odr = self.odr, value & 0xFFFF
        for hook in list(self.on_write):
            hook(self.name, before, self.odr, self.machine.now_s)

    def _write_cr(self, offset: int, value: int) -> None:
        first = 0 if offset == CRL else 8
        old = self.crl if offset == CRL else self.crh
        debug = self.machine.peripheral("AFIO")
        for k in range(8):
            nib = value >> 4 * k & 0xF
            if nib == old >> 4 * k & 0xF:
                continue
            pin = first + k
            label = f"P{self.port}{pin}"
            mode, cnf = nib & 3, nib >> 2
            if mode == 0 and cnf == 3:
                self.misuse(f"{label} configured with the reserved input CNF = 11")
            if mode and (self.port, pin) in debug.debug_pins():
                self.misuse(f"{label} configured as an output while AFIO MAPR "
                            f"{debug.swj_description()} gives it to the debug port "
                            f"(RM0008 §9.3.5)")
            if mode and cnf >= 2:
                function = ALTERNATE_FUNCTIONS.get((self.port, pin))
                if function is None or cnf == 3:
                    kind = "open-drain" if cnf == 3 else "push-pull"
                    self.unmodelled(offset, f"{label} alternate-function {kind} output not "
                                            f"modelled (modelled: PA9 USART1_TX push-pull)")
        if offset == CRL:
            self.crl = value
        else:
            self.crh = value


class GpioA(Gpio):
    """Port A at 0x40010800 (clock RCC.APB2ENR.IOPAEN)."""

    name = clock = "GPIOA"
    base = 0x40010800
    port = "A"


class GpioB(Gpio):
    """Port B at 0x40010C00 (clock RCC.APB2ENR.IOPBEN)."""

    name = clock = "GPIOB"
    base = 0x40010C00
    port = "B"


class GpioC(Gpio):
    """Port C at 0x40011000 (clock RCC.APB2ENR.IOPCEN)."""

    name = clock = "GPIOC"
    base = 0x40011000
    port = "C"

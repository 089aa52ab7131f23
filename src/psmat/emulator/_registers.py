"""Register plumbing shared by the STM32F103 peripheral models (docs/spec.md §5 "Firmware executed").

:class:`RegisterModel` turns the machine's byte-addressed accesses into whole-register reads and
writes, checks the peripheral's RCC clock enable first, brings the model up to the emulated time
before every access, and fails loudly on offsets the model does not know.
"""

from __future__ import annotations

import math
from typing import NoReturn

from ._errors import EmulationError, Misuse, UnmodelledAccess
from ._peripheral import Peripheral

__all__ = ["RegisterModel", "TIME_TOLERANCE_S", "due", "ticks_at"]

# Two emulated times closer than this are the same instant (s): next_event_s() values come back
# through advance() as floats, and an event at t must count as done at now_s == t.
TIME_TOLERANCE_S = 1e-12


def due(event_s: float | None, now_s: float) -> bool:
    """True when an event scheduled at ``event_s`` (s) has happened by ``now_s`` (s)."""
    return event_s is not None and event_s <= now_s + TIME_TOLERANCE_S


def ticks_at(now_s: float, clock_hz: float) -> int:
    """Whole clock periods elapsed from time 0 to ``now_s`` (s) at ``clock_hz`` (Hz).

    A tolerance of 1e-3 period absorbs the float rounding of ``tick / clock_hz`` handed back by
    :meth:`Peripheral.next_event_s`, so that an edge at exactly ``now_s`` has happened.
    """
    return math.floor(now_s * clock_hz + 1e-3)


class RegisterModel(Peripheral):
    """A peripheral of 32-bit registers at word offsets.

    Subclasses set ``clock`` (the name :meth:`Rcc.enabled` knows, None for a peripheral without a
    clock enable), ``halfword_writes`` (RM0008 lets TIMx and USARTx registers be written by
    half-words; the others by words only) and implement :meth:`read_register` /
    :meth:`write_register` for the offsets they model, calling :meth:`unmodelled` otherwise.
    Reads of 1 or 2 bytes return the lanes of the whole register (its read side effects, such as
    clearing a flag, happen as for a word).
    """

    clock: str | None = None
    halfword_writes: bool = False

    # -- failures ----------------------------------------------------------------------------

    def fail(self, cls: type[EmulationError], text: str) -> NoReturn:
        """Raises ``cls`` through ``machine.fail`` (which appends the PC)."""
        self.machine.fail(cls, text)
        raise cls(text)  # pragma: no cover - machine.fail raises

    def misuse(self, text: str) -> NoReturn:
        """Fails with :class:`Misuse`: ``"<name>: <text>"``."""
        self.fail(Misuse, f"{self.name}: {text}")

    def unmodelled(self, offset: int, what: str = "register not modelled") -> NoReturn:
        """Fails with :class:`UnmodelledAccess` naming the address and ``what``."""
        self.fail(UnmodelledAccess, f"{self.name} access at 0x{self.base + offset:08X} "
                                    f"(offset 0x{offset:02X}): {what}")

    # -- the machine's interface --------------------------------------------------------------

    def _enter(self, kind: str, offset: int, size: int) -> None:
        if size not in (1, 2, 4) or offset % size:
            self.misuse(f"unaligned {size}-byte {kind} at offset 0x{offset:02X}")
        if self.clock is not None:
            rcc = self.machine.rcc
            if not rcc.enabled(self.clock):
                reg, bit = rcc.enable_bit(self.clock)
                self.misuse(f"register {kind} while its clock is off (RCC.{reg} bit {bit})")
        self.advance(self.machine.now_s)

    def read(self, offset: int, size: int) -> int:
        """Value of the ``size``-byte read at ``base + offset`` (lanes of one register)."""
        self._enter("read", offset, size)
        word = offset & ~3
        value = self.read_register(word) & 0xFFFFFFFF
        return (value >> (8 * (offset - word))) & ((1 << (8 * size)) - 1)

    def write(self, offset: int, size: int, value: int) -> None:
        """Writes ``value`` with a ``size``-byte store at ``base + offset``."""
        self._enter("write", offset, size)
        if size == 4 or (size == 2 and self.halfword_writes and offset % 4 == 0):
            self.write_register(offset, value & ((1 << (8 * size)) - 1))
            return
        rule = "half-words or words" if self.halfword_writes else "words"
        self.misuse(f"{size}-byte write at offset 0x{offset:02X}: RM0008 has its registers "
                    f"written by {rule}")

    # -- what subclasses implement --------------------------------------------------------------

    def read_register(self, offset: int) -> int:
        """The 32-bit register at ``offset`` (a multiple of 4), with its read side effects."""
        self.unmodelled(offset)

    def write_register(self, offset: int, value: int) -> None:
        """Writes the 32-bit register at ``offset`` (a multiple of 4)."""
        self.unmodelled(offset)

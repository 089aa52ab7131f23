"""The base class of the register-level peripheral models (docs/spec.md §5 "Firmware executed").

A model owns ``size`` bytes of MMIO at ``base``; the machine maps them with unicorn's
``mmio_map`` and calls :meth:`Peripheral.read` / :meth:`Peripheral.write` with the offset from
``base`` and the access size (1, 2 or 4 bytes). Between instruction slices the machine brings
every model up to the emulated time with :meth:`Peripheral.advance`, and asks
:meth:`Peripheral.next_event_s` how far it may run (or skip, at WFI) before the model's state
changes on its own. A model raises interrupts with ``machine.nvic.set_pending(irq)`` and reports
misuse with ``machine.fail(Misuse, "...")``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:  # pragma: no cover - typing only
    from ._machine import Machine

__all__ = ["Peripheral"]


class Peripheral:
    """One memory-mapped peripheral of the STM32F103.

    Subclasses set the class attributes ``name`` (e.g. ``"USART1"``), ``base`` (e.g.
    ``0x40013800``) and ``size`` (bytes of address space, e.g. ``0x400``), and override
    :meth:`reset`, :meth:`read`, :meth:`write` and, when they change state on their own,
    :meth:`next_event_s` and :meth:`advance`.

    Parameters
    ----------
    machine : Machine
        The machine the model belongs to; kept as ``self.machine``.
    """

    name: str = ""
    base: int = 0
    size: int = 0x400

    def __init__(self, machine: Machine) -> None:
        self.machine = machine
        self.reset()

    def reset(self) -> None:
        """Sets the registers to their reset values (RM0008)."""

    def read(self, offset: int, size: int) -> int:
        """Value of the ``size``-byte (1, 2 or 4) access at ``base + offset``.

        The default fails: a register without a model is an unmodelled access.
        """
        from ._errors import UnmodelledAccess

        self.machine.fail(UnmodelledAccess, f"read of {size} bytes at 0x{self.base + offset:08X} "
                                            f"({self.name} register not modelled)")
        return 0  # pragma: no cover - fail raises

    def write(self, offset: int, size: int, value: int) -> None:
        """Carries out the ``size``-byte (1, 2 or 4) write of ``value`` at ``base + offset``.

        The default fails: a register without a model is an unmodelled access.
        """
        from ._errors import UnmodelledAccess

        self.machine.fail(UnmodelledAccess, f"write of {size} bytes at 0x{self.base + offset:08X} "
                                            f"({self.name} register not modelled)")

    def next_event_s(self) -> float | None:
        """Emulated time (s) of the model's next change of state on its own, or None if none.

        A timer's next update, the end of a byte on a serial line, a conversion's end. The
        machine never runs past this time without calling :meth:`advance` (to within its slice
        length, see ``psmat.emulator._machine``), and WFI skips to the earliest of them.
        """
        return None

    def advance(self, now_s: float) -> None:
        """Brings the model's state up to the emulated time ``now_s`` (s).

        Sets the flags of whatever happened since the last call and pends its interrupts
        through ``self.machine.nvic.set_pending(irq)``. The machine calls it between instruction
        slices once ``next_event_s()`` is due (``<= now_s``); a model may call it itself (before
        a register access, say). ``now_s`` never decreases.
        """

    def __repr__(self) -> str:
        return f"<{type(self).__name__} {self.name} at 0x{self.base:08X}+0x{self.size:X}>"

"""Errors of the emulated STM32F103 (docs/spec.md §5 "Firmware executed").

Every error is one line: what happened, the address where there is one, and the PC of the
instruction that caused it (``Machine.fail`` appends ``" at PC 0x........"``).
"""

from __future__ import annotations

__all__ = ["EmulationError", "Misuse", "UnmodelledAccess"]


class EmulationError(RuntimeError):
    """The emulated image did something the emulator cannot or will not carry out."""


class UnmodelledAccess(EmulationError):
    """A read, write or instruction fetch at an address no memory or model covers.

    Example: ``"read of 4 bytes at 0x40013C00 (no model) at PC 0x08000A3C"``.
    """


class Misuse(EmulationError):
    """A peripheral model's own check failed (e.g. a register written while its clock is off)."""

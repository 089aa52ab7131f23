"""AFIO of the STM32F103: MAPR's SWJ_CFG, which decides who owns the debug pins (RM0008 §9.4.2).

After reset the full SWJ (JTAG + SW) port owns PA13, PA14, PA15, PB3 and PB4; the GPIO model asks
:meth:`Afio.debug_pins` before it lets one of them become an output. The peripheral remaps of
MAPR move pins the other models assume in place, so setting any of them fails as unmodelled.
"""

from __future__ import annotations

from ._registers import RegisterModel

__all__ = ["Afio"]

EVCR, MAPR = 0x00, 0x04
_UNMODELLED = {EVCR: "EVCR", 0x08: "EXTICR1", 0x0C: "EXTICR2", 0x10: "EXTICR3",
               0x14: "EXTICR4", 0x1C: "MAPR2"}
_REMAPS = 0x001FFFFF       # bits 20:0: peripheral remaps
_RESERVED = 0xF8E00000     # bits 31:27, 23:21
# SWJ_CFG -> the pins the debug port keeps (RM0008 Table 48).
DEBUG_PINS: dict[int, frozenset[tuple[str, int]]] = {
    0: frozenset({("A", 13), ("A", 14), ("A", 15), ("B", 3), ("B", 4)}),  # full SWJ (reset)
    1: frozenset({("A", 13), ("A", 14), ("A", 15), ("B", 3)}),            # full SWJ, no NJTRST
    2: frozenset({("A", 13), ("A", 14)}),                                 # JTAG off, SW-DP on
    4: frozenset(),                                                       # JTAG and SW-DP off
}
_SWJ_NAMES = {0: "full SWJ", 1: "full SWJ without NJTRST", 2: "SW-DP only", 4: "SWJ disabled"}


class Afio(RegisterModel):
    """Alternate-function I/O at 0x40010000 (clock enable RCC.APB2ENR.AFIOEN)."""

    name = "AFIO"
    base = 0x40010000
    size = 0x400
    clock = "AFIO"

    def reset(self) -> None:
        """SWJ_CFG = 000 (full SWJ), no remaps."""
        self.swj_cfg = 0

    def debug_pins(self) -> frozenset[tuple[str, int]]:
        """The (port letter, pin) pairs the debug port owns under the current SWJ_CFG."""
        return DEBUG_PINS[self.swj_cfg]

    def swj_description(self) -> str:
        """SWJ_CFG in words, for messages (e.g. "SWJ_CFG = 000, full SWJ")."""
        return f"SWJ_CFG = {self.swj_cfg:03b}, {_SWJ_NAMES[self.swj_cfg]}"

    def read_register(self, offset: int) -> int:
        """MAPR: no remaps; SWJ_CFG is write-only and reads as 0 (RM0008 §9.4.2)."""
        if offset == MAPR:
            return 0
        self._no_register(offset)

    def write_register(self, offset: int, value: int) -> None:
        """MAPR: SWJ_CFG 000, 001, 010 or 100; remap bits fail as unmodelled."""
        if offset != MAPR:
            self._no_register(offset)
        if value & _RESERVED:
            self.misuse(f"MAPR reserved bits written: 0x{value & _RESERVED:08X}")
        if value & _REMAPS:
            self.unmodelled(offset, f"MAPR remap bits 0x{value & _REMAPS:06X} not modelled")
        swj = value >> 24 & 7
        if swj not in DEBUG_PINS:
            self.misuse(f"MAPR.SWJ_CFG = {swj:03b} is reserved (000, 001, 010 or 100)")
        self.swj_cfg = swj

    def _no_register(self, offset: int) -> None:
        what = f"AFIO.{_UNMODELLED[offset]} not modelled" if offset in _UNMODELLED else "reserved offset"
        self.unmodelled(offset, what)

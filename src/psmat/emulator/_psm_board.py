"""The PSM BluePill as the emulator wires it: a mat of known counts behind the two multiplexers.

The board's wiring, written once here (firmware/README.md "Pins and links"; docs/spec.md §5
"Firmware executed"):

* the row multiplexer's select lines A0..A3 are PB12..PB15; its channel ``a`` is the mat's row
  ``15 - a`` (the thesis' board: the firmware selects row ``i`` at address ``R - 1 - i``);
* the column multiplexer's A0 is PA15 and A1..A3 are PB3..PB5; its channel ``p`` is column ``p``;
* the ADC input PA0 (ADC1 channel 0) reads, at the start of each conversion, the count of the
  cell the select lines address at that moment: ``counts[15 - a, p]``; an address beyond a
  smaller mat reads full scale (an open line).

Every conversion is logged with the time since the select lines last changed (the mux's
settling time, from the GPIO write to the conversion's start, in emulated time), so a test can
check the ≥ 1 µs the firmware promises (``min_settle_s``).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ._machine import Machine

__all__ = ["PsmBoard", "Conversion", "ROW_PINS", "COL_PINS", "FULL_SCALE"]

#: (port, pin) of the row multiplexer's A0..A3 and of the column multiplexer's A0..A3
ROW_PINS = (("GPIOB", 12), ("GPIOB", 13), ("GPIOB", 14), ("GPIOB", 15))
COL_PINS = (("GPIOA", 15), ("GPIOB", 3), ("GPIOB", 4), ("GPIOB", 5))
#: what an unconnected line reads: the 12-bit ADC's full scale
FULL_SCALE = 4095
_CHANNELS = 16


@dataclass(frozen=True)
class Conversion:
    """One ADC conversion: when it started (s), the multiplexer addresses and the settling time (s)."""

    t_s: float
    row_address: int
    col_address: int
    settle_s: float


@dataclass
class PsmBoard:
    """The PSM image on the emulated BluePill reading a mat of fixed counts.

    Parameters
    ----------
    elf_path : path
        The PSM image (``make -C firmware stm32 LINK=uart``: ``stm32-uart/psm.elf``).
    counts : array_like (R, C) of int
        The mat: the 12-bit count of each logical cell, R, C <= 16.
    uid : (int, int, int)
        The 96-bit unique ID the image reads (its serial is their XOR in hex).
    cycles_per_instruction, max_slice_s
        As :class:`Machine`.
    """

    elf_path: str | Path
    counts: ArrayLike
    uid: tuple[int, int, int] = (0x12345678, 0x9ABCDEF0, 0x0F1E2D3C)
    cycles_per_instruction: float = 1.0
    max_slice_s: float = 1e-6
    conversions: list[Conversion] = field(default_factory=list, init=False)

    def __post_init__(self) -> None:
        c = np.asarray(self.counts)
        if c.ndim != 2 or not (1 <= c.shape[0] <= _CHANNELS and 1 <= c.shape[1] <= _CHANNELS):
            raise ValueError(f"counts must be (R, C) with R, C <= {_CHANNELS}, got shape {c.shape}")
        if c.size and (c.min() < 0 or c.max() > FULL_SCALE or not np.all(c == np.round(c))):
            raise ValueError(f"counts must be whole numbers 0 ... {FULL_SCALE}")
        self.counts = c.astype(np.uint16)
        self.machine = Machine(self.elf_path, cycles_per_instruction=self.cycles_per_instruction,
                               uid=self.uid, max_slice_s=self.max_slice_s)
        self._gpio = {name: self.machine.peripheral(name) for name in ("GPIOA", "GPIOB")}
        self._usart = self.machine.peripheral("USART1")
        self._changed_s = 0.0
        self._address = self._select()
        for port in self._gpio.values():
            port.on_write.append(self._on_gpio)
        self.machine.peripheral("ADC1").source = self._read

    # -- the wiring ----------------------------------------------------------------------
    def _bits(self, pins: tuple[tuple[str, int], ...]) -> int:
        return sum(((self._gpio[port].odr >> pin) & 1) << k for k, (port, pin) in enumerate(pins))

    def _select(self) -> tuple[int, int]:
        return self._bits(ROW_PINS), self._bits(COL_PINS)

    def _on_gpio(self, _port: str, _before: int, _after: int, now_s: float) -> None:
        address = self._select()
        if address != self._address:
            self._address, self._changed_s = address, now_s

    def cell(self, row_address: int, col_address: int) -> int:
        """The count the ADC reads with these multiplexer addresses (the module docstring's wiring)."""
        R, C = self.counts.shape  # type: ignore[union-attr]
        i = _CHANNELS - 1 - row_address
        if 0 <= i < R and col_address < C:
            return int(self.counts[i, col_address])  # type: ignore[index]
        return FULL_SCALE

    def _read(self, channel: int) -> int:
        if channel != 0:
            self.machine.fail(RuntimeError, f"ADC1 channel {channel} converted: the mat is on channel 0 (PA0)")
        now = self.machine.now_s
        a, p = self._address
        self.conversions.append(Conversion(now, a, p, now - self._changed_s))
        return self.cell(a, p)

    # -- running -------------------------------------------------------------------------
    def run(self, until_s: float) -> None:
        """Run the image until ``until_s`` of emulated time (s since power-up)."""
        self.machine.run(until_s=until_s)

    def send(self, data: bytes, at_s: float | None = None) -> None:
        """Host → board bytes on USART1's RX, one per byte time from ``at_s`` (default now)."""
        self._usart.feed(bytes(data), at_s)

    @property
    def tx(self) -> bytes:
        """Every byte the image sent on USART1 since power-up."""
        return bytes(self._usart.tx)

    @property
    def tx_times_s(self) -> list[float]:
        """When each byte of :attr:`tx` finished (s, emulated)."""
        return list(self._usart.tx_times_s)

    @property
    def min_settle_s(self) -> float | None:
        """The shortest time between a change of the select lines and a conversion (s), None before any."""
        return min((c.settle_s for c in self.conversions), default=None)

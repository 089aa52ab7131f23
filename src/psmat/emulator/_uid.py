"""The 96-bit unique device ID of the STM32F103 at 0x1FFFF7E8 (RM0008 §30.2), read-only.

Its three words are the machine's ``uid`` (w0 at 0x1FFFF7E8, w1 at +4, w2 at +8), readable by
bytes, half-words or words; any write is a misuse. It has no clock enable.
"""

from __future__ import annotations

from ._registers import RegisterModel

__all__ = ["Uid"]


class Uid(RegisterModel):
    """The unique device ID: 12 read-only bytes."""

    name = "UID"
    base = 0x1FFFF7E8
    size = 12

    def words(self) -> tuple[int, int, int]:
        """The three 32-bit words of the ID, from the machine's ``uid``."""
        uid = tuple(int(w) for w in self.machine.uid)
        if len(uid) != 3 or not all(0 <= w <= 0xFFFFFFFF for w in uid):
            raise ValueError(f"UID: machine.uid must be three 32-bit words, got {self.machine.uid!r}")
        return uid  # type: ignore[return-value]

    def read_register(self, offset: int) -> int:
        """Word ``offset // 4`` of the ID."""
        if offset >= 12:
            self.unmodelled(offset, "beyond the 12 bytes of the unique ID")
        return self.words()[offset // 4]

    def write_register(self, offset: int, value: int) -> None:
        """Always fails: the ID is read-only."""
        self.misuse(f"write of 0x{value:08X} to the read-only unique ID at 0x{self.base + offset:08X}")

    def write(self, offset: int, size: int, value: int) -> None:
        """Any write, of any size, fails: the ID is read-only."""
        self.misuse(f"{size}-byte write of 0x{value:X} to the read-only unique ID at "
                    f"0x{self.base + offset:08X}")

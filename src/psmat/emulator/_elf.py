"""The firmware image: loadable bytes and symbols of an ARM ELF (pyelftools).

The loadable segments (``PT_LOAD`` with file bytes) are placed at their *physical* (load)
addresses, as a programmer writes them to flash: ``.data`` is linked to run in SRAM but loaded
into flash after ``.text`` (``> RAM AT > FLASH``), and the image's own ``Reset_Handler`` copies
it to SRAM and clears ``.bss``. Segments without file bytes (``.bss``, the stack) load nothing.
"""

from __future__ import annotations

import bisect
from dataclasses import dataclass, field
from pathlib import Path

from ._errors import EmulationError

__all__ = ["Image", "load_image"]

EM_ARM = "EM_ARM"


@dataclass(frozen=True)
class Image:
    """What the machine needs from an ELF file.

    Attributes
    ----------
    path : Path
        The ELF file.
    segments : list of (int, bytes)
        ``(load address, bytes)`` of every loadable segment with file bytes.
    entry : int
        The ELF entry point (Thumb bit cleared).
    symbols : dict of str to int
        Symbol name → address (Thumb bit of functions cleared) of every named function, object
        or untyped symbol (linker-script symbols such as ``_estack`` are untyped).
    sizes : dict of str to int
        Symbol name → size in bytes (0 for linker-script symbols).
    """

    path: Path
    segments: list[tuple[int, bytes]]
    entry: int
    symbols: dict[str, int]
    sizes: dict[str, int]
    _functions: list[tuple[int, int, str]] = field(default_factory=list, repr=False)

    def function_at(self, address: int) -> tuple[str, int] | None:
        """``(name, offset)`` of the function whose bytes hold ``address``, or None."""
        i = bisect.bisect_right(self._functions, (address, 1 << 64, "")) - 1
        if i >= 0:
            start, size, name = self._functions[i]
            if start <= address < start + size:
                return name, address - start
        return None


def load_image(path: str | Path) -> Image:
    """Reads an ARM ELF executable.

    Parameters
    ----------
    path : str or Path
        The ELF file (e.g. ``BUILD/stm32-uart/psm.elf``).

    Returns
    -------
    Image
        Its loadable segments at their load addresses and its symbols.

    Raises
    ------
    EmulationError
        When the file is not a 32-bit little-endian ARM ELF executable.
    """
    from elftools.common.exceptions import ELFError
    from elftools.elf.elffile import ELFFile

    path = Path(path)
    try:
        with path.open("rb") as f:
            elf = ELFFile(f)
            if elf["e_machine"] != EM_ARM or elf.elfclass != 32 or not elf.little_endian:
                raise EmulationError(f"{path}: not a 32-bit little-endian ARM ELF "
                                     f"(machine {elf['e_machine']}, class {elf.elfclass})")
            segments = [(int(s["p_paddr"]), s.data()) for s in elf.iter_segments()
                        if s["p_type"] == "PT_LOAD" and s["p_filesz"] > 0]
            symbols: dict[str, int] = {}
            sizes: dict[str, int] = {}
            functions: list[tuple[int, int, str]] = []
            table = elf.get_section_by_name(".symtab")
            for sym in (table.iter_symbols() if table is not None else ()):
                kind = sym["st_info"]["type"]
                if not sym.name or kind not in ("STT_FUNC", "STT_OBJECT", "STT_NOTYPE"):
                    continue
                if sym["st_shndx"] == "SHN_UNDEF" or sym.name.startswith("$"):
                    continue  # undefined, or an ARM mapping symbol ($t, $d)
                address = int(sym["st_value"]) & ~1 if kind == "STT_FUNC" else int(sym["st_value"])
                # a global wins over a local of the same name (static functions may repeat)
                if sym.name not in symbols or sym["st_info"]["bind"] == "STB_GLOBAL":
                    symbols[sym.name] = address
                    sizes[sym.name] = int(sym["st_size"])
                if kind == "STT_FUNC" and sym["st_size"] > 0:
                    functions.append((address, int(sym["st_size"]), sym.name))
            entry = int(elf["e_entry"]) & ~1
    except (OSError, ELFError) as exc:
        raise EmulationError(f"{path}: cannot read the ELF image ({exc})") from None
    functions.sort()
    return Image(path, segments, entry, symbols, sizes, functions)

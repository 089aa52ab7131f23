"""Finding psmat boxes among the serial ports (USB CDC-ACM, firmware/README.md).

The BluePill firmware enumerates with VID:PID 1209:0001 (a pid.codes *test* PID, to be
replaced by an allocated one before boxes ship) and the product string "psmat ...".
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["PSMAT_USB_IDS", "FoundPort", "find_devices", "is_psmat_port"]

#: (VID, PID) pairs of psmat firmware (test PID, see the module docstring).
PSMAT_USB_IDS: tuple[tuple[int, int], ...] = ((0x1209, 0x0001),)


@dataclass(frozen=True)
class FoundPort:
    port: str  # e.g. /dev/ttyACM0, COM4
    description: str
    serial_number: str | None


def is_psmat_port(vid: int | None, pid: int | None, product: str | None = None,
                  manufacturer: str | None = None) -> bool:
    """Whether a USB serial port's identity is a psmat box's (VID:PID, or "psmat" in its strings)."""
    if vid is not None and (vid, pid) in PSMAT_USB_IDS:
        return True
    return any("psmat" in (text or "").lower() for text in (product, manufacturer))


def find_devices() -> list[FoundPort]:
    """Serial ports that look like psmat boxes (by USB VID:PID or product string), sorted."""
    from serial.tools import list_ports

    found = []
    for p in list_ports.comports():
        if is_psmat_port(p.vid, p.pid, p.product, p.manufacturer):
            found.append(FoundPort(p.device, p.description or "", p.serial_number))
    return sorted(found, key=lambda f: f.port)

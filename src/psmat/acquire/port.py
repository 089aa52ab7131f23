"""Opening a device's serial port with pyserial (real ports, ptys and ``loop://`` URLs)."""

from __future__ import annotations

import errno
from typing import Any

import serial

__all__ = ["open_port", "is_url"]

#: pyserial read timeout of the reader thread (s): bounds how long stop/close wait for it.
READ_TIMEOUT_S = 0.05


def is_url(port: str) -> bool:
    """True for a pyserial URL such as ``loop://`` or ``socket://host:port``."""
    return "://" in port


def open_port(port: str, baudrate: int, timeout: float = READ_TIMEOUT_S) -> Any:
    """Open ``port`` (a device path or a pyserial URL) for the reader thread.

    Parameters
    ----------
    port : str
        ``/dev/ttyACM0``, ``/dev/pts/3``, ``COM4``, ``loop://``, ...
    baudrate : int
        Bit/s (ignored by USB CDC devices and ptys, used by real UARTs).
    timeout : float
        Read timeout (s).

    Returns
    -------
    serial.SerialBase
        The open port. On a real port DTR is asserted: the BluePill's USB CDC only sends
        while the host holds DTR (ptys, which have no modem lines, are accepted as is).

    Raises
    ------
    serial.SerialException
        The port cannot be opened.
    """
    ser = serial.serial_for_url(port, baudrate=baudrate, timeout=timeout, write_timeout=1.0, do_not_open=True)
    ser.dtr = True  # applied by open() (errors from ptys' missing modem lines are ignored there)
    ser.open()
    if not is_url(port):
        try:
            ser.dtr = True
        except (OSError, serial.SerialException) as exc:  # a pty has no modem lines
            if getattr(exc, "errno", None) not in (None, errno.EINVAL, errno.ENOTTY):
                ser.close()
                raise
    return ser

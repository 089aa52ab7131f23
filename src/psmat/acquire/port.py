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
        The port cannot be opened, or another program (a second psmat host) holds it.
    """
    # exclusive: on POSIX pyserial takes an flock before it changes settings or flushes input,
    # so a second host is refused instead of stealing bytes (URLs such as loop:// ignore it)
    ser = serial.serial_for_url(port, baudrate=baudrate, timeout=timeout, write_timeout=1.0, exclusive=True,
                                do_not_open=True)
    ser.dtr = True  # applied by open() (errors from ptys' missing modem lines are ignored there)
    try:
        ser.open()
    except serial.SerialException as exc:
        if exc.errno in (errno.EAGAIN, errno.EWOULDBLOCK):   # the flock is held elsewhere
            raise serial.SerialException(exc.errno, f"{port} is in use by another program (its exclusive lock "
                                                    "is held)") from None
        raise
    if not is_url(port):
        try:
            ser.dtr = True
        except (OSError, serial.SerialException) as exc:  # a pty has no modem lines
            if getattr(exc, "errno", None) not in (None, errno.EINVAL, errno.ENOTTY):
                ser.close()
                raise
    return ser

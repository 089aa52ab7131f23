"""Opening and reading a device's serial port with pyserial: device paths and pyserial URLs.

A device path (``/dev/ttyACM0``, a pty, ``COM4``) is opened exclusively (on POSIX pyserial
takes an flock; Windows opens COM ports exclusively itself) with DTR asserted. A URL
(``socket://HOST:PORT``, ``rfc2217://HOST:PORT``, ``loop://``, ... see pyserial's
``serial_for_url``) goes through pyserial's own handler: no termios, no lock (the other end
decides who it serves: the twin serves one host at a time), DTR only where the handler
forwards it (``rfc2217://``). Re-opening after a disconnect is the same call: a ``socket://``
port connects again.
"""

from __future__ import annotations

import errno
import os
from typing import Any
from urllib.parse import urlsplit

import serial
from serial.urlhandler.protocol_socket import Serial as _SocketSerial

__all__ = ["open_port", "is_url", "read_chunk", "close_port"]

#: URL schemes whose address is HOST:PORT
_HOST_PORT_SCHEMES = ("socket", "rfc2217")
#: bytes taken at most in one read from a ``socket://`` port
_SOCKET_CHUNK = 65536

#: pyserial read timeout of the reader thread (s): bounds how long stop/close wait for it.
READ_TIMEOUT_S = 0.05


def is_url(port: str) -> bool:
    """True for a pyserial URL such as ``loop://`` or ``socket://host:port``."""
    return "://" in port


#: The first 8 bytes of every HDF5 file (HDF5 file format specification, the superblock).
HDF5_SIGNATURE = b"\x89HDF\r\n\x1a\n"


def open_port(port: str, baudrate: int, timeout_s: float = READ_TIMEOUT_S) -> Any:
    """Open ``port`` (a device path or a pyserial URL) for the reader thread.

    Parameters
    ----------
    port : str
        ``/dev/ttyACM0``, ``/dev/pts/3``, ``COM4``, or a pyserial URL: ``socket://127.0.0.1:5555``,
        ``rfc2217://host:2217``, ``loop://``, ...
    baudrate : int
        Bit/s (ignored by USB CDC devices and ptys, used by real UARTs).
    timeout_s : float
        Read timeout (s).

    Returns
    -------
    serial.SerialBase
        The open port. On a real port DTR is asserted: the BluePill's USB CDC only sends
        while the host holds DTR (ptys, which have no modem lines, are accepted as is).

    Raises
    ------
    serial.SerialException
        The port cannot be opened, another program (a second psmat host) holds it, or the
        URL is malformed or of a scheme pyserial does not know.
    """
    if is_url(port):
        _check_url(port)
    elif os.path.isfile(port):  # a recording given where a device is expected: say what reads it
        with open(port, "rb") as f:
            session = f.read(8) == HDF5_SIGNATURE
        if session:
            raise serial.SerialException(f"{port} is a session file (HDF5), not a serial port: `psmat info {port}` "
                                         f"summarises a recorded session, `psmat process {port}` computes its "
                                         f"pressure and CoP, `psmat export {port}` writes it as CSV, Parquet or "
                                         "MATLAB (psmat.io.load_session from Python)")
        raise serial.SerialException(f"{port} is a regular file, not a serial port (a device such as /dev/ttyACM0 "
                                     "or COM4, or a pyserial URL such as socket://HOST:PORT)")
    # exclusive: on POSIX pyserial takes an flock before it changes settings or flushes input,
    # so a second host is refused instead of stealing bytes (URLs such as loop:// ignore it)
    try:
        ser = serial.serial_for_url(port, baudrate=baudrate, timeout=timeout_s, write_timeout=1.0, exclusive=True,
                                    do_not_open=True)
    except ValueError as exc:  # an unknown scheme
        raise serial.SerialException(f"{port}: {exc} (pyserial knows socket://HOST:PORT, rfc2217://HOST:PORT, "
                                     "loop://, ...)") from None
    ser.dtr = True  # applied by open() (errors from ptys' missing modem lines are ignored there)
    try:
        ser.open()
    except serial.SerialException as exc:
        if exc.errno in (errno.EAGAIN, errno.EWOULDBLOCK):   # the flock is held elsewhere
            raise _said(exc.errno, f"{port} is in use by another program (its exclusive lock is held)") from None
        if exc.errno == errno.ENOENT:
            raise _said(exc.errno, f"{port}: no such port; {ports_here()}") from None
        if exc.errno == errno.EACCES:
            raise _said(exc.errno, f"{port}: permission denied{_group_hint(port)}") from None
        raise
    if not is_url(port):
        try:
            ser.dtr = True
        except (OSError, serial.SerialException) as exc:  # a pty has no modem lines
            if getattr(exc, "errno", None) not in (None, errno.EINVAL, errno.ENOTTY):
                ser.close()
                raise
    return ser


def _said(code: int, line: str) -> serial.SerialException:
    """A SerialException that reads as ``line`` alone (no "[Errno N]") and keeps its ``errno``."""
    exc = serial.SerialException(line)
    exc.errno = code
    return exc


def ports_here() -> str:
    """The serial ports of this computer as one clause (pyserial's ``list_ports``; psmat boxes marked)."""
    from serial.tools import list_ports

    from ._discover import is_psmat_port

    found = sorted(list_ports.comports(), key=lambda p: p.device)
    if not found:
        return "this computer has no serial port now: is the board plugged in, with a USB cable that carries data?"
    said = []
    for p in found:
        what = p.description if p.description not in (None, "", "n/a") else "no description"
        box = ", a psmat box" if is_psmat_port(p.vid, p.pid, p.product, p.manufacturer) else ""
        said.append(f"{p.device} ({what}{box})")
    return "serial ports here: " + ", ".join(said)


def _group_hint(port: str) -> str:
    """Why a device file cannot be opened, where it says: the group that may (on Linux a serial port
    belongs to ``dialout`` or ``uucp``, which a new user is not in)."""
    try:
        import grp

        group = grp.getgrgid(os.stat(port).st_gid).gr_name
    except (ImportError, OSError, KeyError):
        return ""
    return (f": this user may not open it; the group {group!r} may: `sudo usermod -aG {group} $USER`, then log "
            "out and in again")


def _check_url(port: str) -> None:
    """One clear line for a ``socket://`` or ``rfc2217://`` URL without a host or a port."""
    scheme = port.partition("://")[0].lower()
    if scheme not in _HOST_PORT_SCHEMES:
        return
    parts = urlsplit(port)
    try:
        number = parts.port
    except ValueError:
        number = None
    if not parts.hostname or number is None:
        raise serial.SerialException(f"{port}: a {scheme} URL is {scheme}://HOST:PORT with PORT 0 ... 65535, "
                                     f"e.g. {scheme}://127.0.0.1:5555")


def read_chunk(ser: Any) -> bytes:
    """The bytes the port has, waiting up to its read timeout for the first one.

    ``in_waiting`` counts the bytes a real port, a pty or ``loop://`` holds, so they are read
    in one call; a ``socket://`` port only says whether the socket is readable (0 or 1), so
    there the first byte is awaited and the rest taken without waiting.

    Parameters
    ----------
    ser : serial.SerialBase
        An open port from :func:`open_port`.

    Returns
    -------
    bytes
        Empty when the timeout ended with nothing received.

    Raises
    ------
    serial.SerialException, OSError
        The port is gone (a ``socket://`` peer that closed: ``socket disconnected``).
    """
    if not isinstance(ser, _SocketSerial):
        return ser.read(max(1, ser.in_waiting))
    first = ser.read(1)
    if not first:
        return first
    timeout = ser.timeout
    ser.timeout = 0  # non-blocking: one recv of what the socket holds (a no-op reconfiguration here)
    try:
        return first + ser.read(_SOCKET_CHUNK)
    finally:
        ser.timeout = timeout


def close_port(ser: Any) -> None:
    """Close a port from :func:`open_port`, whatever state its link is in; never raises.

    pyserial's ``socket://`` handler skips closing its socket when ``shutdown`` fails (a
    peer that already reset the connection), leaving it to the garbage collector; it is
    closed here.
    """
    sock = getattr(ser, "_socket", None) if isinstance(ser, _SocketSerial) else None
    try:
        ser.close()
    except Exception:  # noqa: BLE001 - closing a vanished port
        pass
    finally:
        if sock is not None:
            sock.close()

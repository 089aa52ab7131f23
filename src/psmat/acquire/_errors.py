"""Exceptions raised by :mod:`psmat.acquire`."""

from __future__ import annotations

from typing import Any

__all__ = ["AcquireError", "DeviceDisconnected", "CommandTimeout", "CommandRejected"]


class AcquireError(Exception):
    """Base class of the acquisition errors (port, link and command problems)."""


class DeviceDisconnected(AcquireError, ConnectionError):
    """The serial port vanished (unplugged, pty closed) and the device is not coming back.

    Raised by :meth:`~psmat.acquire.Device.read` once the buffered frames have been
    returned, and by commands sent to a disconnected device.

    Attributes
    ----------
    port : str
        The port name or URL.
    cause : str or None
        The error the reader saw (e.g. ``"read failed: [Errno 5] Input/output error"``).
    """

    def __init__(self, port: str, cause: str | None = None, what: str = "device") -> None:
        self.port = port
        self.cause = cause
        msg = f"{what} on {port} is disconnected"
        if cause:
            msg += f" ({cause})"
        super().__init__(msg)

    def __reduce__(self) -> tuple[Any, ...]:  # pragma: no cover - pickling support
        return (type(self), (self.port, self.cause))


class CommandTimeout(AcquireError, TimeoutError):
    """No reply to a command within its timeout."""


class CommandRejected(AcquireError):
    """The device answered a command with a non-OK status.

    Attributes
    ----------
    reply : psmat.protocol.Reply
        The device's reply (``status`` is 1 = bad argument, 2 = unknown opcode).
    """

    def __init__(self, message: str, reply: Any) -> None:
        super().__init__(message)
        self.reply = reply

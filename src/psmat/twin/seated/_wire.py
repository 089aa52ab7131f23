"""What the back device sends for given readings (docs/spec.md §5): the IMU firmware core of the serial
twin (:class:`psmat.twin.SerialTwin` with ``kind="imu"``, ``firmware/core`` compiled into
``psmat._core.firmware``), ticked at given timer stamps instead of in real time.

A simulated recording (:mod:`psmat.synth`) goes through here, so its bytes are the device's own:
the same framing, sequence numbers, CRC and IDENTIFY reply as on a serial port.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from ... import protocol as _protocol
from ..._core import firmware as _fw

__all__ = ["imu_packets", "imu_identity"]


def _core(serial: str, protocol: str) -> Any:
    if protocol not in ("v1", "v2"):
        raise ValueError(f"protocol must be 'v1' or 'v2', got {protocol!r}")
    return _fw.ImuFirmware(1 if protocol == "v1" else 2, serial)


def imu_packets(angles_deg: ArrayLike, t_us: ArrayLike, serial: str, protocol: str = "v2") -> bytes:
    """The bytes the back device sends for the readings ``angles_deg`` (T, 5, 3) degrees taken at its
    timer's ``t_us`` (T,) µs (wrapped to 32 bits as the MCU's counter): one packet per reading.

    Parameters
    ----------
    angles_deg : array_like, (T, 5, 3)
        Heading, roll, pitch of each sensor, degrees (sent as float32).
    t_us : array_like of int, (T,)
        The device clock at each reading, µs.
    serial : str
        The device's serial number (its IDENTIFY reply).
    protocol : {"v1", "v2"}
        The framing (v2: sequence number, µs stamp and CRC).
    """
    a = np.asarray(angles_deg, dtype=np.float32)
    stamps = np.asarray(t_us, dtype=np.int64)
    if a.ndim != 3 or a.shape[1:] != _protocol.IMU_SHAPE or stamps.shape != a.shape[:1]:
        raise ValueError(f"angles_deg must be (T, 5, 3) degrees and t_us (T,) µs, got {a.shape} and {stamps.shape}")
    core = _core(serial, protocol)
    return b"".join(core.tick(x, int(s) & 0xFFFFFFFF) for x, s in zip(a, stamps))


def imu_identity(serial: str) -> dict[str, Any]:
    """The back device's reply to IDENTIFY (a v2 command), parsed: what ``psmat record`` stores as the
    stream's device."""
    core = _core(serial, "v2")
    events = _protocol.V2Decoder().feed(core.receive(_protocol.encode_command(_protocol.Opcode.IDENTIFY)))
    return _protocol.parse_identify(next(e.text for e in events if isinstance(e, _protocol.Reply)))

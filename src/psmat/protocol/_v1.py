"""Protocol v1 framing, thesis-compatible (docs/protocol.md, docs/spec.md §5; thesis Code 2.1-2.2).

PSM frame::

    INIT INIT | cell[0] lo hi | ... | cell[R*C-1] lo hi | check lo hi

with ``INIT = 0xFF``, cells 12-bit counts as little-endian uint16 in row-major order and
``check = (sum of cells) mod 4096``; ``2 + 2*R*C + 2`` bytes (516 for 16x16). The shape is not
on the wire. Every high byte is <= 0x0F, so ``0xFF 0xFF`` never occurs inside a valid frame.

IMU frame (spine DAQ): ``INIT INIT | 60 payload bytes | check lo hi``, the payload being the
15 float32 Euler angles (degrees, sensor-major, shape (5, 3)) and ``check`` the sum of the
payload read as 30 little-endian uint16 words, mod 4096.
"""

from __future__ import annotations


import numpy as np
from numpy.typing import ArrayLike

from .._checks import float32_frame, int_frame, shape2

__all__ = [
    "INIT", "V1_MAX_COUNT", "IMU_SHAPE",
    "v1_frame_size", "encode_v1", "encode_v1_many", "encode_imu_v1",
]

#: Frame marker byte; a frame starts with two of them.
INIT: int = 0xFF
#: Largest cell value (12-bit ADC).
V1_MAX_COUNT: int = 4095
#: Shape of one IMU sample: 5 sensors x (heading, roll, pitch), degrees.
IMU_SHAPE: tuple[int, int] = (5, 3)


def v1_frame_size(shape: tuple[int, int]) -> int:
    """Bytes in one v1 PSM frame of ``shape = (R, C)``: ``2 + 2*R*C + 2``."""
    r, c = shape2(shape)
    return 4 + 2 * r * c


def encode_v1(frame: ArrayLike) -> bytes:
    """Encode one PSM frame in protocol v1.

    Parameters
    ----------
    frame : array_like of int, shape (R, C)
        ADC counts, each in ``[0, 4095]``; row-major on the wire.

    Returns
    -------
    bytes
        ``0xFF 0xFF``, the cells as little-endian uint16, ``sum mod 4096`` as little-endian
        uint16.

    Raises
    ------
    TypeError
        ``frame`` is not an integer array.
    ValueError
        Wrong shape, or a value outside ``[0, 4095]``.
    """
    arr = int_frame(frame, "frame", V1_MAX_COUNT)
    cells = arr.astype("<u2")
    check = int(cells.sum(dtype=np.int64)) & 0xFFF
    return b"\xff\xff" + cells.tobytes() + check.to_bytes(2, "little")


def encode_v1_many(frames: ArrayLike) -> bytes:
    """Encode a sequence of PSM frames, shape (N, R, C), into one v1 byte stream (vectorised).

    Same bytes as ``b"".join(encode_v1(f) for f in frames)``; same errors as :func:`encode_v1`.
    """
    arr = np.asarray(frames)
    if arr.ndim != 3:
        raise ValueError(f"frames must have shape (N, R, C), got {arr.shape}")
    n, r, c = arr.shape
    if arr.dtype == np.bool_ or not np.issubdtype(arr.dtype, np.integer):
        raise TypeError(f"frames must be an integer array (counts), got dtype {arr.dtype}")
    if r < 1 or c < 1:
        raise ValueError(f"frames must have shape (N, R, C) with R, C >= 1, got {arr.shape}")
    if n == 0:
        return b""
    int_frame(arr.reshape(n * r, c), "frames", V1_MAX_COUNT)
    cells = arr.reshape(n, r * c).astype("<u2")
    out = np.empty((n, 4 + 2 * r * c), dtype=np.uint8)
    out[:, :2] = INIT
    out[:, 2:-2] = cells.view(np.uint8)
    check = (cells.sum(axis=1, dtype=np.int64) & 0xFFF).astype("<u2")
    out[:, -2:] = check.view(np.uint8).reshape(n, 2)
    return out.tobytes()


def encode_imu_v1(angles_deg: ArrayLike) -> bytes:
    """Encode one spine-IMU sample in v1 framing.

    Parameters
    ----------
    angles_deg : array_like of float, shape (5, 3)
        Euler angles in degrees, ``angles_deg[s] = (heading, roll, pitch)`` of sensor ``s``;
        sent as little-endian float32 (finite values only).

    Returns
    -------
    bytes
        ``0xFF 0xFF``, 60 payload bytes, check (sum of the 30 payload uint16 words mod 4096).
    """
    arr = float32_frame(angles_deg, "angles_deg")
    if arr.shape != IMU_SHAPE:
        raise ValueError(f"angles_deg must have shape {IMU_SHAPE}, got {arr.shape}")
    payload = arr.astype("<f4").tobytes()
    check = int(np.frombuffer(payload, dtype="<u2").sum(dtype=np.int64)) & 0xFFF
    return b"\xff\xff" + payload + check.to_bytes(2, "little")

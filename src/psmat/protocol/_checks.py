"""Input validation shared by the encoders (private)."""

from __future__ import annotations

import numbers
from typing import Any

import numpy as np
from numpy.typing import NDArray


def int_frame(frame: Any, name: str, max_value: int) -> NDArray[np.int64]:
    """A 2-D integer array with every value in ``[0, max_value]`` (else TypeError/ValueError)."""
    arr = np.asarray(frame)
    if arr.dtype == np.bool_ or not np.issubdtype(arr.dtype, np.integer):
        raise TypeError(f"{name} must be an integer array (counts), got dtype {arr.dtype}")
    if arr.ndim != 2 or arr.shape[0] < 1 or arr.shape[1] < 1:
        raise ValueError(f"{name} must have shape (R, C) with R, C >= 1, got {arr.shape}")
    lo, hi = int(arr.min()), int(arr.max())
    if lo < 0 or hi > max_value:
        raise ValueError(f"{name} values must lie in [0, {max_value}], got range [{lo}, {hi}]")
    return arr


def float32_frame(frame: Any, name: str) -> NDArray[np.float32]:
    """A 2-D real array of finite values representable as float32, returned as float32."""
    arr = np.asarray(frame)
    if arr.dtype == np.bool_ or not (np.issubdtype(arr.dtype, np.floating) or np.issubdtype(arr.dtype, np.integer)):
        raise TypeError(f"{name} must be a real array, got dtype {arr.dtype}")
    if arr.ndim != 2 or arr.shape[0] < 1 or arr.shape[1] < 1:
        raise ValueError(f"{name} must have shape (R, C) with R, C >= 1, got {arr.shape}")
    f64 = arr.astype(np.float64)
    if not np.all(np.isfinite(f64)):
        raise ValueError(f"{name} must be finite")
    if np.any(np.abs(f64) > float(np.finfo(np.float32).max)):
        raise ValueError(f"{name} values exceed the float32 range")
    return f64.astype(np.float32)


def uint(value: Any, name: str, bits: int, *, wrap: bool = False) -> int:
    """A non-negative integer below ``2**bits`` (reduced modulo ``2**bits`` if ``wrap``)."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Integral):
        raise TypeError(f"{name} must be an integer, got {type(value).__name__}")
    v = int(value)
    if v < 0:
        raise ValueError(f"{name} must be >= 0, got {v}")
    if wrap:
        return v % (1 << bits)
    if v >= 1 << bits:
        raise ValueError(f"{name} must be < 2**{bits}, got {v}")
    return v


def shape2(shape: Any) -> tuple[int, int]:
    """A frame shape ``(R, C)`` of two positive integers."""
    try:
        r, c = shape
    except (TypeError, ValueError):
        raise ValueError(f"shape must be a pair (R, C), got {shape!r}") from None
    for v in (r, c):
        if isinstance(v, (bool, np.bool_)) or not isinstance(v, numbers.Integral):
            raise TypeError(f"shape must hold integers, got {shape!r}")
    if r < 1 or c < 1:
        raise ValueError(f"shape must be positive, got {shape!r}")
    return int(r), int(c)


def as_bytes(data: Any, name: str = "data") -> bytes | bytearray | memoryview:
    if isinstance(data, (bytes, bytearray, memoryview)):
        return data
    raise TypeError(f"{name} must be bytes-like, got {type(data).__name__}")

"""Input validation for the whole package, in one module.

Every public function of psmat that takes numbers from a user checks them here and raises
one clear, one-line error naming the argument: ``TypeError`` for the wrong kind of value
(a string, a float where an integer count is meant, a boolean), ``ValueError`` for the right
kind out of range. Nothing here converts silently (no rounding of 2.5 cells to 2).
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Callable
from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = [
    "is_int",
    "shape2",
    "positive",
    "finite",
    "fraction",
    "positive_int",
    "nonneg_int",
    "pair",
    "vector",
    "real_array",
    "int_frame",
    "float32_frame",
    "uint",
    "as_bytes",
    "first_bad",
    "real_dtype",
    "positive_scalar",
    "finite_values",
    "nonnegative",
    "conductances",
    "MAX_RATE_HZ",
    "MAX_SESSION_S",
    "rate_hz",
    "duration_s",
    "int_at_most",
]

#: The fastest frame rate a psmat device takes (frames/s): the PSM firmware's SET_RATE range is
#: 1 ... 1000 (firmware/core/psm_core.h, ``PSM_RATE_MAX``; docs/spec.md §5: 100 Hz by default,
#: 165 Hz or more at most). Nothing psmat records or simulates runs faster.
MAX_RATE_HZ = 1000
#: The longest simulated session (s): an hour, sixty times a thesis balance trial (60 s,
#: docs/spec.md §7) and twenty times a posture session (about 175 s, §8); a simulation holds a
#: whole session's times and trajectory in memory.
MAX_SESSION_S = 3600.0


def is_int(value: Any) -> bool:
    """True for a Python or NumPy integer (booleans excluded)."""
    return isinstance(value, numbers.Integral) and not isinstance(value, (bool, np.bool_))


def _scalar(name: str, value: Any, what: str) -> float:
    if np.ndim(value) != 0:
        raise ValueError(f"{name} must be a single number, got an array of shape {np.shape(value)}")
    if isinstance(value, (str, bytes)):
        raise ValueError(f"{name} must be {what}, got {value!r}")
    try:
        return float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be {what}, got {value!r}") from None


def shape2(shape: Any, name: str = "shape") -> tuple[int, int]:
    """A frame shape ``(R, C)`` of two positive integers."""
    try:
        dims = tuple(shape)
    except TypeError:
        raise ValueError(f"{name} must be a pair (rows, cols), got {shape!r}") from None
    if len(dims) != 2:
        raise ValueError(f"{name} must be a pair (rows, cols), got {shape!r}")
    for d in dims:
        if not is_int(d):
            raise TypeError(f"{name} must hold two integers (rows, cols), got {shape!r}")
        if d < 1:
            raise ValueError(f"{name} must hold two positive integers (rows, cols), got {shape!r}")
    return int(dims[0]), int(dims[1])


def positive(name: str, value: Any) -> float:
    """A finite number > 0, as float."""
    v = _scalar(name, value, "a positive number")
    if not (math.isfinite(v) and v > 0):
        raise ValueError(f"{name} must be a finite number > 0, got {value!r}")
    return v


def finite(name: str, value: Any) -> float:
    """A finite number, as float."""
    v = _scalar(name, value, "a finite number")
    if not math.isfinite(v):
        raise ValueError(f"{name} must be a finite number, got {value!r}")
    return v


def fraction(name: str, value: Any, lo: float = 0.0, hi: float = 1.0) -> float:
    """A finite number in ``[lo, hi]``."""
    v = finite(name, value)
    if not lo <= v <= hi:
        raise ValueError(f"{name} must lie in [{lo}, {hi}], got {value!r}")
    return v


def positive_int(name: str, value: Any, minimum: int = 1) -> int:
    """An integer (not a float, not a bool) ``>= minimum``."""
    if not is_int(value):
        raise ValueError(f"{name} must be an integer >= {minimum}, got {value!r}")
    if value < minimum:
        raise ValueError(f"{name} must be an integer >= {minimum}, got {value!r}")
    return int(value)


def nonneg_int(name: str, value: Any) -> int:
    """An integer ``>= 0`` (seeds, indices)."""
    if not is_int(value) or value < 0:
        raise ValueError(f"{name} must be a non-negative integer, got {value!r}")
    return int(value)


def pair(name: str, value: Any, *, nonneg: bool = True, labels: str = "ML, AP") -> tuple[float, float]:
    """Two finite numbers (``>= 0`` unless ``nonneg=False``)."""
    a = None if isinstance(value, (str, bytes)) else np.asarray(value, dtype=np.float64)
    if a is None or a.shape != (2,) or not np.all(np.isfinite(a)) or (nonneg and np.any(a < 0)):
        kind = "non-negative finite" if nonneg else "finite"
        raise ValueError(f"{name} must be a pair of {kind} numbers ({labels}), got {value!r}")
    return float(a[0]), float(a[1])


def vector(name: str, value: Any) -> NDArray[np.float64]:
    """A 1-D float64 array of finite numbers."""
    try:
        a = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a 1-D array of numbers") from None
    if a.ndim != 1:
        raise ValueError(f"{name} must be 1-D, got shape {a.shape}")
    if not np.all(np.isfinite(a)):
        bad = int(np.flatnonzero(~np.isfinite(a))[0])
        raise ValueError(f"{name} must be finite; sample {bad} is {a[bad]!r}")
    return a


def real_array(value: Any, name: str, *, unit: str = "", allow_nan: bool = False) -> NDArray[np.float64]:
    """A C-contiguous float64 copy of a real (integer or floating) array, finite unless ``allow_nan``."""
    a = np.asarray(value)
    if a.dtype == object or a.dtype == np.bool_ or not (
        np.issubdtype(a.dtype, np.floating) or np.issubdtype(a.dtype, np.integer)
    ):
        raise TypeError(f"{name} must be a real numeric array{f' ({unit})' if unit else ''}, got dtype {a.dtype}")
    a = np.array(a, dtype=np.float64, order="C")  # a copy; keeps 0-d scalars 0-d
    bad = np.isinf(a) if allow_nan else ~np.isfinite(a)
    if bad.any():
        first = tuple(int(i) for i in np.argwhere(bad)[0])
        raise ValueError(f"{name} has {int(bad.sum())} non-finite value(s), first at {first}")
    return a


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
    if not is_int(value):
        raise TypeError(f"{name} must be an integer, got {type(value).__name__}")
    v = int(value)
    if v < 0:
        raise ValueError(f"{name} must be >= 0, got {v}")
    if wrap:
        return v % (1 << bits)
    if v >= 1 << bits:
        raise ValueError(f"{name} must be < 2**{bits}, got {v}")
    return v


def as_bytes(data: Any, name: str = "data") -> bytes | bytearray | memoryview:
    """``data`` itself if it is bytes-like, else TypeError."""
    if isinstance(data, (bytes, bytearray, memoryview)):
        return data
    raise TypeError(f"{name} must be bytes-like, got {type(data).__name__}")


def first_bad(mask: NDArray[np.bool_]) -> tuple[int, ...]:
    """Index (as a tuple) of the first True element of ``mask`` in C order."""
    flat = int(np.flatnonzero(mask)[0])
    return tuple(int(k) for k in np.unravel_index(flat, mask.shape))


def real_dtype(name: str, value: Any) -> NDArray[Any]:
    """``value`` as an ndarray of a real numeric dtype, not converted (NaN/inf are the caller's);
    complex, object, str or bool → TypeError."""
    arr = np.asarray(value)
    if arr.dtype.kind not in "iuf":
        raise TypeError(f"{name} must be a real numeric array, got dtype {arr.dtype}")
    return arr


def positive_scalar(name: str, value: Any, *, allow_inf: bool = False) -> float:
    """A real number > 0 (finite unless ``allow_inf``); TypeError for anything but a real number
    (a string included), where :func:`positive` answers ValueError."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise TypeError(f"{name} must be a real number, got {type(value).__name__}")
    v = float(value)
    if math.isnan(v) or v <= 0 or (math.isinf(v) and not allow_inf):
        raise ValueError(f"{name} must be {'> 0' if allow_inf else 'finite and > 0'}, got {value!r}")
    return v


def finite_values(a: NDArray[Any], name: str, *, where: Callable[[tuple[int, ...]], str] = str) -> None:
    """ValueError counting the NaN/inf entries of ``a`` and naming the first (``where`` formats
    its index)."""
    bad = ~np.isfinite(a)
    if bad.any():
        raise ValueError(f"{name} has {int(bad.sum())} non-finite value(s) (NaN/inf), first at {where(first_bad(bad))}")


def nonnegative(a: NDArray[Any], name: str, *, allow_zero: bool = True, noun: str = "value(s)",
                where: Callable[[tuple[int, ...]], str] = str, hint: str = "") -> None:
    """ValueError counting the negative (or, unless ``allow_zero``, zero or negative) entries of
    ``a`` and naming the first (``where`` formats its index; ``hint`` ends the message)."""
    bad = a < 0 if allow_zero else a <= 0
    if bad.any():
        idx = first_bad(bad)
        what = "negative" if allow_zero else "zero or negative"
        raise ValueError(f"{name} has {int(bad.sum())} {what} {noun}, first at {where(idx)} = {a[idx]!r}{hint}")


def conductances(G: Any, name: str = "G") -> NDArray[np.float64]:
    """Equivalent conductances (S) as float64: a real array, finite and >= 0."""
    g = real_dtype(name, G).astype(np.float64, copy=False)
    bad = ~np.isfinite(g)
    if bad.any():
        raise ValueError(f"{name} must be finite; non-finite value {float(g[first_bad(bad)])!r} at index {first_bad(bad)}")
    bad = g < 0
    if bad.any():
        raise ValueError(f"{name} must be >= 0 (S); negative value {float(g[first_bad(bad)])!r} at index {first_bad(bad)}")
    return g


def rate_hz(name: str, value: Any, *, maximum: float = MAX_RATE_HZ, whole: bool = False,
            limit: str = "the PSM firmware's fastest, docs/spec.md §5") -> float:
    """A frame rate (Hz): finite, > 0, at most ``maximum`` (``limit`` says why) and, with
    ``whole``, a whole number of frames per second (a firmware's timer counts whole frames)."""
    v = _scalar(name, value, "a rate in Hz")
    if not (math.isfinite(v) and v > 0):
        raise ValueError(f"{name} must be > 0 Hz, got {value!r}")
    if v > maximum:
        raise ValueError(f"{name} must be at most {maximum:g} Hz ({limit}), got {v:g}")
    if whole and v != math.floor(v):
        raise ValueError(f"{name} must be a whole number of frames per second, 1 ... {maximum:g} "
                         f"(the firmware's timer), got {v:g}")
    return v


def duration_s(name: str, value: Any, *, maximum: float = MAX_SESSION_S,
               limit: str = "an hour: the longest session psmat simulates") -> float:
    """A duration (s): finite, > 0 and at most ``maximum`` (``limit`` says why)."""
    v = positive(name, value)
    if v > maximum:
        raise ValueError(f"{name} must be at most {maximum:g} s ({limit}), got {v:g}")
    return v


def int_at_most(name: str, value: Any, maximum: int, *, minimum: int = 1, why: str = "") -> int:
    """An integer (not a float, not a bool) in ``[minimum, maximum]``; ``why`` explains the maximum."""
    if not is_int(value) or not minimum <= value <= maximum:
        raise ValueError(f"{name} must be an integer {minimum} ... {maximum}{f' ({why})' if why else ''}, "
                         f"got {value!r}")
    return int(value)

"""The IECM's conductance frames: clear errors instead of garbage (generic checks: psmat._checks)."""

from __future__ import annotations

import numpy as np

from .._checks import finite_values, nonnegative

__all__ = ["as_frames"]


def as_frames(x, name: str, *, allow_zero: bool, max_ndim: int = 3,
              measured: bool = False) -> tuple[np.ndarray, bool]:
    """Validate a conductance array of shape (R, C) or (T, R, C).

    Returns the array as C-contiguous float64 of shape (T, R, C) and whether the input was a
    single frame. Raises TypeError for non-real dtypes (and, with ``measured``, for integer
    dtypes: measured G comes from ``Circuit.conductance`` as floats, integers are raw ADC
    counts), ValueError for wrong shapes, non-finite, negative or (unless ``allow_zero``)
    zero values.
    """
    a = np.asarray(x)
    if a.dtype == object or not (np.issubdtype(a.dtype, np.floating) or np.issubdtype(a.dtype, np.integer)):
        raise TypeError(f"{name} must be a real numeric array (conductances in S), got dtype {a.dtype}")
    if measured and np.issubdtype(a.dtype, np.integer):
        raise TypeError(
            f"{name} has integer dtype {a.dtype}: raw ADC counts? IECM takes equivalent conductances in S; "
            "convert counts with psmat.Circuit().conductance(counts) (or pass floats if these are conductances)"
        )
    if a.ndim not in (2, 3) or a.ndim > max_ndim:
        allowed = "(R, C)" if max_ndim == 2 else "(R, C) or (T, R, C)"
        raise ValueError(f"{name} must have shape {allowed}, got {a.shape}")
    if a.shape[-1] < 2 or a.shape[-2] < 2:
        raise ValueError(f"{name}: arrays need at least 2 rows and 2 columns, got {a.shape[-2:]}")
    single = a.ndim == 2
    a = np.ascontiguousarray(a, dtype=np.float64)
    if single:
        a = a[None]
    if a.shape[0] == 0:
        raise ValueError(f"{name} has no frames")
    at = (lambda idx: f"cell {idx[1:]}") if single else (lambda idx: f"frame {idx[0]}, cell {idx[1:]}")
    finite_values(a, name, where=at)
    nonnegative(a, name, allow_zero=allow_zero, noun="conductance(s)", where=at,
                hint="; conductances are in S and must be > 0"
                + ("" if allow_zero else " (an open or saturated reading must be masked before IECM)"))
    return a, single


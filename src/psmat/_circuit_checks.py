"""Validation of the measurement-chain constants (SPEC §2), shared by ``Circuit`` and ``Calibration``.

One home for the checks, so that a circuit and a calibration accept and reject the same
constants with the same messages; neither module has to build the other to validate itself.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["check_constants", "first_bad", "positive_scalar", "real_array"]


def first_bad(mask: NDArray[np.bool_]) -> tuple[int, ...]:
    """Index (as a tuple) of the first True element of ``mask`` in C order."""
    flat = int(np.flatnonzero(mask)[0])
    return tuple(int(k) for k in np.unravel_index(flat, mask.shape))


def real_array(name: str, value: ArrayLike) -> NDArray[Any]:
    """Convert to an ndarray of a real numeric dtype; complex/object/str/bool → TypeError."""
    arr = np.asarray(value)
    if arr.dtype.kind not in "iuf":
        raise TypeError(f"{name} must be a real numeric array, got dtype {arr.dtype}")
    return arr


def positive_scalar(name: str, value: Any, *, allow_inf: bool = False) -> float:
    """Validate a strictly positive real scalar (finite unless ``allow_inf``)."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise TypeError(f"{name} must be a real number, got {type(value).__name__}")
    v = float(value)
    if math.isnan(v) or v <= 0 or (math.isinf(v) and not allow_inf):
        raise ValueError(f"{name} must be {'> 0' if allow_inf else 'finite and > 0'}, got {value!r}")
    return v


def check_constants(
    r_o: Any, r_mux: Any, r_adc: Any, v_ref: Any, bits: Any
) -> tuple[float, float | NDArray[np.float64], float, float, int]:
    """Validated, normalised constants of the reading circuit (SPEC §2).

    Parameters
    ----------
    r_o : float
        Divider resistor (Ω), finite and > 0.
    r_mux : float or array_like, shape (R, C)
        Series resistance of both mux channels (Ω), finite and >= 0: a scalar or one per pair.
    r_adc : float
        ADC input resistance (Ω), > 0; ``inf`` is an ideal ADC.
    v_ref : float
        Reference voltage (V), finite and > 0.
    bits : int
        ADC resolution, 1..16.

    Returns
    -------
    tuple
        ``(r_o, r_mux, r_adc, v_ref, bits)`` as floats and an int; ``r_mux`` a float or a
        read-only float64 (R, C) array.

    Raises
    ------
    TypeError
        For a non-real value or a non-integer ``bits``.
    ValueError
        For a value out of range or an ``r_mux`` that is neither scalar nor (R, C).
    """
    r_o_ = positive_scalar("r_o", r_o)
    r_adc_ = positive_scalar("r_adc", r_adc, allow_inf=True)
    v_ref_ = positive_scalar("v_ref", v_ref)
    if isinstance(bits, (bool, np.bool_)) or not isinstance(bits, (int, np.integer)):
        raise TypeError(f"bits must be an integer, got {type(bits).__name__}")
    if not 1 <= int(bits) <= 16:
        raise ValueError(f"bits must be in 1..16, got {bits}")
    rm = real_array("r_mux", r_mux).astype(np.float64)
    if rm.ndim not in (0, 2):
        raise ValueError(f"r_mux must be a scalar or an (R, C) array, got shape {rm.shape}")
    bad = ~np.isfinite(rm) | (rm < 0)
    if bad.any():
        where = "" if rm.ndim == 0 else f" at index {first_bad(bad)}"
        raise ValueError(f"r_mux must be finite and >= 0 (Ω){where}")
    if rm.ndim == 0:
        return r_o_, float(rm), r_adc_, v_ref_, int(bits)
    rm.setflags(write=False)
    return r_o_, rm, r_adc_, v_ref_, int(bits)

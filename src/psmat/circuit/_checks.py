"""Validation of the measurement-chain constants (docs/spec.md §2), shared by ``Circuit`` and ``Calibration``.

Circuit-specific: which constants a reading circuit has and their ranges (``bits`` 1..16,
``r_mux`` a scalar or one per pair, ``r_adc = inf`` for an ideal ADC), so that a circuit and
a calibration accept and reject the same constants with the same messages. The generic
checks it is built from live in :mod:`psmat._checks`.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from .._checks import first_bad, positive_scalar, real_dtype

__all__ = ["check_constants"]


def check_constants(
    r_o: Any, r_mux: Any, r_adc: Any, v_ref: Any, bits: Any
) -> tuple[float, float | NDArray[np.float64], float, float, int]:
    """Validated, normalised constants of the reading circuit (docs/spec.md §2).

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
    rm = real_dtype("r_mux", r_mux).astype(np.float64)
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

"""Random arrays of cell conductances: the case of thesis Fig. 2.11/2.13 (§2.3).

The thesis drew a 16 × 16 array of cell conductances "randomly selected between 1e-5 and
1e-2 S"; :func:`random_array` draws them log-uniformly (every decade equally likely) or
uniformly, in S.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from .._checks import nonneg_int, positive, shape2

__all__ = ["random_array"]


def random_array(
    shape: tuple[int, int] = (16, 16),
    g_range_s: tuple[float, float] = (1e-5, 1e-2),
    *,
    log: bool = True,
    seed: int | None = 0,
) -> NDArray[np.float64]:
    """Random cell conductances in ``g_range_s``, the thesis' Fig. 2.13 case.

    Parameters
    ----------
    shape : (R, C)
        Array size in cells (thesis 16 × 16).
    g_range_s : (low, high)
        Range of the conductances in S, ``0 < low <= high`` (thesis 1e-5…1e-2 S).
    log : bool
        Draw log-uniformly (default) or uniformly in g.
    seed : int or None
        Seed of :func:`numpy.random.default_rng` (None: fresh entropy).

    Returns
    -------
    ndarray, shape (R, C)
        Cell conductances g in S.
    """
    r, c = shape2(shape)
    try:
        lo_in, hi_in = g_range_s
    except (TypeError, ValueError):
        raise ValueError(f"g_range_s must be a pair (low, high) in S, got {g_range_s!r}") from None
    low, high = positive("g_range_s low", lo_in), positive("g_range_s high", hi_in)
    if low > high:
        raise ValueError(f"g_range_s must have low <= high (S), got {g_range_s!r}")
    rng = np.random.default_rng(None if seed is None else nonneg_int("seed", seed))
    if log:
        return np.exp(rng.uniform(np.log(low), np.log(high), size=(r, c)))
    return rng.uniform(low, high, size=(r, c))

"""Distances between CoP traces (thesis §3.2, docs/spec.md §7)."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

__all__ = ["eu"]


def eu(a: ArrayLike, b: ArrayLike) -> float:
    """Eu = sqrt(Σ_i d_i²) / N (eq. 3.1; note the division by N, not sqrt(N)).

    ``a`` and ``b`` are (N, 2) CoP traces (or (N,) components, for Eu_ML and Eu_AP, eq. 3.2)
    on the same time base; ``d_i`` is the Euclidean distance between sample i of each.
    """
    a, b = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    if a.shape != b.shape or a.ndim not in (1, 2) or a.shape[0] == 0:
        raise ValueError(f"a and b must be equal-shaped (N,) or (N, 2) traces, got {a.shape} and {b.shape}")
    if not (np.all(np.isfinite(a)) and np.all(np.isfinite(b))):
        raise ValueError("a and b must be finite (drop missing samples first)")
    d2 = (a - b) ** 2 if a.ndim == 1 else np.sum((a - b) ** 2, axis=1)
    return float(np.sqrt(d2.sum()) / a.shape[0])

"""Centre of pressure of pressure images (docs/spec.md §7).

``x = Σ p·x_cell / Σ p`` over cell centres: x is medial–lateral along the columns, y
anterior–posterior along the rows, in cm. The origin is the centre of cell (0, 0), so cell
(i, p) sits at ``(p·pitch, i·pitch)`` — the convention of :mod:`psmat.twin.field`.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["cop", "cell_centres_cm"]


def cell_centres_cm(shape: tuple[int, int], pitch_cm: float = 2.0) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """x (columns) and y (rows) of the cell centres, cm: two (C,) and (R,) vectors."""
    R, C = shape
    return np.arange(C) * float(pitch_cm), np.arange(R) * float(pitch_cm)


def cop(pressure: ArrayLike, pitch_cm: float = 2.0) -> NDArray[np.float64]:
    """Centre of pressure, cm.

    Parameters
    ----------
    pressure : array_like, (..., R, C)
        Pressure images (any unit: the CoP does not depend on it), >= 0, e.g. (T, R, C) or
        one (R, C) frame; NaN cells (missing readings) are left out of both sums.
    pitch_cm : float
        Cell pitch (thesis mat: 2 cm).

    Returns
    -------
    ndarray, (..., 2)
        (x, y) = (M-L, A-P) in cm; NaN for a frame with no pressure on it.
    """
    p = np.asarray(pressure, dtype=np.float64)
    if p.ndim < 2:
        raise ValueError(f"pressure must be (..., R, C), got shape {p.shape}")
    if not (np.isfinite(pitch_cm) and pitch_cm > 0):
        raise ValueError(f"pitch_cm must be positive, got {pitch_cm}")
    if np.any(p < 0):
        idx = tuple(int(v) for v in np.argwhere(p < 0)[0])
        raise ValueError(f"pressure must be >= 0 (index {idx} is {p[idx]:g})")
    p = np.where(np.isfinite(p), p, 0.0)
    x, y = cell_centres_cm(p.shape[-2:], pitch_cm)
    total = p.sum(axis=(-2, -1))
    with np.errstate(invalid="ignore", divide="ignore"):
        out = np.stack([p.sum(axis=-2) @ x / total, p.sum(axis=-1) @ y / total], axis=-1)
    out[total <= 0] = np.nan
    return out

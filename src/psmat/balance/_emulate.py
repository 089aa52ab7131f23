"""A coarser mat emulated from a finer one (thesis §3.2.1, PROP-8x8 and SCHC-8x8).

Keeping one of every two rows and columns of the 16×16 mat gives an 8×8 mat at twice
the pitch. There are four ways to choose (odd or even rows × odd or even columns); the
thesis reports the average over the four of each metric. Cell ``(i, p)`` of the choice
``(r0, c0)`` is cell ``(r0 + 2i, c0 + 2p)`` of the full mat, so its CoP is expressed in the
full mat's coordinates (docs/spec.md §7: cell (i, p) at (p·pitch, i·pitch)) by adding
``(c0·pitch, r0·pitch)``.
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .. import _checks
from ..profile import default_geometry
from ._cop import cop

__all__ = ["Subgrid", "subgrids", "subgrid_cops"]


class Subgrid(NamedTuple):
    """One choice of rows and columns: the images, where they sit and their pitch."""

    rows0: int  # first kept row (0 or 1 for a factor of 2)
    cols0: int  # first kept column
    images: NDArray[np.float64]  # (..., R/k, C/k)
    offset_cm: NDArray[np.float64]  # (x, y) of the sub-grid's cell (0, 0) on the full mat
    pitch_cm: float  # k · pitch


def subgrids(images: ArrayLike, pitch_cm: float | None = None, factor: int = 2) -> Iterator[Subgrid]:
    """The ``factor²`` sub-grids of ``images`` (..., R, C), each keeping one of ``factor`` rows and columns.

    ``pitch_cm`` (cm) is the full mat's; None: the default profile's (docs/spec.md §5 "Device profiles").
    """
    a = np.asarray(images, dtype=np.float64)
    if a.ndim < 2:
        raise ValueError(f"images must be (..., R, C), got shape {a.shape}")
    k = _checks.positive_int("factor", factor, minimum=2)
    pitch = _checks.positive("pitch_cm", default_geometry().pitch_cm if pitch_cm is None else pitch_cm)
    R, C = a.shape[-2:]
    if R < k or C < k:
        raise ValueError(f"a {R}x{C} mat has no {k}x coarser sub-grid")
    for r0 in range(k):
        for c0 in range(k):
            yield Subgrid(r0, c0, a[..., r0::k, c0::k], np.array([c0 * pitch, r0 * pitch]), k * pitch)


def subgrid_cops(pressure_kpa: ArrayLike, pitch_cm: float | None = None, factor: int = 2) -> NDArray[np.float64]:
    """CoP (cm, full-mat coordinates) of each sub-grid: (factor², ..., 2), choices in row-major order.

    ``pressure_kpa`` (..., R, C): any pressure unit gives the same CoP; the chain's is kPa.
    """
    return np.stack([cop(s.images, s.pitch_cm) + s.offset_cm for s in subgrids(pressure_kpa, pitch_cm, factor)])

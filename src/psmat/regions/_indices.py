"""Seat indices: peak pressure index, dispersion index, coefficient of variation (docs/spec.md §7 "Regions").

Each index is computed on one image: an (R, C) frame as given, or the mean of a (T, R, C) trial
over its frames present (a frame of NaN is missing and left out; a NaN cell is left out).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..profile import Geometry
from ._common import DEFAULT_THRESHOLD_KPA, check_masks, geometry_of, mean_image, stack, threshold

__all__ = ["PeakPressureIndex", "peak_pressure_index_kpa", "dispersion_index_pct", "coefficient_of_variation"]


@dataclass(frozen=True)
class PeakPressureIndex:
    """The peak pressure index and the square of cells it was taken over.

    Attributes
    ----------
    value_kpa : float
        The highest mean pressure over a ``side_cells`` × ``side_cells`` square of cells, kPa.
    side_cells : int
        The square's side, in cells.
    square_area_cm2 : float
        The square's area, cm² (``side_cells² · pitch²``).
    within_range : bool
        True when that area lies in the asked range; False when the mat's pitch allows no square
        in it and the smallest square above the range was taken (a 2 cm mat: 2×2 cells, 16 cm²).
    row, col : int
        The square's first row and column (its corner of smallest indices).
    """

    value_kpa: float
    side_cells: int
    square_area_cm2: float
    within_range: bool
    row: int
    col: int


def _image(pressure_kpa: ArrayLike) -> NDArray[np.float64]:
    return mean_image(stack(pressure_kpa))


def _side(cell_area_cm2: float, low: float, high: float, limit: int) -> tuple[int, bool]:
    """The smallest square side (cells) whose area is in [low, high], else the smallest above ``low``."""
    k = max(1, math.ceil(math.sqrt(low / cell_area_cm2) - 1e-9))
    while k * k * cell_area_cm2 < low * (1 - 1e-12):
        k += 1
    if k > limit:
        raise ValueError(f"area_cm2: the mat holds no square of cells of at least {low:g} cm² "
                         f"(cell area {cell_area_cm2:g} cm²)")
    return k, k * k * cell_area_cm2 <= high * (1 + 1e-12)


def peak_pressure_index_kpa(pressure_kpa: ArrayLike, geometry: Geometry | None = None, *,
                            area_cm2: tuple[float, float] = (9.0, 10.0)) -> PeakPressureIndex:
    """The highest mean pressure over a square of contiguous cells covering ``area_cm2``.

    The square's side is the smallest number of cells ``k`` whose area ``k²·pitch²`` lies within
    ``area_cm2`` (a 1 cm mat: 3×3 cells, 9 cm²). When the pitch allows none (the thesis' 2 cm mat:
    one cell is 4 cm², 2×2 cells 16 cm²), the smallest square of at least the lower bound is taken
    and the result says so (``within_range`` False). Every position of the square on the mat is
    tried; a square holding a NaN cell is left out.

    Parameters
    ----------
    pressure_kpa : array_like, (R, C) or (T, R, C)
        Pressure, kPa; a trial is averaged over its frames present first.
    geometry : psmat.profile.Geometry, optional
        The cells' pitch; default the default profile's geometry (2 cm).
    area_cm2 : (float, float)
        The square's wanted area, lower and upper bound, cm²; default (9, 10).

    Returns
    -------
    PeakPressureIndex
    """
    low, high = (float(v) for v in area_cm2)
    if not (np.isfinite(low) and np.isfinite(high) and 0 < low <= high):
        raise ValueError(f"area_cm2 must be (low, high) cm² with 0 < low <= high, got {area_cm2!r}")
    image = _image(pressure_kpa)
    geo = geometry_of(image.shape, geometry)
    R, C = image.shape
    k, within = _side(geo.cell_area_cm2, low, high, min(R, C))
    # sums over every k×k window from the integral image; a window with a NaN cell is left out
    nan = np.isnan(image)
    integral = np.pad(np.where(nan, 0.0, image), ((1, 0), (1, 0))).cumsum(0).cumsum(1)
    holes = np.pad(nan.astype(np.int64), ((1, 0), (1, 0))).cumsum(0).cumsum(1)

    def windows(a: NDArray) -> NDArray:
        return a[k:, k:] - a[:-k, k:] - a[k:, :-k] + a[:-k, :-k]

    means = np.where(windows(holes) == 0, windows(integral) / (k * k), -np.inf)
    if not np.isfinite(means.max()):
        raise ValueError("pressure_kpa: every square holds a missing (NaN) cell")
    row, col = np.unravel_index(int(np.argmax(means)), means.shape)
    return PeakPressureIndex(value_kpa=float(means[row, col]), side_cells=k, square_area_cm2=k * k * geo.cell_area_cm2,
                             within_range=bool(within), row=int(row), col=int(col))


def dispersion_index_pct(pressure_kpa: ArrayLike, masks: Mapping[str, ArrayLike],
                         ischial: Sequence[str] = ("left_ischial", "right_ischial")) -> float:
    """Σ p over the ischial regions / Σ p over the mat × 100 (%).

    Parameters
    ----------
    pressure_kpa : array_like, (R, C) or (T, R, C)
        Pressure, kPa; a trial is averaged over its frames present first (NaN cells left out).
    masks : dict of str -> (R, C) bool
        Regions (:func:`seat_masks` or the user's), holding the names in ``ischial``.
    ischial : sequence of str
        The names of the ischial regions; a cell in both counts once.

    Returns
    -------
    float
        Percent; NaN when the mat carries nothing.
    """
    image = np.nan_to_num(_image(pressure_kpa), nan=0.0)
    checked = check_masks(masks, image.shape)
    names = [ischial] if isinstance(ischial, str) else list(ischial)
    absent = [n for n in names if n not in checked]
    if not names or absent:
        raise ValueError(f"dispersion_index_pct: masks lack {', '.join(map(repr, absent)) or 'ischial names'}; "
                         f"they hold {', '.join(checked)}")
    union = np.zeros(image.shape, dtype=bool)
    for n in names:
        union |= checked[n]
    total = image.sum()
    return float(100.0 * image[union].sum() / total) if total > 0 else math.nan


def coefficient_of_variation(pressure_kpa: ArrayLike, *, threshold_kpa: float = DEFAULT_THRESHOLD_KPA,
                             mask: ArrayLike | None = None) -> float:
    """Standard deviation / mean of the loaded cells' pressure (a ratio, not %; population SD, ddof 0).

    Parameters
    ----------
    pressure_kpa : array_like, (R, C) or (T, R, C)
        Pressure, kPa; a trial is averaged over its frames present first (NaN cells left out).
    threshold_kpa : float
        Cells above this pressure (kPa) count; default 5 kPa.
    mask : (R, C) bool, optional
        Only the cells of this region.

    Returns
    -------
    float
        Unitless; NaN when no cell is loaded.
    """
    image = np.nan_to_num(_image(pressure_kpa), nan=0.0)
    keep = image > threshold(threshold_kpa)
    if mask is not None:
        keep &= check_masks({"mask": mask}, image.shape)["mask"]
    values = image[keep]
    if values.size == 0:
        return math.nan
    return float(values.std() / values.mean())

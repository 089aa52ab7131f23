"""Per-region, per-frame loads and their time integrals (docs/spec.md §7 "Regions").

For every region (a boolean mask over the cells) and every frame:

* ``force_n`` = Σ p·A over the region's cells (:func:`psmat.units.force_n`, A the geometry's
  cell area), every cell counted, like the centre of pressure;
* ``cop_cm`` = (Σ p·x / Σ p, Σ p·y / Σ p) over the same cells, in the geometry's coordinates
  (NaN when the region carries nothing);
* ``peak_kpa`` = the highest pressure among the region's *loaded* cells (above
  ``threshold_kpa``), 0 when none is loaded;
* ``mean_kpa`` = the mean pressure of the loaded cells, NaN when none is loaded;
* ``contact_area_cm2`` = the number of loaded cells × the cell area.

Per trial, with the trapezoid rule: ``pti_kpa_s`` = ∫ peak p dt and ``fti_n_s`` = ∫ F dt.

Missing data: a frame whose cells are all NaN is missing; its values are NaN, and every
interval that touches it (from the frame present before it to the one after) is left out of the
integrals — no value is interpolated across a gap; ``integrated_s`` says how much time the
integrals cover. A NaN cell in a frame present is left out of that frame's sums.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..profile import Geometry
from ..units import force_n
from ._common import DEFAULT_THRESHOLD_KPA, check_masks, geometry_of, missing_frames, stack, threshold

__all__ = ["Region", "RegionResults", "region_table"]


@dataclass(frozen=True)
class Region:
    """One region's loads: (T,) series per frame and the trial's integrals.

    Attributes
    ----------
    name : str
        The mask's name.
    n_cells : int
        Cells in the mask.
    force_n : ndarray, (T,)
        Σ p·A over the region, N.
    peak_kpa, mean_kpa : ndarray, (T,)
        Highest and mean pressure of the loaded cells, kPa (peak 0 and mean NaN when none is loaded).
    contact_area_cm2 : ndarray, (T,)
        Loaded cells × cell area, cm².
    cop_cm : ndarray, (T, 2)
        (x, y) centre of pressure of the region, cm (geometry's coordinates).
    pti_kpa_s : float
        Pressure–time integral ∫ peak p dt, kPa·s.
    fti_n_s : float
        Force–time integral ∫ F dt, N·s.
    """

    name: str
    n_cells: int
    force_n: NDArray[np.float64]
    peak_kpa: NDArray[np.float64]
    mean_kpa: NDArray[np.float64]
    contact_area_cm2: NDArray[np.float64]
    cop_cm: NDArray[np.float64]
    pti_kpa_s: float
    fti_n_s: float


@dataclass(frozen=True)
class RegionResults:
    """The loads of every region of a trial (:func:`region_table`).

    Attributes
    ----------
    t_s : ndarray, (T,)
        Frame times, s.
    missing : ndarray of bool, (T,)
        Frames left out (every cell NaN).
    integrated_s : float
        Time the integrals cover (the intervals between two consecutive frames present), s.
    threshold_kpa : float
        The pressure above which a cell counted as loaded, kPa.
    regions : dict of str -> Region
        One entry per mask, in the masks' order.
    """

    t_s: NDArray[np.float64]
    missing: NDArray[np.bool_]
    integrated_s: float
    threshold_kpa: float
    regions: dict[str, Region]

    def __getitem__(self, name: str) -> Region:
        try:
            return self.regions[name]
        except KeyError:
            raise KeyError(f"no region {name!r}; the regions are {', '.join(self.regions)}") from None

    @property
    def names(self) -> list[str]:
        """The regions' names."""
        return list(self.regions)


def _times(n: int, dt_s: float | None, t_s: ArrayLike | None) -> NDArray[np.float64]:
    if (dt_s is None) == (t_s is None):
        raise ValueError("give dt_s (s) or t_s (s, one time per frame), exactly one of them")
    if dt_s is not None:
        dt = float(dt_s)
        if not (np.isfinite(dt) and dt > 0):
            raise ValueError(f"dt_s must be a finite number > 0 (s), got {dt_s!r}")
        return np.arange(n) * dt
    t = np.asarray(t_s, dtype=np.float64)
    if t.shape != (n,):
        raise ValueError(f"t_s must hold one time per frame ({n}), got shape {t.shape}")
    if not np.all(np.isfinite(t)) or np.any(np.diff(t) <= 0):
        raise ValueError("t_s must be finite and strictly increasing (s)")
    return t


def _integral(values: NDArray[np.float64], t: NDArray[np.float64], pairs: NDArray[np.bool_]) -> float:
    """Trapezoid over the intervals whose two ends are both present (``pairs``, (T-1,))."""
    if t.size < 2:
        return 0.0
    parts = 0.5 * (values[1:] + values[:-1]) * np.diff(t)
    return float(parts[pairs].sum())


def region_table(pressure_kpa: ArrayLike, masks: Mapping[str, ArrayLike], geometry: Geometry | None = None, *,
                 dt_s: float | None = None, t_s: ArrayLike | None = None,
                 threshold_kpa: float = DEFAULT_THRESHOLD_KPA) -> RegionResults:
    """Force, peak and mean pressure, contact area and CoP of each region per frame, and PTI/FTI per trial.

    Parameters
    ----------
    pressure_kpa : array_like, (T, R, C) or (R, C)
        Pressure, kPa (>= 0); a frame of NaN is missing.
    masks : dict of str -> (R, C) bool
        The regions: from :func:`foot_masks`, :func:`seat_masks` or the user's own.
    geometry : psmat.profile.Geometry, optional
        Where the cells are and their area; default the default profile's geometry (2 cm pitch).
    dt_s : float, optional
        Frame period, s (frames at ``k·dt_s``). Exactly one of ``dt_s`` and ``t_s``.
    t_s : array_like, (T,), optional
        Frame times, s, strictly increasing.
    threshold_kpa : float
        A cell is loaded above this pressure (kPa); default 5 kPa.

    Returns
    -------
    RegionResults
    """
    p = stack(pressure_kpa)
    geo = geometry_of(p.shape[1:], geometry)
    limit = threshold(threshold_kpa)
    checked = check_masks(masks, p.shape[1:])
    t = _times(p.shape[0], dt_s, t_s)
    missing = missing_frames(p)
    pairs = ~missing[1:] & ~missing[:-1]
    integrated = float(np.diff(t)[pairs].sum()) if t.size > 1 else 0.0
    area = geo.cell_area_cm2
    x, y = geo.cell_centres_cm()
    clean = np.where(np.isfinite(p), p, 0.0)
    regions: dict[str, Region] = {}
    for name, mask in checked.items():
        cells = clean[:, mask]                                  # (T, n)
        loaded = cells > limit
        n_loaded = loaded.sum(axis=1)
        total = cells.sum(axis=1)
        force = force_n(total, area)
        peak = np.where(loaded, cells, 0.0).max(axis=1, initial=0.0)
        with np.errstate(invalid="ignore", divide="ignore"):
            mean = np.where(n_loaded > 0, np.where(loaded, cells, 0.0).sum(axis=1) / np.maximum(n_loaded, 1),
                            np.nan)
            cop = np.stack([cells @ x[mask] / total, cells @ y[mask] / total], axis=-1)
        cop[total <= 0] = np.nan
        contact = n_loaded * area
        series = [force, peak, mean, contact.astype(np.float64)]
        for s in series:
            s[missing] = np.nan
        cop[missing] = np.nan
        regions[name] = Region(name=name, n_cells=int(mask.sum()), force_n=force, peak_kpa=peak, mean_kpa=mean,
                               contact_area_cm2=series[3], cop_cm=cop, pti_kpa_s=_integral(peak, t, pairs),
                               fti_n_s=_integral(force, t, pairs))
    return RegionResults(t_s=t, missing=missing, integrated_s=integrated, threshold_kpa=limit, regions=regions)

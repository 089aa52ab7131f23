"""Automatic region masks over a mat's cells: two feet and their thirds, a seat (docs/spec.md §7 "Regions").

Coordinates are the geometry's (:class:`psmat.profile.Geometry`): ``x`` medial-lateral, ``y``
anterior-posterior, in cm. psmat's convention (that of the digital twin, :mod:`psmat.twin.field`)
is that a person faces ``+y`` (toes and knees towards larger ``y``), so their left is the smaller
``x``. The masks are made by coordinates, so a mirrored or turned geometry keeps "left" on the
subject's left and "rearfoot" at the heel.

A cell is *loaded* when its pressure exceeds ``threshold_kpa`` in at least one frame present (the
footprint of the whole trial); missing frames (every cell NaN) and NaN cells are left out.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..profile import Geometry
from ._common import DEFAULT_THRESHOLD_KPA, Masks, geometry_of, mean_image, missing_frames, stack, threshold

__all__ = ["foot_masks", "seat_masks", "FOOT_REGIONS", "SEAT_REGIONS"]

#: Names :func:`foot_masks` returns.
FOOT_REGIONS = ("left", "left_rearfoot", "left_midfoot", "left_forefoot",
                "right", "right_rearfoot", "right_midfoot", "right_forefoot")
#: Names :func:`seat_masks` returns.
SEAT_REGIONS = ("left_ischial", "right_ischial", "sacrum", "thighs")


def _footprint(p: NDArray[np.float64], limit_kpa: float) -> NDArray[np.bool_]:
    present = p[~missing_frames(p)]
    if present.shape[0] == 0:
        raise ValueError("pressure_kpa: every frame is missing (NaN)")
    loaded = (np.where(np.isfinite(present), present, 0.0) > limit_kpa).any(axis=0)
    if not loaded.any():
        raise ValueError(f"pressure_kpa: no cell is above threshold_kpa={limit_kpa:g} kPa in any frame")
    return loaded


def _split_x(loaded: NDArray[np.bool_], geo: Geometry) -> float:
    """The x (cm) midway across the widest run of empty lines between loaded lines along M-L."""
    axis, pos = geo.axis_positions_cm("x")
    lines = loaded.any(axis=0) if axis == -1 else loaded.any(axis=1)
    order = np.argsort(pos)
    pos, lines = pos[order], lines[order]
    idx = np.flatnonzero(lines)
    gaps = np.diff(idx) - 1
    if idx.size < 2 or gaps.max() < 1:
        raise ValueError("foot_masks: the loaded cells form one block along M-L (no empty line between two "
                         "feet); give the masks yourself")
    k = int(np.argmax(gaps))  # the widest gap; on a tie, the one at the smaller x
    return float(0.5 * (pos[idx[k]] + pos[idx[k + 1]]))


def _thirds(foot: NDArray[np.bool_], y: NDArray[np.float64], pitch_cm: float
            ) -> tuple[NDArray[np.bool_], NDArray[np.bool_], NDArray[np.bool_]]:
    ys = y[foot]
    start = ys.min() - pitch_cm / 2
    length = ys.max() - ys.min() + pitch_cm
    rear = foot & (y < start + length / 3)
    fore = foot & (y > start + 2 * length / 3)
    return rear, foot & ~rear & ~fore, fore


def foot_masks(pressure_kpa: ArrayLike, geometry: Geometry | None = None, *,
               threshold_kpa: float = DEFAULT_THRESHOLD_KPA) -> Masks:
    """Left and right foot, and each foot's rearfoot, midfoot and forefoot.

    * **Feet**: the loaded cells, split along M-L at the middle of the widest run of empty lines
      (columns, in the default geometry) between loaded lines; ``"left"`` is the side of smaller
      ``x`` (the subject faces ``+y``, so their left is ``-x``), ``"right"`` the other.
    * **Thirds**: each foot's length along A-P runs from the rear edge of its rearmost loaded cell
      to the front edge of its foremost (``(n_lines)·pitch``); a cell belongs to the third in which
      its centre lies, ``"rearfoot"`` at the smaller ``y`` (the heel), ``"forefoot"`` at the larger.
      A centre never falls on a boundary (it sits half a pitch off a multiple of the pitch).

    Parameters
    ----------
    pressure_kpa : array_like, (T, R, C) or (R, C)
        Pressure, kPa (>= 0; NaN = missing).
    geometry : psmat.profile.Geometry, optional
        Where the cells are; default the default profile's geometry for the frames' shape.
    threshold_kpa : float
        A cell is loaded above this pressure in some frame (kPa); default 5 kPa.

    Returns
    -------
    dict of str -> (R, C) bool
        :data:`FOOT_REGIONS`: ``"left"``, ``"left_rearfoot"``, ``"left_midfoot"``,
        ``"left_forefoot"`` and the same for ``"right"``.

    Raises
    ------
    ValueError
        No loaded cell, or no empty line between the feet along M-L.
    """
    p = stack(pressure_kpa)
    geo = geometry_of(p.shape[1:], geometry)
    loaded = _footprint(p, threshold(threshold_kpa))
    x, y = geo.cell_centres_cm()
    cut = _split_x(loaded, geo)
    out: Masks = {}
    for side, foot in (("left", loaded & (x < cut)), ("right", loaded & (x > cut))):
        rear, mid, fore = _thirds(foot, y, geo.pitch_cm)
        out.update({side: foot, f"{side}_rearfoot": rear, f"{side}_midfoot": mid, f"{side}_forefoot": fore})
    return out


def seat_masks(pressure_kpa: ArrayLike, geometry: Geometry | None = None, *,
               threshold_kpa: float = DEFAULT_THRESHOLD_KPA, ischial_radius_cm: float = 5.0) -> Masks:
    """Ischial regions, sacrum and thighs of a person sitting on the mat (facing ``+y``).

    From the loaded cells (the footprint) and the time-mean image (missing frames left out):

    * **halves**: the loaded cells' extent along A-P runs from the rear edge of the rearmost
      loaded line to the front edge of the foremost; the *rear half* holds the loaded cells whose
      centre ``y`` is at most the middle of that extent (a middle line goes with the rear), the
      *front half* the others;
    * **M-L split**: the ``x`` of the rear half's centre of pressure (time-mean image);
    * **ischial peaks**: in the rear half, the cell of highest time-mean pressure on each side of
      that split (``x`` smaller: left; larger: right; a cell exactly on it is on neither side);
    * ``"left_ischial"`` / ``"right_ischial"``: the rear half's loaded cells on the peak's side
      whose centre lies within ``ischial_radius_cm`` of the peak's centre;
    * ``"sacrum"``: the loaded cells behind every ischial cell (``y`` below the smallest ``y`` of
      both ischial regions) and between the two peaks along M-L (inclusive) — empty when the
      pelvis does not roll back onto it;
    * ``"thighs"``: the front half's loaded cells.

    Parameters
    ----------
    pressure_kpa : array_like, (T, R, C) or (R, C)
        Pressure, kPa (>= 0; NaN = missing).
    geometry : psmat.profile.Geometry, optional
        Where the cells are; default the default profile's geometry for the frames' shape.
    threshold_kpa : float
        A cell is loaded above this pressure in some frame (kPa); default 5 kPa.
    ischial_radius_cm : float
        Radius of each ischial region around its peak (cm, centre to centre); default 5 cm.

    Returns
    -------
    dict of str -> (R, C) bool
        :data:`SEAT_REGIONS`.

    Raises
    ------
    ValueError
        No loaded cell, or no load on one side of the rear half.
    """
    radius = float(ischial_radius_cm)
    if not (np.isfinite(radius) and radius > 0):
        raise ValueError(f"ischial_radius_cm must be a finite number > 0 (cm), got {ischial_radius_cm!r}")
    p = stack(pressure_kpa)
    geo = geometry_of(p.shape[1:], geometry)
    loaded = _footprint(p, threshold(threshold_kpa))
    mean = np.nan_to_num(mean_image(p), nan=0.0)
    x, y = geo.cell_centres_cm()
    ys = y[loaded]
    middle = 0.5 * ((ys.min() - geo.pitch_cm / 2) + (ys.max() + geo.pitch_cm / 2))
    rear = loaded & (y <= middle)
    r = np.where(rear, mean, 0.0)
    cut = float((r * x).sum() / r.sum())
    peaks, regions = [], {}
    for side, on_side in (("left", x < cut), ("right", x > cut)):
        candidates = np.where(on_side, r, 0.0)
        if candidates.max() <= 0:
            raise ValueError(f"seat_masks: no load in the rear half on the {side} of x = {cut:.2f} cm: "
                             "two ischial peaks are needed; give the masks yourself")
        i, j = np.unravel_index(int(np.argmax(candidates)), candidates.shape)
        peaks.append(float(x[i, j]))
        near = np.hypot(x - x[i, j], y - y[i, j]) <= radius * (1 + 1e-12)
        regions[f"{side}_ischial"] = rear & on_side & near
    ischial = regions["left_ischial"] | regions["right_ischial"]
    behind = y < y[ischial].min()
    between = (x >= min(peaks)) & (x <= max(peaks))
    regions["sacrum"] = loaded & behind & between
    regions["thighs"] = loaded & ~rear
    return regions

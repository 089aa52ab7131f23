"""Checks shared by the regions' modules: pressure stacks, geometries and masks (docs/spec.md §7 "Regions")."""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..profile import Geometry, geometry_for

Masks = dict[str, NDArray[np.bool_]]

#: Pressure (kPa) above which a cell counts as loaded, unless the caller states another.
DEFAULT_THRESHOLD_KPA = 5.0


def stack(pressure_kpa: ArrayLike) -> NDArray[np.float64]:
    """Pressure as a (T, R, C) float array (one (R, C) frame becomes T = 1); >= 0 where finite."""
    p = np.asarray(pressure_kpa, dtype=np.float64)
    if p.ndim == 2:
        p = p[None]
    if p.ndim != 3 or p.shape[0] < 1 or p.shape[1] < 1 or p.shape[2] < 1:
        raise ValueError(f"pressure_kpa must be (R, C) or (T, R, C), got shape {np.shape(pressure_kpa)}")
    if np.any(p < 0):
        idx = tuple(int(v) for v in np.argwhere(p < 0)[0])
        raise ValueError(f"pressure_kpa must be >= 0 (index {idx} is {p[idx]:g} kPa)")
    if np.any(np.isinf(p)):
        raise ValueError("pressure_kpa must be finite or NaN (missing), got an infinite value")
    return p


def missing_frames(p: NDArray[np.float64]) -> NDArray[np.bool_]:
    """(T,) True for a missing frame: every cell NaN."""
    return np.all(np.isnan(p), axis=(1, 2))


def mean_image(p: NDArray[np.float64]) -> NDArray[np.float64]:
    """The mean (R, C) image over the frames present (missing frames left out), kPa; NaN cells left out."""
    present = p[~missing_frames(p)]
    if present.shape[0] == 0:
        raise ValueError("pressure_kpa: every frame is missing (NaN)")
    finite = np.isfinite(present)
    n = finite.sum(axis=0)
    total = np.where(finite, present, 0.0).sum(axis=0)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(n > 0, total / np.maximum(n, 1), np.nan)


def geometry_of(shape: tuple[int, int], geometry: Geometry | None) -> Geometry:
    """``geometry`` checked against the frames' (R, C), or the default profile's for that shape."""
    return geometry_for(shape, geometry=geometry)


def threshold(value: float) -> float:
    """A checked threshold (kPa): finite and >= 0."""
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)) \
            or not math.isfinite(float(value)) or value < 0:
        raise ValueError(f"threshold_kpa must be a finite number >= 0 (kPa), got {value!r}")
    return float(value)


def check_masks(masks: Mapping[str, ArrayLike], shape: tuple[int, int]) -> Masks:
    """User or automatic masks checked: a non-empty mapping of name -> (R, C) bool array."""
    if not isinstance(masks, Mapping) or not masks:
        raise ValueError("masks must be a non-empty dict of name -> (R, C) bool array")
    out: Masks = {}
    for name, mask in masks.items():
        if not isinstance(name, str) or not name:
            raise ValueError(f"masks: every name must be a non-empty string, got {name!r}")
        m = np.asarray(mask)
        if m.dtype != np.bool_:
            raise ValueError(f"masks[{name!r}] must be a bool array, got dtype {m.dtype}")
        if m.shape != tuple(shape):
            raise ValueError(f"masks[{name!r}] has shape {m.shape}, the frames are {tuple(shape)}")
        out[name] = m.copy()
    return out

"""Positional posturography descriptors, preset ``quijoux2021`` (docs/spec.md §7).

Definitions after Quijoux et al. (2021) and their open code. Input: the centred, uniformly
sampled trace (cm); moments are population moments (divided by N). The radius is
``√(ML² + AP²)``. Lengths in cm, areas in cm², the direction in degrees; ``mean_value_*``
is the mean of the raw trace, which the entry point passes in (the families only see the
centred one).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy import spatial, stats

__all__ = ["compute", "rms", "ellipse_area_cm2", "diameter_cm"]

_CHUNK = 256


def rms(x: NDArray[np.float64]) -> float:
    """Root mean square (same unit as ``x``); on a centred signal, its population SD."""
    return float(np.sqrt(np.mean(np.square(x))))


def diameter_cm(xy: NDArray[np.float64]) -> float:
    """Largest distance (cm) between two points of a (N, 2) trace."""
    try:
        pts = xy[spatial.ConvexHull(xy).vertices]
    except (spatial.QhullError, ValueError):   # collinear or too few points: use them all
        pts = xy
    best = 0.0
    for i in range(0, len(pts), _CHUNK):
        d = np.hypot(*(pts[i:i + _CHUNK, None, :] - pts[None, :, :]).transpose(2, 0, 1))
        best = max(best, float(d.max()))
    return best


def ellipse_area_cm2(ml: NDArray[np.float64], ap: NDArray[np.float64], p: float = 0.95) -> float:
    """Area (cm²) of the ``p`` confidence ellipse of a centred trace.

    ``2π·F_p(2, n−2)·(n+1)(n−1)/(n(n−2))·√(s_ML²·s_AP² − s_MLAP²)`` with population moments.
    """
    n = ml.size
    s_xy = float(np.mean(ml * ap))
    det = rms(ml) ** 2 * rms(ap) ** 2 - s_xy ** 2
    coeff = (n + 1) * (n - 1) / (n * (n - 2))
    return float(2.0 * np.pi * stats.f.ppf(p, 2, n - 2) * coeff * np.sqrt(max(det, 0.0)))


def _principal_direction_deg(ml: NDArray[np.float64], ap: NDArray[np.float64]) -> float:
    # The eigenvector of the covariance with the largest eigenvalue (the first principal
    # component); its angle to the A-P axis, folded into [0°, 90°].
    cov = np.cov(np.vstack((ml, ap)), ddof=0)
    _, vec = np.linalg.eigh(cov)
    main = vec[:, -1]
    return float(np.degrees(np.arccos(min(1.0, abs(main[1]) / np.linalg.norm(main)))))


def compute(ml_cm: NDArray[np.float64], ap_cm: NDArray[np.float64], fs_hz: float,
            mean_ml_cm: float = 0.0, mean_ap_cm: float = 0.0) -> dict[str, float]:
    """The positional descriptors of a centred trace.

    Parameters
    ----------
    ml_cm, ap_cm : array, (N,)
        Centred M-L and A-P coordinates (cm), uniformly sampled, N ≥ 3.
    fs_hz : float
        Sampling rate (Hz); unused by these descriptors, kept for the families' interface.
    mean_ml_cm, mean_ap_cm : float
        Means of the raw trace (cm), reported as ``mean_value_ML`` and ``mean_value_AP``.

    Returns
    -------
    dict
        ``mean_value_{ML,AP}``, ``mean_distance_{ML,AP,Radius}``,
        ``maximal_distance_{ML,AP,Radius}``, ``rms_{ML,AP,Radius}`` (cm);
        ``range_{ML,AP,ML_AND_AP}`` (cm); ``range_ratio_ML_AND_AP`` (1);
        ``planar_deviation_ML_AND_AP`` (cm); ``coefficient_sway_direction_ML_AND_AP`` (1);
        ``confidence_ellipse_area_ML_AND_AP`` (cm²); ``principal_sway_direction_ML_AND_AP`` (deg).
    """
    ml = np.asarray(ml_cm, dtype=np.float64)
    ap = np.asarray(ap_cm, dtype=np.float64)
    radius = np.hypot(ml, ap)
    out: dict[str, float] = {"mean_value_ML": float(mean_ml_cm), "mean_value_AP": float(mean_ap_cm)}
    for name, x in (("ML", ml), ("AP", ap), ("Radius", radius)):
        out[f"mean_distance_{name}"] = float(np.mean(np.abs(x)))
        out[f"maximal_distance_{name}"] = float(np.max(np.abs(x)))
        out[f"rms_{name}"] = rms(x)
    range_ml, range_ap = float(np.ptp(ml)), float(np.ptp(ap))
    rms_ml, rms_ap = rms(ml), rms(ap)
    out["range_ML"] = range_ml
    out["range_AP"] = range_ap
    out["range_ML_AND_AP"] = diameter_cm(np.column_stack((ml, ap)))
    out["range_ratio_ML_AND_AP"] = range_ml / range_ap if range_ap > 0 else float("nan")
    out["planar_deviation_ML_AND_AP"] = float(np.hypot(rms_ml, rms_ap))
    spread = rms_ml * rms_ap
    out["coefficient_sway_direction_ML_AND_AP"] = float(np.mean(ml * ap)) / spread if spread > 0 else float("nan")
    out["confidence_ellipse_area_ML_AND_AP"] = ellipse_area_cm2(ml, ap)
    out["principal_sway_direction_ML_AND_AP"] = _principal_direction_deg(ml, ap)
    return out

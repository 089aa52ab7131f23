"""Dynamic posturography descriptors, preset ``quijoux2021`` (docs/spec.md §7).

Definitions after Quijoux et al. (2021) and their open code. Input: the centred, uniformly
sampled trace (cm) and its rate (Hz). The velocity is the first derivative of a
Savitzky–Golay fit (window 5 samples, cubic); the path is the sum of the distances between
consecutive samples; the duration of a mean velocity is ``N / fs``, that of the sway area
``(N − 1) / fs``. The sway density at sample i is the time (s) the trace stays within
0.3 cm of sample i before it first leaves that circle.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy import signal

from . import _desc_positional

__all__ = ["compute", "velocity_cm_s", "sway_density_s", "SWAY_DENSITY_RADIUS_CM"]

#: The sway density's circle (cm).
SWAY_DENSITY_RADIUS_CM = 0.3
_SG_WINDOW, _SG_ORDER = 5, 3


def velocity_cm_s(x_cm: NDArray[np.float64], fs_hz: float) -> NDArray[np.float64]:
    """Velocity (cm/s) along the first axis: Savitzky–Golay derivative, 5 samples, cubic."""
    return signal.savgol_filter(x_cm, _SG_WINDOW, _SG_ORDER, deriv=1, delta=1.0 / fs_hz, axis=0)


def sway_density_s(xy_cm: NDArray[np.float64], fs_hz: float,
                   radius_cm: float = SWAY_DENSITY_RADIUS_CM) -> NDArray[np.float64]:
    """Sway density (s), one value per sample but the last (shape (N − 1,)).

    For sample i: the number of the samples i+1, i+2, ... that stay within ``radius_cm`` of
    sample i before the first one that does not, divided by ``fs_hz``.
    """
    n = xy_cm.shape[0]
    count = np.zeros(n - 1)
    alive = np.ones(n - 1, dtype=bool)
    for lag in range(1, n):
        idx = np.flatnonzero(alive[: n - lag])
        if idx.size == 0:
            break
        inside = np.hypot(*(xy_cm[idx + lag] - xy_cm[idx]).T) <= radius_cm
        alive[idx[~inside]] = False
        count[idx[inside]] += 1
    return count / fs_hz


def _mean(values: NDArray[np.float64]) -> float:
    return float(np.mean(values)) if values.size else float("nan")


def _velocity_peaks(v: NDArray[np.float64]) -> tuple[int, float, float, float]:
    # Zero samples are ignored; the rest splits into runs of one sign. A zero crossing is a
    # change of sign between consecutive runs; a peak is the largest |v| of a run bounded by
    # two crossings (the first and the last runs are cut by the trial and give none).
    nz = v[v != 0]
    if nz.size == 0:
        return 0, float("nan"), float("nan"), float("nan")
    starts = np.flatnonzero(np.diff(np.sign(nz)) != 0) + 1
    runs = np.split(nz, starts)
    inner = runs[1:-1]
    pos = np.array([r.max() for r in inner if r[0] > 0])
    neg = np.array([-r.min() for r in inner if r[0] < 0])
    return starts.size, _mean(pos), _mean(neg), _mean(np.concatenate((pos, neg)))


def compute(ml_cm: NDArray[np.float64], ap_cm: NDArray[np.float64], fs_hz: float) -> dict[str, float]:
    """The dynamic descriptors of a centred, uniformly sampled trace.

    Parameters
    ----------
    ml_cm, ap_cm : array, (N,)
        Centred M-L and A-P coordinates (cm), N ≥ 5.
    fs_hz : float
        Sampling rate (Hz).

    Returns
    -------
    dict
        ``mean_velocity_{ML,AP,ML_AND_AP}`` (cm/s); ``sway_area_per_second_ML_AND_AP`` (cm²/s);
        ``phase_plane_parameter_{ML,AP}`` (mixes cm and cm/s, as the paper does);
        ``LFS_ML_AND_AP`` (1/cm); ``fractal_dimension_ML_AND_AP`` (1);
        ``zero_crossing_SPD_{ML,AP}`` (a count over the trial);
        ``peak_velocity_{pos,neg,all}_SPD_{ML,AP}`` (cm/s); ``mean_peak_Sway_Density`` (s);
        ``mean_distance_peak_Sway_Density`` (cm).
    """
    ml = np.asarray(ml_cm, dtype=np.float64)
    ap = np.asarray(ap_cm, dtype=np.float64)
    fs = float(fs_hz)
    n = ml.size
    xy = np.column_stack((ml, ap))
    out: dict[str, float] = {}
    path = {"ML": float(np.sum(np.abs(np.diff(ml)))), "AP": float(np.sum(np.abs(np.diff(ap)))),
            "ML_AND_AP": float(np.sum(np.hypot(np.diff(ml), np.diff(ap))))}
    for name, length in path.items():
        out[f"mean_velocity_{name}"] = length * fs / n
    triangles = np.abs(ml[1:] * ap[:-1] - ap[1:] * ml[:-1])   # twice the area swept per step
    out["sway_area_per_second_ML_AND_AP"] = float(np.sum(triangles)) / (2.0 * (n - 1) / fs)
    vel = velocity_cm_s(xy, fs)
    for j, name in enumerate(("ML", "AP")):
        out[f"phase_plane_parameter_{name}"] = float(np.sqrt(_desc_positional.rms(xy[:, j]) ** 2 + np.var(vel[:, j])))
    area = _desc_positional.ellipse_area_cm2(ml, ap)
    out["LFS_ML_AND_AP"] = path["ML_AND_AP"] / area if area > 0 else float("nan")
    d = np.sqrt(4.0 * area / np.pi)   # diameter of the disc as large as the ellipse
    ok = d > 0 and path["ML_AND_AP"] > 0
    out["fractal_dimension_ML_AND_AP"] = (float(np.log(n) / (np.log(n) + np.log(d) - np.log(path["ML_AND_AP"])))
                                          if ok else float("nan"))
    for j, name in enumerate(("ML", "AP")):
        crossings, pos, neg, both = _velocity_peaks(vel[:, j])
        out[f"zero_crossing_SPD_{name}"] = float(crossings)
        out[f"peak_velocity_pos_SPD_{name}"] = pos
        out[f"peak_velocity_neg_SPD_{name}"] = neg
        out[f"peak_velocity_all_SPD_{name}"] = both
    density = sway_density_s(xy, fs)
    peaks = np.flatnonzero((density[1:-1] > density[:-2]) & (density[1:-1] > density[2:])) + 1
    out["mean_peak_Sway_Density"] = _mean(density[peaks])
    steps = np.diff(xy[peaks], axis=0) if peaks.size > 1 else np.zeros((0, 2))
    out["mean_distance_peak_Sway_Density"] = _mean(np.hypot(steps[:, 0], steps[:, 1]))
    return out

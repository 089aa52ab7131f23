"""The mat beside a force platform: alignment (:func:`psmat.balance.align`), Eu, the same metrics on both.

The platform's CoP is aligned with the mat's (the lag maximising their cross-correlation); on the
overlap, Eu (thesis eq. 3.1, and eq. 3.2 per axis) is computed at the mat's frame times with the
platform interpolated there, both mean-removed, as the thesis defines it (before any
preprocessing: Eu depends on the number of samples). The sway metrics of each are computed on its
own samples within the overlap after the report's one preprocessing.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..balance import SpreadCheck, align, check_spread, eu, find_platform_axes, orient_platform, preprocess, sway
from ..io import load_forceplate_csv

__all__ = ["PlatformResult", "compare_platform"]


@dataclass
class PlatformResult:
    """The mat against a force platform (:func:`compare_platform`)."""

    path: Path
    rate_hz: float  # the platform's sample rate, Hz
    lag_s: float  # platform time = mat time + lag, s
    r: float  # correlation at the lag (mean of M-L and A-P)
    overlap_s: float
    eu_cm: float
    eu_ml_cm: float
    eu_ap_cm: float
    mat: dict[str, float]  # sway metrics of the mat on the overlap
    fp: dict[str, float]  # sway metrics of the platform on the overlap
    t_s: NDArray[np.float64]  # preprocessed common times from the overlap's start (figure), s
    mat_cm: NDArray[np.float64]  # (N, 2) the mat, preprocessed, mean removed, cm
    fp_cm: NDArray[np.float64]  # (N, 2) the platform at the same times, preprocessed, mean removed, cm
    #: the alignment is poor (psmat.balance.Alignment.poor: the traces share no sway)
    poor: bool = False
    #: for a poor alignment, the platform axes that align it and their r (psmat.balance.find_platform_axes)
    other_axes: tuple[str, float] | None = None
    #: how far the platform's CoP spreads against the mat's (psmat.balance.check_spread: a file read in another unit)
    spread: SpreadCheck | None = None
    #: how the platform file's CoP was found (ForcePlateRecording.meta["cop_from"])
    cop_from: str = "the columns"


def _metrics(t: NDArray[np.float64], c: NDArray[np.float64], preset: str | None
             ) -> tuple[dict[str, float], NDArray[np.float64], NDArray[np.float64]]:
    tp, ml, ap = preprocess(t, c[:, 0], c[:, 1], preset=preset)
    xy = np.column_stack([ml, ap])
    return sway(xy, (tp.size - 1) / (tp[-1] - tp[0])).as_dict(), tp, xy


def compare_platform(path: Path, t_s: NDArray[np.float64], cop_cm: NDArray[np.float64],
                     p: dict[str, Any]) -> PlatformResult:
    """Align a platform file with the mat's filled CoP (``t_s`` s, ``cop_cm`` (T, 2) cm) and compare them.

    Raises
    ------
    ValueError
        A platform file that cannot be read or does not overlap the mat by 8 samples (one line,
        naming the file).
    """
    fp = load_forceplate_csv(path)
    t_fp, c_loaded = fp.samples()  # the samples with a time and a CoP (a NaN one is a lost sample)
    if t_fp.size < 8:
        raise ValueError(f"force-platform file {path.name}: fewer than 8 samples with a time and a CoP")
    c_fp = orient_platform(c_loaded, p["platform_axes"])
    a = align(t_fp, c_fp, t_s, cop_cm, max_lag_s=p["max_lag_s"])
    other = (find_platform_axes(t_fp, c_loaded, t_s, cop_cm, besides=p["platform_axes"], max_lag_s=p["max_lag_s"])
             if a.poor else None)
    lo, hi = max(t_s[0] + a.lag_s, t_fp[0]), min(t_s[-1] + a.lag_s, t_fp[-1])
    in_mat = (t_s + a.lag_s >= lo) & (t_s + a.lag_s <= hi)
    in_fp = (t_fp >= lo) & (t_fp <= hi)
    if in_mat.sum() < 8 or in_fp.sum() < 8:
        raise ValueError(f"force-platform file {path.name}: mat and platform overlap by fewer than 8 samples")
    tm = t_s[in_mat] + a.lag_s
    mat = cop_cm[in_mat]
    ref = np.column_stack([np.interp(tm, t_fp, c_fp[:, k]) for k in range(2)])
    am, bm = mat - mat.mean(axis=0), ref - ref.mean(axis=0)
    m_mat, tp, xy_mat = _metrics(tm, mat, p["preset"])
    m_fp, tq, xy_fp = _metrics(t_fp[in_fp], c_fp[in_fp], p["preset"])
    fp_at = np.column_stack([np.interp(tp, tq, xy_fp[:, k]) for k in range(2)])
    return PlatformResult(path=path, rate_hz=(t_fp.size - 1) / (t_fp[-1] - t_fp[0]), lag_s=a.lag_s, r=a.r,
                          overlap_s=float(hi - lo), eu_cm=eu(am, bm), eu_ml_cm=eu(am[:, 0], bm[:, 0]),
                          eu_ap_cm=eu(am[:, 1], bm[:, 1]), mat=m_mat, fp=m_fp, t_s=tp - tp[0],
                          mat_cm=xy_mat - xy_mat.mean(axis=0), fp_cm=fp_at - fp_at.mean(axis=0),
                          poor=a.poor, other_axes=None if other is None else (other[0], other[1].r),
                          spread=check_spread(c_fp[in_fp], mat, fp.meta["unit"]), cop_from=fp.meta["cop_from"])

"""Alignment of a mat and spine IMUs recorded apart (thesis §4.3, Fig. 4.11; docs/spec.md §8).

The thesis adds all the cells of the crosstalk-free conductance into one signal and all the
angles into another, finds "a clear relation" between them, and aligns the two recordings by
it. :func:`align_mat_imu` does that:

1. the summed mat signal ``Σ_cells g`` (S) is averaged over each interval of a grid at the IMU
   rate on the mat's own clock (:func:`psmat.posture.data.mean_over_samples`, the averaging
   that makes the learning images, so the figure shows what the network sees);
2. the summed angles ``Σ_i α_i`` (any unit) at the IMU samples;
3. :func:`psmat.balance.search_lag` — psmat's one cross-correlation search — scores each
   lag by the Pearson r on that lag's own overlap and refines the peak below one sample.

**Convention**: ``t_imu = t_mat + lag_s``: when the mat's clock reads ``t`` the IMU's reads
``t + lag_s`` (as :func:`psmat.balance.align`, the IMU in the platform's place). The search
window is centred on what the starts say, ``t_imu[0] − t_mat[0]`` (both recordings started
about together), ``± max_lag_s``.

**Sign.** The relation between summed conductance and summed flexion has no fixed sign: at a
constant force, spreading it over more cells (the thighs take load when leaning forward)
raises ``Σ g`` when the cells' conductance is concave in pressure (``g ∝ p^β``, β < 1) and
lowers it when convex (β > 1, a sensor near its threshold). So by default the lag is the one
of the largest ``|r|`` and ``r`` is reported with its sign; ``sign=+1`` or ``-1`` searches
one sign only when it is known for the cushion (it halves the ambiguity of a periodic
stretch, e.g. bounces, where a peak of the other sign sits half a period away).

**Scaling.** The thesis scales both series by ``(x − mean) / mean``. Pearson r does not depend
on it, only the figure does, and for the summed angles the mean is near 0 (an upright back)
or negative, where that scaling explodes or flips the curve; both series are therefore
standardised, ``(x − mean) / SD`` on the overlap (for the mat, whose mean is positive, the
same curve as the thesis' up to a factor).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ... import _checks
from ...balance import pearson_at_lag, search_lag
from ._resample import mean_over_samples

__all__ = ["MatImuAlignment", "align_mat_imu", "summed_mat_at_rate"]

_MIN_SAMPLES = 8


@dataclass(frozen=True, eq=False)
class MatImuAlignment:
    """Result of :func:`align_mat_imu`.

    Attributes
    ----------
    lag_s : float
        ``t_imu = t_mat + lag_s`` (s): the IMU clock's reading when the mat's reads ``t_mat``.
    r : float
        Pearson r of the summed mat signal and the summed angles at ``lag_s`` (signed).
    sign : int
        +1 or -1, the sign of the relation used (that of ``r`` unless ``sign`` was imposed).
    fs_hz : float
        The IMU rate, the rate of the search (Hz).
    overlap_s : float
        Duration the two recordings share at ``lag_s`` (s).
    manual : bool
        ``lag_s`` was given, not searched.
    t_s : ndarray, (K,)
        The IMU samples inside the overlap, on the IMU's clock (s).
    mat : ndarray, (K,)
        The summed mat signal at ``t_s − lag_s`` on the mat's clock, standardised (no unit).
    imu : ndarray, (K,)
        The summed IMU angles at ``t_s``, standardised (no unit).
    """

    lag_s: float
    r: float
    sign: int
    fs_hz: float
    overlap_s: float
    manual: bool
    t_s: NDArray[np.float64]
    mat: NDArray[np.float64]
    imu: NDArray[np.float64]

    def to_imu_time(self, t_mat: ArrayLike) -> NDArray[np.float64]:
        """Times of the mat's clock on the IMU's clock (s)."""
        return np.asarray(t_mat, dtype=np.float64) + self.lag_s


def _standardise(x: NDArray[np.float64]) -> NDArray[np.float64]:
    return (x - x.mean()) / x.std()


def summed_mat_at_rate(t_mat: ArrayLike, g_mat: ArrayLike, fs_hz: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The summed mat signal averaged over each interval of a grid at ``fs_hz`` on the mat's clock.

    Parameters
    ----------
    t_mat : array_like, (N,)
        Mat frame times (s), increasing where finite; NaN for a frame without a time.
    g_mat : array_like, (N, R, C) or (N, cells)
        Crosstalk-free conductance g (S); a frame holding NaN (invalid) is left out.
    fs_hz : float
        Rate of the grid (Hz), the IMU's.

    Returns
    -------
    t : ndarray, (K,)
        Grid times (s) on the mat's clock, from its first usable frame, where at least one frame fell.
    s : ndarray, (K,)
        Mean of ``Σ_cells g`` over each grid interval (S).
    """
    fs = _checks.positive("fs_hz", fs_hz)
    g = _checks.real_array(g_mat, "g_mat", unit="S", allow_nan=True)
    t = _checks.real_array(t_mat, "t_mat", unit="s", allow_nan=True)
    if t.ndim != 1 or g.ndim < 2 or g.shape[0] != t.size:
        raise ValueError(f"g_mat must have shape (N, R, C) or (N, cells) with N = len(t_mat) = {t.size}, got {g.shape}")
    total = g.reshape(t.size, -1).sum(axis=1)  # NaN on an invalid frame
    keep = np.isfinite(t) & np.isfinite(total)
    if keep.sum() < _MIN_SAMPLES:
        raise ValueError(f"the mat has {int(keep.sum())} usable frames; alignment needs at least {_MIN_SAMPLES}")
    tk = t[keep]
    if not np.all(np.diff(tk) > 0):
        raise ValueError("t_mat must increase strictly")
    grid = tk[0] + np.arange(int(np.floor((tk[-1] - tk[0]) * fs)) + 1) / fs
    mean, n = mean_over_samples(tk, total[keep], grid)
    return grid[n > 0], mean[n > 0]


def align_mat_imu(t_mat: ArrayLike, g_mat: ArrayLike, t_imu: ArrayLike, angles_rad: ArrayLike, *,
                  max_lag_s: float | None = None, sign: int | None = None, lag_s: float | None = None,
                  imu_rate_hz: float | None = None, min_overlap: float = 0.5) -> MatImuAlignment:
    """Align a mat and spine IMUs recorded apart by their summed signals (thesis Fig. 4.11).

    Parameters
    ----------
    t_mat : array_like, (N,)
        Mat frame times on the mat's clock (s); NaN for a frame without a time.
    g_mat : array_like, (N, R, C) or (N, cells)
        Crosstalk-free conductance (S); frames holding NaN are left out.
    t_imu : array_like, (M,)
        IMU sample times on the IMU's clock (s), finite and increasing.
    angles_rad : array_like, (M, S)
        The angles summed (the five pitches, rad as :func:`psmat.posture.spine_points`; the
        summed series is standardised, so degrees give the same lag); rows holding NaN
        (invalid samples, as :func:`psmat.io.load_imu_log` leaves them) are left out.
    max_lag_s : float, optional
        Largest ``|lag_s − (t_imu[0] − t_mat[0])|`` searched (s); default any lag keeping ``min_overlap``.
    sign : {None, 1, -1}
        Sign of the relation between summed conductance and summed angles: None takes the lag
        of the largest ``|r|`` (see the module docstring).
    lag_s : float, optional
        Manual override (thesis: "a semi manual process"): only report r there.
    imu_rate_hz : float, optional
        The IMU rate (Hz); default ``1 / median(diff(t_imu))``.
    min_overlap : float
        Smallest overlap searched, as a fraction of the shorter recording.

    Returns
    -------
    MatImuAlignment
    """
    if sign is not None and (not _checks.is_int(sign) or sign not in (1, -1)):
        raise ValueError(f"sign must be None, 1 or -1, got {sign!r}")
    ti = _checks.vector("t_imu", t_imu)
    a = _checks.real_array(angles_rad, "angles_rad", allow_nan=True)
    if a.ndim != 2 or a.shape[0] != ti.size or a.shape[1] < 1:
        raise ValueError(f"angles_rad must have shape ({ti.size}, S) (S sensors) to match t_imu, got {a.shape}")
    if not np.all(np.diff(ti) > 0):
        raise ValueError("t_imu must increase strictly")
    total = a.sum(axis=1)
    keep = np.isfinite(total)
    ti, total = ti[keep], total[keep]
    if ti.size < _MIN_SAMPLES:
        raise ValueError(f"the IMUs have {ti.size} valid samples; alignment needs at least {_MIN_SAMPLES}")
    fs = (1.0 / float(np.median(np.diff(ti)))) if imu_rate_hz is None else _checks.positive("imu_rate_hz", imu_rate_hz)
    tm, sm = summed_mat_at_rate(t_mat, g_mat, fs)
    if tm.size < _MIN_SAMPLES:
        raise ValueError(f"the mat spans {tm.size} IMU samples; alignment needs at least {_MIN_SAMPLES}")
    if not (sm.std() > 0):
        raise ValueError("the summed mat signal does not change: nothing to align")
    if not (total.std() > 0):
        raise ValueError("the summed angles do not change: nothing to align")
    min_overlap = _checks.fraction("min_overlap", min_overlap, 0.0, 1.0)
    ref, mat = total[:, None], sm[:, None]  # search_lag: mat(t) ≈ imu(t + lag)
    if lag_s is not None:
        lag = _checks.finite("lag_s", lag_s)
        r_arr, ov = pearson_at_lag(ti, ref, tm, mat, lag)
        if ov == 0.0:
            raise ValueError(f"with lag_s = {lag:g} s the mat and the IMUs do not overlap")
        r = float(r_arr[0])
        used = sign if sign is not None else (1 if r >= 0 else -1)
    else:
        found = [(search_lag(ti, s * ref, tm, mat, fs, max_lag_s=max_lag_s, min_overlap=min_overlap), s)
                 for s in ((1, -1) if sign is None else (sign,))]
        (lag, r_arr, ov), used = max(found, key=lambda f: f[0][1][0])  # the largest r of the signs searched
        r = used * float(r_arr[0])
    inside = (ti - lag >= tm[0]) & (ti - lag <= tm[-1])
    t_s = ti[inside]
    return MatImuAlignment(lag_s=lag, r=r, sign=int(used), fs_hz=float(fs), overlap_s=ov, manual=lag_s is not None,
                           t_s=t_s, mat=_standardise(np.interp(t_s - lag, tm, sm)), imu=_standardise(total[inside]))

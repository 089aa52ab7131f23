"""Time alignment of the mat's CoP with the force platform's (thesis §3.2.1, docs/spec.md §7 and §9).

The two instruments start on their own clocks and sample at their own rates; the mat also
sees a smaller, offset trajectory (its gain and its origin differ). :func:`align` resamples
both traces to a common rate, maximises over the lag the sum of the two components' Pearson
correlations on that lag's overlap (so gains and offsets drop out, and a quiet stretch at
one end cannot pull the peak), refines the peak below one sample (a parabola through the three samples
around it, then the Pearson correlation maximised on the continuous lag), and reports the
lag and the correlation there. ``lag_s`` given by the user overrides the search. The search
itself, :func:`search_lag`, is psmat's one cross-correlation alignment: the posture study's
mat-to-IMU alignment (thesis Fig. 4.11, :func:`psmat.posture.align_mat_imu`) runs it on one column.

Convention (docs/spec.md §9): ``cop(t) ≈ cop_ref(t + lag_s)``, each time on its own clock: when the
mat's clock reads ``t`` the platform's reads ``t + lag_s``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import optimize

from .. import _checks

__all__ = ["Alignment", "align", "pearson_at_lag", "resample_standardised", "search_lag", "POOR_ALIGNMENT_R",
           "PLATFORM_AXES", "orient_platform", "find_platform_axes"]

#: An alignment whose correlation (the mean of the M-L and A-P components') is below this shows no
#: sway the two traces share: the platform file is another recording's, or the mat did not see the
#: sway. Its lag, and the Eu and the comparisons made at it, mean nothing (:attr:`Alignment.poor`).
#: In simulation (mats the processing does not know, BDS sway) a session's own platform file aligns at
#: r 0.96-0.99; another recording's at 0.07-0.24 over 60 s, and up to 0.51 over 12 s (a short trace
#: correlates more by chance at some lag).
POOR_ALIGNMENT_R = 0.6


@dataclass(frozen=True)
class Alignment:
    """Result of :func:`align`.

    Attributes
    ----------
    lag_s : float
        ``cop(t) ≈ cop_ref(t + lag_s)`` (s).
    r : float
        Pearson correlation at ``lag_s``, the mean of the M-L and A-P components' (``r_ml``,
        ``r_ap``), on the overlap of the two traces.
    r_ml, r_ap : float
        Per component.
    fs_hz : float
        Common rate the search ran at (Hz).
    overlap_s : float
        Duration the two traces share at ``lag_s`` (s).
    manual : bool
        ``lag_s`` was given, not searched.
    """

    lag_s: float
    r: float
    r_ml: float
    r_ap: float
    fs_hz: float
    overlap_s: float
    manual: bool = False

    @property
    def poor(self) -> bool:
        """``r`` is below :data:`POOR_ALIGNMENT_R` (or not a number): the traces share no sway."""
        return not self.r >= POOR_ALIGNMENT_R

    def to_ref_time(self, t: ArrayLike) -> NDArray[np.float64]:
        """Times of the mat's clock on the platform's clock (s)."""
        return np.asarray(t, dtype=np.float64) + self.lag_s


def _trace(t: ArrayLike, cop: ArrayLike, name: str) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    tt = _checks.vector(f"{name} times", t)
    c = _checks.real_array(cop, name, unit="cm")
    if c.ndim != 2 or c.shape[1] != 2 or c.shape[0] != tt.size:
        raise ValueError(f"{name} must have shape ({tt.size}, 2) (M-L, A-P in cm) to match its times, got {c.shape}")
    if tt.size < 8:
        raise ValueError(f"{name} has {tt.size} samples; alignment needs at least 8")
    if not np.all(np.diff(tt) > 0):
        raise ValueError(f"{name} times must increase strictly")
    sd = c.std(axis=0)
    if not np.all(sd > 0):
        raise ValueError(f"{name} does not move on one axis: nothing to align")
    return tt, c


def resample_standardised(t: NDArray[np.float64], c: NDArray[np.float64], fs_hz: float) -> NDArray[np.float64]:
    """The trace ``c`` (N, K) standardised per column on a uniform grid from t[0] at fs_hz (linear interpolation)."""
    grid = t[0] + np.arange(int(np.floor((t[-1] - t[0]) * fs_hz)) + 1) / fs_hz
    out = np.column_stack([np.interp(grid, t, c[:, k]) for k in range(c.shape[1])])
    return (out - out.mean(axis=0)) / out.std(axis=0)


def pearson_at_lag(t_ref: NDArray[np.float64], c_ref: NDArray[np.float64], t: NDArray[np.float64],
                   c: NDArray[np.float64], lag_s: float) -> tuple[NDArray[np.float64], float]:
    """Per column, the Pearson r of ``c`` (N, K) and ``c_ref(t + lag_s)`` on their overlap, at the samples
    of ``c``, and the overlap's duration (s); NaN and 0 when fewer than 8 samples overlap."""
    tr = t + lag_s
    keep = (tr >= t_ref[0]) & (tr <= t_ref[-1])
    if keep.sum() < 8:
        return np.full(c.shape[1], np.nan), 0.0
    ref = np.column_stack([np.interp(tr[keep], t_ref, c_ref[:, k]) for k in range(c.shape[1])])
    r = np.array([np.corrcoef(c[keep, k], ref[:, k])[0, 1] for k in range(c.shape[1])])
    return r, float(tr[keep][-1] - tr[keep][0])


def _overlap_pearson(A: NDArray[np.float64], B: NDArray[np.float64], n: NDArray[np.int64]) -> NDArray[np.float64]:
    """Sum over the columns of the Pearson correlation of A and B on each lag's overlap.

    Each lag's own overlap, not the whole traces' standardisation: a lag that drops a quiet
    start must not score above the true one. The overlap sums (Σa, Σb, Σa², Σb², Σab) come
    from cross-correlations with a window of ones, in the order of
    ``signal.correlation_lags(len(A), len(B))``.
    """
    from scipy import signal  # here, not at import: scipy.signal is slow to import (docs/architecture.md)

    def xc(a: NDArray[np.float64], b: NDArray[np.float64]) -> NDArray[np.float64]:
        return signal.correlate(a, b, mode="full", method="fft")

    one_a, one_b = np.ones(len(A)), np.ones(len(B))
    total = np.zeros(n.size)
    for k in range(A.shape[1]):
        a, b = A[:, k], B[:, k]
        sa, sb = xc(a, one_b), xc(one_a, b)
        cov = n * xc(a, b) - sa * sb
        va = n * xc(a * a, one_b) - sa * sa
        vb = n * xc(one_a, b * b) - sb * sb
        den = np.sqrt(np.clip(va, 0.0, None) * np.clip(vb, 0.0, None))
        total += np.where(den > 1e-9 * n * n, cov / np.where(den > 0, den, 1.0), 0.0)
    return total


def search_lag(t_ref: NDArray[np.float64], c_ref: NDArray[np.float64], t: NDArray[np.float64],
               c: NDArray[np.float64], fs_hz: float, *, max_lag_s: float | None = None,
               min_overlap: float = 0.5) -> tuple[float, NDArray[np.float64], float]:
    """The lag that maximises the summed per-column Pearson r of ``c(t)`` and ``c_ref(t + lag)``.

    The one cross-correlation search of psmat (balance §3.2.1, posture Fig. 4.11): both traces
    (times increasing, values (N, K) with every column moving) are resampled to ``fs_hz`` and
    standardised, each integer lag is scored by the Pearson r on its own overlap, the peak is
    refined by a parabola through its three samples, then by maximising the r on the continuous
    lag within one sample of it (and within ``max_lag_s``, which the result never leaves).

    Parameters
    ----------
    t_ref, c_ref : (N,) s and (N, K)
        The reference trace on its clock.
    t, c : (M,) s and (M, K)
        The other trace on its own clock.
    fs_hz : float
        Rate of the search (Hz).
    max_lag_s : float, optional
        Largest ``|lag − (t_ref[0] − t[0])|`` searched (s); default any lag keeping ``min_overlap``.
    min_overlap : float
        Smallest overlap searched, as a fraction of the shorter trace.

    Returns
    -------
    lag_s : float
        ``c(t) ≈ c_ref(t + lag_s)`` (s).
    r : ndarray, (K,)
        Pearson r per column at ``lag_s``.
    overlap_s : float
        Duration the traces share at ``lag_s`` (s).
    """
    from scipy import signal  # here, not at import: scipy.signal is slow to import

    A, B = resample_standardised(t_ref, c_ref, fs_hz), resample_standardised(t, c, fs_hz)
    lags = signal.correlation_lags(len(A), len(B))
    overlap = np.minimum(len(A), lags + len(B)) - np.maximum(0, lags)
    ok = overlap >= max(8, min_overlap * min(len(A), len(B)))
    base = t_ref[0] - t[0]
    lo, hi = -np.inf, np.inf
    if max_lag_s is not None:
        max_lag_s = _checks.positive("max_lag_s", max_lag_s)
        ok &= np.abs(lags / fs_hz) <= max_lag_s
        lo, hi = base - max_lag_s, base + max_lag_s
    if not ok.any():
        raise ValueError("no lag satisfies max_lag_s and min_overlap: the traces cannot be aligned")
    score = np.where(ok, _overlap_pearson(A, B, overlap), -np.inf)
    j = int(np.argmax(score))
    shift = float(lags[j])
    if 0 < j < len(score) - 1 and np.isfinite(score[j - 1]) and np.isfinite(score[j + 1]):
        y0, y1, y2 = score[j - 1], score[j], score[j + 1]
        den = y0 - 2 * y1 + y2
        if den < 0:
            shift += 0.5 * (y0 - y2) / den  # vertex of the parabola through the three samples
    guess = base + shift / fs_hz

    def neg_r(lag: float) -> float:
        total = float(pearson_at_lag(t_ref, c_ref, t, c, lag)[0].sum())
        return -total if np.isfinite(total) else float(c.shape[1])

    res = optimize.minimize_scalar(neg_r, bounds=(max(guess - 1.0 / fs_hz, lo), min(guess + 1.0 / fs_hz, hi)),
                                   method="bounded", options={"xatol": 1e-6})
    lag = float(res.x) if res.fun <= neg_r(guess) else guess
    r, ov = pearson_at_lag(t_ref, c_ref, t, c, lag)
    return lag, r, ov


def align(t_ref: ArrayLike, cop_ref: ArrayLike, t: ArrayLike, cop: ArrayLike, *, fs_hz: float | None = None,
          max_lag_s: float | None = None, lag_s: float | None = None, min_overlap: float = 0.5) -> Alignment:
    """Align a mat CoP trace with the force platform's.

    Parameters
    ----------
    t_ref, cop_ref : arrays, (N,) s and (N, 2) cm
        The force platform (the reference): times on its clock, CoP (M-L, A-P).
    t, cop : arrays, (M,) s and (M, 2) cm
        The mat: times on its own clock, CoP (M-L, A-P).
    fs_hz : float, optional
        Common rate of the search (Hz); default the higher of the two traces' mean rates.
    max_lag_s : float, optional
        Largest ``|lag − (t_ref[0] − t[0])|`` searched (s), the sub-sample refinement included:
        how far apart the two starts may be beyond what the clocks say; default any lag that
        keeps ``min_overlap``.
    lag_s : float, optional
        Manual override: use this lag, only report the correlation there.
    min_overlap : float
        Smallest overlap searched, as a fraction of the shorter trace.

    Returns
    -------
    Alignment
    """
    tr, cr = _trace(t_ref, cop_ref, "cop_ref")
    tm, cm = _trace(t, cop, "cop")
    if lag_s is not None:
        lag = _checks.finite("lag_s", lag_s)
        r, ov = pearson_at_lag(tr, cr, tm, cm, lag)
        if ov == 0.0:
            raise ValueError(f"with lag_s = {lag:g} s the two traces do not overlap")
        fs_used = float((tm.size - 1) / (tm[-1] - tm[0]))
        return Alignment(lag, 0.5 * float(r[0] + r[1]), float(r[0]), float(r[1]), fs_used, ov, manual=True)
    rates = [(tr.size - 1) / (tr[-1] - tr[0]), (tm.size - 1) / (tm[-1] - tm[0])]
    fs = max(rates) if fs_hz is None else _checks.positive("fs_hz", fs_hz)
    min_overlap = _checks.fraction("min_overlap", min_overlap, 0.0, 1.0)
    lag, r, ov = search_lag(tr, cr, tm, cm, fs, max_lag_s=max_lag_s, min_overlap=min_overlap)
    return Alignment(lag, 0.5 * float(r[0] + r[1]), float(r[0]), float(r[1]), float(fs), ov)


#: How a platform's axes lie on the mat's: ``"M-L,A-P"`` in terms of the platform's x and y as loaded
#: (:func:`psmat.io.load_forceplate_csv`: x = M-L, y = A-P unless told otherwise), each reversed
#: (``-``) or not, swapped or not. ``"x,y"``: as loaded; ``"x,-y"``: its A-P axis points the other way
#: (towards the heels where the mat's points towards the toes); ``"y,x"``: its x is A-P.
PLATFORM_AXES = ("x,y", "-x,y", "x,-y", "-x,-y", "y,x", "-y,x", "y,-x", "-y,-x")


def orient_platform(cop_cm: ArrayLike, axes: str = "x,y") -> NDArray[np.float64]:
    """A platform's CoP ``(N, 2)`` (its x, y as loaded, cm) on the mat's axes (M-L, A-P, cm), by
    ``axes`` (one of :data:`PLATFORM_AXES`)."""
    if axes not in PLATFORM_AXES:
        raise ValueError(f"platform axes must be one of {', '.join(PLATFORM_AXES)}, got {axes!r}")
    c = np.asarray(cop_cm, dtype=np.float64)
    cols = [(-1.0 if a.startswith("-") else 1.0) * c[:, "xy".index(a[-1])] for a in axes.split(",")]
    return np.column_stack(cols)


def find_platform_axes(t_ref: ArrayLike, cop_ref_cm: ArrayLike, t: ArrayLike, cop_cm: ArrayLike, *,
                       besides: str = "x,y", max_lag_s: float | None = None) -> tuple[str, Alignment] | None:
    """The platform axes (:data:`PLATFORM_AXES`, other than ``besides``) under which the platform's CoP
    ``cop_ref_cm`` (as loaded; times ``t_ref`` s) aligns with the mat's ``cop_cm`` (times ``t`` s) without
    being :attr:`Alignment.poor`: the best of
    them and its alignment, or None. For a poor alignment, it tells a platform whose axes point
    otherwise than the mat's (its A-P reversed: that component's correlation is about -1 and cancels the
    other's) from another recording's file (no orientation aligns)."""
    found = [(axes, align(t_ref, orient_platform(cop_ref_cm, axes), t, cop_cm, max_lag_s=max_lag_s))
             for axes in PLATFORM_AXES if axes != besides]
    axes, best = max(found, key=lambda f: f[1].r)
    return None if best.poor else (axes, best)

"""Sway metrics of a centre-of-pressure trace (docs/spec.md §7, the BDS authors' definitions).

Santos & Duarte (2016), "A public data set of human balance evaluations", PeerJ 4:e2648,
publish the area, mean velocity and mean frequency of every trial; these definitions
reproduce them (``tests/unit/test_balance_sway.py`` checks all 24 trials shipped with the project).

All metrics are on the mean-removed trace; axes are M-L (x, columns) and A-P (y, rows), cm.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import signal, stats

from .. import _checks

__all__ = ["Sway", "sway", "prediction_ellipse_area", "mean_frequency"]


@dataclass(frozen=True)
class Sway:
    """Sway metrics of one trace (docs/spec.md §7); lengths in cm, times in s."""

    sd_ml_cm: float  # standard deviation, M-L (ddof 1)
    sd_ap_cm: float  # standard deviation, A-P (ddof 1)
    range_ml_cm: float  # max - min, M-L
    range_ap_cm: float  # max - min, A-P
    path_cm: float  # total path length
    velocity_cm_s: float  # path / duration, duration = N / fs
    area95_cm2: float  # 95 % prediction ellipse
    mean_freq_hz: float  # power-weighted mean of the per-axis Welch mean frequencies

    def as_dict(self) -> dict[str, float]:
        """The metrics by name (the column names of a study's metrics table)."""
        return asdict(self)


def _trace(cop: ArrayLike) -> NDArray[np.float64]:
    a = _checks.real_array(cop, "cop", unit="cm")
    if a.ndim != 2 or a.shape[1] != 2:
        raise ValueError(f"cop must have shape (T, 2) (M-L, A-P in cm), got {a.shape}")
    if a.shape[0] < 4:
        raise ValueError(f"cop has {a.shape[0]} samples; sway metrics need at least 4")
    return a - a.mean(axis=0)


def prediction_ellipse_area(cop_cm: ArrayLike, p: float = 0.95) -> float:
    """Area (cm²) of the ``p`` prediction ellipse of a (T, 2) trace (docs/spec.md §7).

    ``π·√(λ1·F)·√(λ2·F)`` with λ the eigenvalues of the covariance (ddof 1) and
    ``F = F_p(2, n−2)·2(n−1)(n+1)/(n(n−2))``.
    """
    x = _trace(cop_cm)
    n = x.shape[0]
    lam = np.linalg.eigvalsh(np.cov(x, rowvar=False, ddof=1))
    f = stats.f.ppf(p, 2, n - 2) * 2.0 * (n - 1) * (n + 1) / (n * (n - 2))
    return float(np.pi * f * np.sqrt(max(lam[0], 0.0) * max(lam[1], 0.0)))


def mean_frequency(cop_cm: ArrayLike, fs_hz: float) -> tuple[float, float, float]:
    """Mean frequency (Hz): (combined, M-L, A-P) from Welch PSDs (docs/spec.md §7).

    Per axis: Hann window, nperseg = N/2, noverlap = N/4, nfft = N/2, constant detrend;
    ``∫f·P / ∫P`` by the trapezoid rule. The combined value weights each axis by ``∫P``.
    """
    fs = _checks.positive("fs_hz", fs_hz)
    x = _trace(cop_cm)
    n = x.shape[0]
    seg = n // 2
    f, P = signal.welch(x, fs=fs, window="hann", nperseg=seg, noverlap=seg // 2, nfft=seg,
                        detrend="constant", axis=0)
    power = np.trapezoid(P, f, axis=0)
    if not np.all(power > 0):
        raise ValueError("the trace does not move on one axis: its mean frequency is undefined")
    per_axis = np.trapezoid(f[:, None] * P, f, axis=0) / power
    combined = float(np.sum(per_axis * power) / np.sum(power))
    return combined, float(per_axis[0]), float(per_axis[1])


def sway(cop: ArrayLike, fs_hz: float) -> Sway:
    """Sway metrics of a centre-of-pressure trace.

    Parameters
    ----------
    cop : array, (T, 2)
        Centre of pressure in cm: M-L (x) and A-P (y), sampled at ``fs_hz``.
    fs_hz : float
        Sampling rate (Hz).

    Returns
    -------
    Sway
        ``sd_ml_cm, sd_ap_cm, range_ml_cm, range_ap_cm, path_cm, velocity_cm_s,
        area95_cm2, mean_freq_hz``.
    """
    fs = _checks.positive("fs_hz", fs_hz)
    x = _trace(cop)
    n = x.shape[0]
    sd = x.std(axis=0, ddof=1)
    rng = x.max(axis=0) - x.min(axis=0)
    path = float(np.sum(np.hypot(*np.diff(x, axis=0).T)))
    return Sway(
        sd_ml_cm=float(sd[0]), sd_ap_cm=float(sd[1]),
        range_ml_cm=float(rng[0]), range_ap_cm=float(rng[1]),
        path_cm=path, velocity_cm_s=path / (n / fs),
        area95_cm2=prediction_ellipse_area(x),
        mean_freq_hz=mean_frequency(x, fs)[0],
    )

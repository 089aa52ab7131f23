"""Frequency descriptors of a CoP trace, preset ``quijoux2021`` (docs/spec.md §7).

Definitions after Quijoux et al. (2021) and their open code; psmat's own implementation.
The input is the preprocessed trace: uniformly sampled at ``fs_hz``, mean removed, in cm.

* ``mean_frequency_{ML,AP,ML_AND_AP}`` (Hz) is not read from a spectrum: it is the ratio of
  the mean velocity to the mean distance (Prieto et al. 1996), ``v̄/(4√2·d̄)`` per axis and
  ``v̄/(2π·d̄)`` on the plane (velocity = |finite difference|·fs, d̄ = mean |x| or mean radius).
  A circle of frequency f traced at constant speed gives f on the plane; Gaussian white noise
  gives fs/4 on each axis.
* the ``_Power_Spectrum_Density_{ML,AP}`` family reads a Welch PSD (Hann window, 10 s segments,
  50 % overlap, linear detrend per segment, zero-padded to the trace's length so that the bins
  are fs/N apart) restricted to the band [0.15, 5] Hz. Powers are ``Σ P·Δf`` over the bins
  (cm²); the reference code sums P without Δf (its values are ours divided by Δf).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import signal

from .. import _checks

__all__ = ["compute", "welch_psd", "BAND_HZ", "SEGMENT_S"]

BAND_HZ = (0.15, 5.0)  # the band every spectral descriptor reads (Hz)
SEGMENT_S = 10.0  # Welch segment length (s), overlap one half
_PSD = "_Power_Spectrum_Density_"


def _traces(ml_cm: ArrayLike, ap_cm: ArrayLike, fs_hz: float) -> tuple[NDArray[np.float64], NDArray[np.float64], float]:
    fs = _checks.positive("fs_hz", fs_hz)
    ml = _checks.vector("ml_cm", ml_cm)
    ap = _checks.vector("ap_cm", ap_cm)
    if ml.shape != ap.shape:
        raise ValueError(f"ml_cm and ap_cm must have the same length, got {ml.size} and {ap.size}")
    if ml.size < 4:
        raise ValueError(f"the trace has {ml.size} samples; the descriptors need at least 4")
    return ml, ap, fs


def welch_psd(x_cm: ArrayLike, fs_hz: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """One-sided Welch PSD (cm²/Hz) of a uniformly sampled trace, and its frequencies (Hz).

    Hann window of ``SEGMENT_S`` (or the whole trace when shorter), 50 % overlap, linear
    detrend per segment, FFT length = the trace's length (bins ``fs/N`` apart).
    """
    fs = _checks.positive("fs_hz", fs_hz)
    x = _checks.vector("x_cm", x_cm)
    n = x.size
    seg = min(int(round(SEGMENT_S * fs)), n)
    f, p = signal.welch(x, fs=fs, window="hann", nperseg=seg, noverlap=seg // 2, nfft=max(n, seg),
                        detrend="linear", scaling="density")
    return f, p


def _mean_frequency(ml: NDArray[np.float64], ap: NDArray[np.float64], fs: float) -> dict[str, float]:
    out: dict[str, float] = {}
    for name, x in (("ML", ml), ("AP", ap)):
        d = float(np.mean(np.abs(x)))
        if d <= 0:
            raise ValueError(f"the {name} trace does not move: its mean frequency is undefined")
        out[f"mean_frequency_{name}"] = float(np.mean(np.abs(np.diff(x))) * fs) / (4.0 * math.sqrt(2.0) * d)
    r = float(np.mean(np.hypot(ml, ap)))
    v = float(np.mean(np.hypot(np.diff(ml), np.diff(ap))) * fs)
    out["mean_frequency_ML_AND_AP"] = v / (2.0 * math.pi * r)
    return out


def _spectral(x: NDArray[np.float64], fs: float, axis: str) -> dict[str, float]:
    f, p = welch_psd(x, fs)
    df = float(f[1] - f[0])
    lo, hi = BAND_HZ
    keep = (f >= lo) & (f <= hi)
    if not keep.any():
        raise ValueError(f"the PSD has no bin in [{lo}, {hi}] Hz (fs_hz={fs}, {x.size} samples)")
    f, p = f[keep], p[keep]
    m0, m1, m2 = (float(np.sum(f ** k * p)) for k in (0, 1, 2))
    if not m0 > 0:
        raise ValueError(f"the {axis} trace has no power in [{lo}, {hi}] Hz: its spectral descriptors are undefined")
    cum = np.cumsum(p)
    below = float(np.sum(p[f <= 0.5])) * df
    middle = float(np.sum(p[(f > 0.5) & (f <= 2.0)])) * df
    above = float(np.sum(p[f > 2.0])) * df
    s = _PSD + axis
    return {
        "total_power" + s: m0 * df,
        "power_frequency_50" + s: float(f[np.argmax(cum >= 0.5 * cum[-1])]),
        "power_frequency_95" + s: float(f[np.argmax(cum >= 0.95 * cum[-1])]),
        "frequency_mode" + s: float(f[np.argmax(p)]),
        "centroid_frequency" + s: math.sqrt(m2 / m0),
        "frequency_dispersion" + s: math.sqrt(max(1.0 - m1 * m1 / (m0 * m2), 0.0)),
        "energy_content_below_05" + s: below,
        "energy_content_05_2" + s: middle,
        "energy_content_above_2" + s: above,
        "frequency_quotient" + s: above / (below + middle) if below + middle > 0 else math.inf,
    }


def compute(ml_cm: ArrayLike, ap_cm: ArrayLike, fs_hz: float) -> dict[str, float]:
    """The frequency descriptors of a preprocessed trace (docs/spec.md §7).

    Parameters
    ----------
    ml_cm, ap_cm : array, (N,)
        M-L and A-P centre of pressure (cm), uniformly sampled, mean removed.
    fs_hz : float
        Sampling rate (Hz).

    Returns
    -------
    dict[str, float]
        ``mean_frequency_{ML,AP,ML_AND_AP}`` (Hz) and, with the suffix
        ``_Power_Spectrum_Density_{ML,AP}``: ``total_power``, ``energy_content_below_05``,
        ``energy_content_05_2``, ``energy_content_above_2`` (cm²); ``power_frequency_50``,
        ``power_frequency_95``, ``frequency_mode``, ``centroid_frequency`` (Hz);
        ``frequency_dispersion``, ``frequency_quotient`` (no unit).
    """
    ml, ap, fs = _traces(ml_cm, ap_cm, fs_hz)
    out = _mean_frequency(ml, ap, fs)
    out.update(_spectral(ml, fs, "ML"))
    out.update(_spectral(ap, fs, "AP"))
    return out

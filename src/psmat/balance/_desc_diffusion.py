"""Stabilogram diffusion descriptors, preset ``quijoux2021`` (docs/spec.md §7).

Stabilogram diffusion analysis (Collins & De Luca 1993) as Quijoux et al. (2021) compute it;
psmat's own implementation. Per axis, on the preprocessed trace (uniform, mean removed, cm):

* the diffusion plot: the mean square displacement ``MSD(τ) = mean_i (x[i+k] − x[i])²`` at the
  lags ``τ = k/fs``, k = 1 … ⌊N/3⌋ (cm²);
* two straight lines in log–log, ``log MSD = b + a·log τ``: the short-time line fits the lags
  1 … i, the long-time line the lags i … ⌊N/3⌋; each one's i is searched over
  ``⌊0.3·fs⌋ + 1 … ⌊2.5·fs⌋`` (0.3 s to 2.5 s) and is the one whose fit leaves the smallest
  root mean square residual (the last one on a tie). The two searches are independent;
* diffusion = ``exp(b)`` (cm²/s^a: the MSD the line gives at τ = 1 s, i.e. ``2D`` in Collins &
  De Luca's ``MSD = 2D·τ``), scaling = ``a/2`` (the Hurst-like exponent H of ``MSD ∝ τ^2H``);
* critical time = where the two lines cross, ``exp((b_l − b_s)/(a_s − a_l))`` (s), at most the
  longest lag; critical displacement = the short-time line's MSD there (cm²).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ._desc_frequency import _traces

__all__ = ["compute", "diffusion_plot"]

MAX_LAG_FRACTION = 1.0 / 3.0  # the diffusion plot reaches a third of the trial
REGION_S = (0.3, 2.5)  # where the boundary between the two regions is searched (s)
_SDA = "_Diffusion_"


def diffusion_plot(x_cm: ArrayLike, fs_hz: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Lags (s) and mean square displacement (cm²) of one axis, lags 1 … ⌊N/3⌋ samples.

    ``MSD(k) = (Σ_{i≥k} x_i² + Σ_{i<N−k} x_i² − 2·Σ_i x_i·x_{i+k}) / (N − k)``, the products
    summed by FFT.
    """
    x = np.asarray(x_cm, dtype=np.float64)
    n = x.size
    kmax = int(n * MAX_LAG_FRACTION)
    k = np.arange(1, kmax + 1)
    nfft = 1 << (2 * n - 1).bit_length()
    spec = np.fft.rfft(x, nfft)
    acf = np.fft.irfft(spec * np.conj(spec), nfft)[1:kmax + 1]
    sq = np.concatenate(([0.0], np.cumsum(x * x)))  # sq[j] = Σ_{i<j} x_i²
    tail = sq[n] - sq[k]  # Σ_{i≥k} x_i²
    head = sq[n - k]  # Σ_{i<N−k} x_i²
    msd = (tail + head - 2.0 * acf) / (n - k)
    return k / fs_hz, np.maximum(msd, 0.0)


def _fit(log_t: NDArray[np.float64], log_msd: NDArray[np.float64]) -> tuple[float, float, float]:
    """Slope, intercept and root mean square residual of a least-squares line."""
    a, b = np.polyfit(log_t, log_msd, 1)
    rms = float(np.sqrt(np.mean((log_msd - (a * log_t + b)) ** 2)))
    return float(a), float(b), rms


def _best(fits: list[tuple[float, float, float]]) -> tuple[float, float]:
    best = 0
    for j, fit in enumerate(fits):
        if fit[2] <= fits[best][2]:
            best = j
    return fits[best][0], fits[best][1]


def _axis(x: NDArray[np.float64], fs: float, axis: str) -> dict[str, float]:
    t, msd = diffusion_plot(x, fs)
    i_lo, i_hi = int(REGION_S[0] * fs) + 1, int(REGION_S[1] * fs)
    if t.size < i_hi + 2:
        raise ValueError(f"the trace lasts {x.size / fs:.3g} s: stabilogram diffusion needs lags up to "
                         f"{REGION_S[1]} s within a third of the trial, i.e. at least {3 * (i_hi + 2) / fs:.3g} s")
    if not np.all(msd > 0):
        raise ValueError(f"the {axis} trace does not move: its diffusion plot has no logarithm")
    lt, lm = np.log(t), np.log(msd)
    a_s, b_s = _best([_fit(lt[:i], lm[:i]) for i in range(i_lo, i_hi + 1)])
    a_l, b_l = _best([_fit(lt[i - 1:], lm[i - 1:]) for i in range(i_lo, i_hi + 1)])
    log_tc = (b_l - b_s) / (a_s - a_l) if a_s != a_l else math.inf
    log_tc = min(log_tc, float(lt[-1]))
    s = _SDA + axis
    return {
        "short_time_diffusion" + s: math.exp(b_s),
        "long_time_diffusion" + s: math.exp(b_l),
        "critical_time" + s: math.exp(log_tc),
        "critical_displacement" + s: math.exp(b_s + a_s * log_tc),
        "short_time_scaling" + s: a_s / 2.0,
        "long_time_scaling" + s: a_l / 2.0,
    }


def compute(ml_cm: ArrayLike, ap_cm: ArrayLike, fs_hz: float) -> dict[str, float]:
    """The stabilogram diffusion descriptors of a preprocessed trace (docs/spec.md §7).

    Parameters
    ----------
    ml_cm, ap_cm : array, (N,)
        M-L and A-P centre of pressure (cm), uniformly sampled, mean removed; the trial must
        last at least about 7.7 s (lags to 2.5 s within a third of it).
    fs_hz : float
        Sampling rate (Hz).

    Returns
    -------
    dict[str, float]
        With the suffix ``_Diffusion_{ML,AP}``: ``short_time_diffusion``,
        ``long_time_diffusion`` (cm²/s^(2H), the fitted MSD at 1 s), ``critical_time`` (s),
        ``critical_displacement`` (cm², a mean square displacement), ``short_time_scaling``,
        ``long_time_scaling`` (no unit, H).
    """
    ml, ap, fs = _traces(ml_cm, ap_cm, fs_hz)
    out = _axis(ml, fs, "ML")
    out.update(_axis(ap, fs, "AP"))
    return out

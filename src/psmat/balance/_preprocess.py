"""Preprocessing of a CoP trace before the posturography descriptors (docs/spec.md §7).

Preset ``quijoux2021`` (Quijoux et al. 2021): the trace is centred, resampled to 25 Hz by
SWARII (Sliding Windows Weighted Averaged Interpolation, window 1/25 s), low-passed by a
4th-order Butterworth filter at 10 Hz run forward then backward (zero phase), and centred
again (the filter moves the mean by a hair; every descriptor assumes a centred trace).
Without a preset the trace is only centred; its times must then be uniform.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import signal

from .. import _checks

__all__ = ["Prepared", "prepare", "preprocess", "describe_preset", "swarii", "lowpass", "RATE_HZ", "WINDOW_S",
           "CUTOFF_HZ", "ORDER", "PRESETS"]

#: The preset's resampling rate (Hz) and SWARII window (s).
RATE_HZ = 25.0
WINDOW_S = 1.0 / 25.0
#: The preset's low-pass: cutoff (Hz) and Butterworth order.
CUTOFF_HZ = 10.0
ORDER = 4
#: The presets :func:`preprocess` knows (None: no preset).
PRESETS = ("quijoux2021",)
#: Uniform times (no preset): every step within this fraction of the mean step.
_UNIFORM_RTOL = 0.01


@dataclass(frozen=True)
class Prepared:
    """A trace ready for the descriptor families: uniform, centred; lengths in cm, rate in Hz."""

    ml_cm: NDArray[np.float64]
    ap_cm: NDArray[np.float64]
    fs_hz: float
    mean_ml_cm: float  # mean of the raw M-L samples, before any processing
    mean_ap_cm: float  # mean of the raw A-P samples


def _inputs(t_s: ArrayLike, ml_cm: ArrayLike, ap_cm: ArrayLike) -> tuple[NDArray[np.float64], ...]:
    arrays = []
    for name, value, unit in (("t_s", t_s, "s"), ("ml_cm", ml_cm, "cm"), ("ap_cm", ap_cm, "cm")):
        a = _checks.real_array(value, name, unit=unit)
        if a.ndim != 1:
            raise ValueError(f"{name} must be one-dimensional, got shape {a.shape}")
        arrays.append(a)
    t, ml, ap = arrays
    if not (t.size == ml.size == ap.size):
        raise ValueError(f"t_s, ml_cm and ap_cm must have the same length, got {t.size}, {ml.size} and {ap.size}")
    if t.size < 2:
        raise ValueError(f"the trace has {t.size} sample(s); descriptors need a trace")
    steps = np.diff(t)
    if np.any(steps <= 0):
        i = int(np.argmax(steps <= 0))
        raise ValueError(f"t_s must increase strictly, but t_s[{i + 1}] = {t[i + 1]} follows t_s[{i}] = {t[i]}")
    return t, ml, ap


def swarii(t_s: ArrayLike, x: ArrayLike, rate_hz: float = RATE_HZ,
           window_s: float = WINDOW_S) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Resample an irregularly sampled signal by SWARII.

    The output times are ``t0 + k / rate_hz`` from the first sample to the last. At each
    output time ``τ`` the window ``(τ − w/2, τ + w/2)``, clipped to ``[t0, t_last]``, is shared
    among the samples strictly inside it: each gets the part of the window nearer to it than
    to its neighbours inside the window (cut at the midpoints between consecutive samples),
    and the output is the average of their values weighted by those lengths. A lone sample
    gives its own value. Windows holding no sample are filled by linear interpolation
    between their neighbours (held constant past the last filled one).

    Parameters
    ----------
    t_s : array, (N,)
        Strictly increasing sample times (s).
    x : array, (N,) or (N, k)
        Values at those times (any unit; the output has the same).
    rate_hz : float
        Output rate (Hz).
    window_s : float
        Window width (s).

    Returns
    -------
    (times_s, values)
        The output times (s), shape (M,), and values, shape (M,) or (M, k).
    """
    t = np.asarray(t_s, dtype=np.float64)
    v = np.asarray(x, dtype=np.float64)
    rate = _checks.positive("rate_hz", rate_hz)
    half = 0.5 * _checks.positive("window_s", window_s)
    t0, t1 = float(t[0]), float(t[-1])
    n_out = int(np.floor((t1 - t0) * rate + 1e-9)) + 1
    grid = t0 + np.arange(n_out) / rate
    lo = np.searchsorted(t, grid - half, side="right")   # first sample with t > τ − w/2
    hi = np.searchsorted(t, grid + half, side="left")    # one past the last with t < τ + w/2
    out = np.empty((n_out,) + v.shape[1:])
    filled = hi > lo
    _window_means(t, v.reshape(t.size, -1), np.maximum(grid - half, t0), np.minimum(grid + half, t1), lo, hi,
                  out.reshape(n_out, -1))
    if not filled.all():
        known = np.flatnonzero(filled)
        cols = out.reshape(n_out, -1)
        for j in range(cols.shape[1]):
            cols[:, j] = np.interp(grid, grid[known], cols[known, j])
    return grid, out


def _window_means(t: NDArray[np.float64], v: NDArray[np.float64], left: NDArray[np.float64],
                  right: NDArray[np.float64], lo: NDArray[np.intp], hi: NDArray[np.intp],
                  out: NDArray[np.float64]) -> None:
    """SWARII's weighted means into ``out`` (M, k) for the windows ``[left, right]`` (M,) (s) holding
    the samples ``lo[k]:hi[k]`` of ``t`` (N,) (s), ``v`` (N, k); rows of empty windows untouched.

    Array code over blocks of windows: each window's samples padded to the longest window of the
    block, each weighted by its cell between the cuts (the window's ends and the midpoints of
    consecutive samples).
    """
    mid = 0.5 * (t[1:] + t[:-1])  # mid[i]: the cut between samples i and i + 1
    count = hi - lo
    lone = np.flatnonzero(count == 1)
    out[lone] = v[lo[lone]]  # a lone sample gives its own value
    many = np.flatnonzero(count > 1)
    if many.size == 0:
        return
    width = int(count[many].max())
    step = max(1, (1 << 20) // (width * v.shape[1]))  # windows per block: ~8 MB of padded samples
    j = np.arange(width)
    for s in range(0, many.size, step):
        rows = many[s:s + step]
        a, b = lo[rows, None], hi[rows, None]
        idx = a + j  # (m, width) sample indices, valid below b
        inside = idx < b
        idx = np.where(inside, idx, a)
        cut_lo = np.where(j == 0, left[rows, None], mid[np.maximum(idx - 1, 0)])
        cut_hi = np.where(idx == b - 1, right[rows, None], mid[np.minimum(idx, mid.size - 1)])
        w = np.where(inside, cut_hi - cut_lo, 0.0)
        out[rows] = np.einsum("mj,mjk->mk", w, v[idx]) / w.sum(axis=1)[:, None]


def lowpass(x: ArrayLike, fs_hz: float, cutoff_hz: float = CUTOFF_HZ, order: int = ORDER) -> NDArray[np.float64]:
    """Zero-phase Butterworth low-pass (forward then backward) along the first axis.

    ``scipy.signal.filtfilt`` with its default padding: the signal must hold more than
    ``3·(order + 1)`` samples.
    """
    v = np.asarray(x, dtype=np.float64)
    b, a = signal.butter(order, cutoff_hz, btype="lowpass", fs=fs_hz)
    need = 3 * max(len(a), len(b)) + 1
    if v.shape[0] < need:
        raise ValueError(f"the trace has {v.shape[0]} samples at {fs_hz:g} Hz; the {cutoff_hz:g} Hz low-pass "
                         f"needs at least {need} ({need / fs_hz:g} s)")
    return signal.filtfilt(b, a, v, axis=0)


def _fraction_s(x: float) -> str:
    """A time (s) as ``1/n s`` when it is the inverse of a whole number, else as ``x s``."""
    n = round(1.0 / x)
    return f"1/{n} s" if n > 0 and abs(1.0 / n - x) <= 1e-12 * x else f"{x:g} s"


def _ordinal(n: int) -> str:
    """``4`` → ``"4th"``, ``2`` → ``"2nd"``."""
    return f"{n}{'th' if 10 <= n % 100 <= 20 else {1: 'st', 2: 'nd', 3: 'rd'}.get(n % 10, 'th')}"


def describe_preset(preset: str | None) -> str:
    """What :func:`preprocess` does to a trace with ``preset``, in words built from its constants.

    Parameters
    ----------
    preset : {"quijoux2021", None}
        The preset.

    Returns
    -------
    str
        A clause without a final stop, e.g. for ``"quijoux2021"`` "preset quijoux2021: SWARII
        resampling to 25 Hz (window 1/25 s), then a 4th-order Butterworth low-pass at 10 Hz run
        forward and backward (zero phase)"; for None, "no preprocessing: the trace as recorded
        (no resampling, no filter)".

    Raises
    ------
    ValueError
        An unknown preset (one line).
    """
    if preset is None:
        return "no preprocessing: the trace as recorded (no resampling, no filter)"
    if preset not in PRESETS:
        raise ValueError(f"preset must be one of {', '.join(PRESETS)} or None, got {preset!r}")
    return (f"preset {preset}: SWARII resampling to {RATE_HZ:g} Hz (window {_fraction_s(WINDOW_S)}), then a "
            f"{_ordinal(ORDER)}-order Butterworth low-pass at {CUTOFF_HZ:g} Hz run forward and backward (zero phase)")


def _uniform_rate_hz(t: NDArray[np.float64]) -> float:
    steps = np.diff(t)
    mean = float(np.mean(steps))
    worst = float(np.max(np.abs(steps - mean)))
    if worst > _UNIFORM_RTOL * mean:
        raise ValueError(f"preset=None needs uniform t_s, but a step differs from the mean {mean:g} s by {worst:g} s; "
                         "use preset='quijoux2021' to resample")
    return 1.0 / mean


def preprocess(t_s: ArrayLike, ml_cm: ArrayLike, ap_cm: ArrayLike, preset: str | None = "quijoux2021"
               ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """A CoP trace through a preset's resampling and filter, NOT centred (docs/spec.md §7, §9).

    The study applies this to the platform and to every mat variant alike before the sway
    metrics, so both go through the same processing.

    Parameters
    ----------
    t_s, ml_cm, ap_cm : array, (N,)
        Sample times (s, strictly increasing, irregular steps allowed) and the CoP's M-L and
        A-P coordinates (cm), finite.
    preset : {"quijoux2021", None}
        ``"quijoux2021"``: SWARII to 25 Hz (window 1/25 s) from the first sample, then a
        4th-order Butterworth low-pass at 10 Hz run forward and backward (zero phase).
        ``None``: the trace as given (checked, copied).

    Returns
    -------
    (t_s, ml_cm, ap_cm)
        Times (s) — ``t_s[0] + k / 25`` with the preset — and coordinates (cm), absolute (the
        mean is kept). Equal to :func:`prepare`'s trace plus its mean, up to rounding (the
        filter passes a constant unchanged).

    Raises
    ------
    ValueError
        As :func:`prepare`: bad arrays, times that do not increase, a trace too short for the
        low-pass (under 16 samples at 25 Hz), an unknown preset.
    """
    t, ml, ap = _inputs(t_s, ml_cm, ap_cm)
    xy = np.column_stack((ml, ap))
    if preset == "quijoux2021":
        t, xy = swarii(t, xy, RATE_HZ, WINDOW_S)
        xy = lowpass(xy, RATE_HZ)
    elif preset is not None:
        raise ValueError(f"preset must be 'quijoux2021' or None, got {preset!r}")
    return t.copy(), np.ascontiguousarray(xy[:, 0]), np.ascontiguousarray(xy[:, 1])


def prepare(t_s: ArrayLike, ml_cm: ArrayLike, ap_cm: ArrayLike, preset: str | None) -> Prepared:
    """Check a trace and bring it to the descriptor families' input (docs/spec.md §7).

    Parameters
    ----------
    t_s, ml_cm, ap_cm : array, (N,)
        Sample times (s, strictly increasing) and the CoP's M-L and A-P coordinates (cm).
    preset : {"quijoux2021", None}
        ``"quijoux2021"``: centre, SWARII to 25 Hz (window 1/25 s), Butterworth 4th order
        10 Hz forward-backward, centre. ``None``: centre only; the times must be uniform
        (every step within 1 % of the mean step) and give the rate.

    Returns
    -------
    Prepared
    """
    t, ml, ap = _inputs(t_s, ml_cm, ap_cm)
    mean_ml, mean_ap = float(ml.mean()), float(ap.mean())
    xy = np.column_stack((ml - mean_ml, ap - mean_ap))
    if preset is None:
        fs = _uniform_rate_hz(t)
    elif preset == "quijoux2021":
        fs = RATE_HZ
        _, xy = swarii(t, xy, RATE_HZ, WINDOW_S)
        xy = lowpass(xy, fs)
        xy = xy - xy.mean(axis=0)
    else:
        raise ValueError(f"preset must be 'quijoux2021' or None, got {preset!r}")
    return Prepared(ml_cm=np.ascontiguousarray(xy[:, 0]), ap_cm=np.ascontiguousarray(xy[:, 1]), fs_hz=fs,
                    mean_ml_cm=mean_ml, mean_ap_cm=mean_ap)

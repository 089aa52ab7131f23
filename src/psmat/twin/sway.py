"""Time base and band-limited sway of the twin's scenes (docs/spec.md §5): times in s, rates and bands in Hz, sway in cm."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .._checks import pair, positive

__all__ = ["band_noise", "time_base", "check_band", "sway_noise"]


def band_noise(n: int, rate_hz: float, band_hz: tuple[float, float], rng: np.random.Generator) -> NDArray[np.float64]:
    """Unit-SD Gaussian noise with its power in band_hz (FFT mask); zeros if the band is empty."""
    if n < 2:
        return np.zeros(n)
    spec = rng.standard_normal(n // 2 + 1) + 1j * rng.standard_normal(n // 2 + 1)
    f = np.fft.rfftfreq(n, 1.0 / rate_hz)
    spec[(f < band_hz[0]) | (f > band_hz[1])] = 0.0
    x = np.fft.irfft(spec, n)
    sd = x.std()
    return x / sd if sd > 0 else np.zeros(n)


def time_base(duration_s: Any, rate_hz: Any) -> tuple[NDArray[np.float64], float]:
    """Frame times ``k / rate_hz`` (s) for ``duration_s`` and the checked rate (Hz)."""
    duration = positive("duration_s", duration_s)
    rate = positive("rate_hz", rate_hz)
    n = int(math.floor(duration * rate + 1e-9))
    if n < 1:
        raise ValueError(f"duration_s={duration_s!r} at rate_hz={rate_hz!r} gives no frame")
    return np.arange(n) / rate, rate


def check_band(band_hz: Any) -> tuple[float, float]:
    """A frequency band ``(low, high)`` in Hz with ``0 <= low < high``."""
    lo, hi = pair("band_hz", band_hz)
    if not 0 <= lo < hi:
        raise ValueError(f"band_hz must be (low, high) with 0 <= low < high in Hz, got {band_hz!r}")
    return lo, hi


def sway_noise(n: int, rate: float, sway_cm: tuple[float, float], band: tuple[float, float], rng: np.random.Generator) -> NDArray[np.float64]:
    """Sway (n, 2) in cm: SDs ``sway_cm`` (M-L, A-P), each axis :func:`band_noise` in ``band``."""
    return np.column_stack(
        [sway_cm[0] * band_noise(n, rate, band, rng), sway_cm[1] * band_noise(n, rate, band, rng)]
    )

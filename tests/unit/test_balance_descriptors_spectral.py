"""Frequency and stabilogram-diffusion descriptors (preset quijoux2021, docs/spec.md §7).

Every expectation is a closed form: a sine or a circle of known amplitude and frequency,
Gaussian white noise of known variance (flat PSD), a random walk of known step variance, an
Ornstein–Uhlenbeck process of known time constant. Tolerances are derived beside each test.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from psmat.balance import _desc_diffusion, _desc_frequency

FS = 25.0  # Hz, the preset's rate
PSD = "_Power_Spectrum_Density_"
SEG_S = 10.0  # Welch segment (s)
LO, HI = 0.15, 5.0  # the spectral band (Hz)

FREQ_NAMES = {f"mean_frequency_{a}" for a in ("ML", "AP", "ML_AND_AP")} | {
    f"{n}{PSD}{a}" for a in ("ML", "AP") for n in (
        "total_power", "power_frequency_50", "power_frequency_95", "frequency_mode", "centroid_frequency",
        "frequency_dispersion", "energy_content_below_05", "energy_content_05_2", "energy_content_above_2",
        "frequency_quotient")}
DIFF_NAMES = {f"{n}_Diffusion_{a}" for a in ("ML", "AP") for n in (
    "short_time_diffusion", "long_time_diffusion", "critical_time", "critical_displacement",
    "short_time_scaling", "long_time_scaling")}


def _t(duration_s: float) -> np.ndarray:
    return np.arange(int(round(duration_s * FS))) / FS


def _centred(x: np.ndarray) -> np.ndarray:
    return x - x.mean()


# ---------------------------------------------------------------- frequency: sines and circles

def test_the_names_are_the_papers() -> None:
    t = _t(60.0)
    r = _desc_frequency.compute(np.sin(2 * np.pi * t), np.cos(2 * np.pi * 0.7 * t), FS)
    assert set(r) == FREQ_NAMES
    walk = np.cumsum(np.random.default_rng(1).normal(size=(1500, 2)), axis=0)
    assert set(_desc_diffusion.compute(*_centred(walk).T, FS)) == DIFF_NAMES


def test_a_sine_puts_its_power_at_its_frequency() -> None:
    # f0 = 1 Hz sits on a bin (bins are fs/N = 1/60 Hz apart) and gives 10 periods per 10 s segment.
    a_cm, f0 = 2.0, 1.0
    t = _t(60.0)
    ml, ap = a_cm * np.sin(2 * np.pi * f0 * t), a_cm * np.cos(2 * np.pi * f0 * t)
    r = _desc_frequency.compute(_centred(ml), _centred(ap), FS)
    df = FS / t.size
    # The Hann spectrum of a segment L long has rms width σ_f = 1/(√3·L) (∫w'² / (4π²∫w²)),
    # so m2/m0 = f0² + σ_f² and 1 − m1²/(m0·m2) = σ_f²/(f0² + σ_f²).
    sigma_f = 1.0 / (math.sqrt(3.0) * SEG_S)
    for axis in ("ML", "AP"):
        s = PSD + axis
        # Parseval: the density-scaled Welch PSD integrates to the mean square A²/2; the linear
        # detrend of each segment removes at most 6/(π²n²) = 0.6 % of it (n = 10 periods).
        assert r["total_power" + s] == pytest.approx(a_cm ** 2 / 2, rel=0.01)
        assert r["frequency_mode" + s] == pytest.approx(f0, abs=1e-9)
        # The main lobe is symmetric about f0: half the power is reached at f0's bin; 95 % of
        # it within the main lobe's half-width 2/L = 0.2 Hz above f0.
        assert abs(r["power_frequency_50" + s] - f0) <= df + 1e-9
        assert f0 < r["power_frequency_95" + s] <= f0 + 2.0 / SEG_S
        assert r["centroid_frequency" + s] == pytest.approx(math.hypot(f0, sigma_f), abs=1e-3)
        assert r["frequency_dispersion" + s] == pytest.approx(sigma_f / math.hypot(f0, sigma_f), rel=0.05)
        # Hann side lobes fall by 18 dB/octave: 0.5 Hz (5 lobes) away, the leakage is < 1e-3.
        assert r["energy_content_05_2" + s] == pytest.approx(r["total_power" + s], rel=1e-3)
        assert r["energy_content_below_05" + s] < 1e-3 * r["total_power" + s]
        assert r["energy_content_above_2" + s] < 1e-3 * r["total_power" + s]
        assert r["frequency_quotient" + s] < 1e-3


def test_three_sines_fill_the_three_bands() -> None:
    t = _t(60.0)
    amp = {0.3: 1.0, 1.0: 2.0, 3.0: 0.5}  # Hz: cm
    x = _centred(sum(a * np.sin(2 * np.pi * f * t) for f, a in amp.items()))
    r = _desc_frequency.compute(x, x[::-1].copy(), FS)
    for axis in ("ML", "AP"):
        s = PSD + axis
        assert r["energy_content_05_2" + s] == pytest.approx(2.0 ** 2 / 2, rel=0.01)
        assert r["energy_content_above_2" + s] == pytest.approx(0.5 ** 2 / 2, rel=0.01)
        # 0.3 Hz: 3 periods per segment; the main lobe (±0.2 Hz) crosses the band's 0.15 Hz
        # edge and the detrend takes up to 6/(π²·9) ≈ 7 %: only a bound is certain.
        assert 0.9 * 0.5 < r["energy_content_below_05" + s] <= 0.5 * 1.001
        quotient = r["energy_content_above_2" + s] / (r["energy_content_below_05" + s] + r["energy_content_05_2" + s])
        assert r["frequency_quotient" + s] == pytest.approx(quotient, rel=1e-12)
        assert r["frequency_quotient" + s] == pytest.approx(0.125 / 2.5, rel=0.03)


def test_scaling_the_trace_scales_the_powers_only() -> None:
    rng = np.random.default_rng(7)
    ml, ap = _centred(np.cumsum(rng.normal(size=1500))), _centred(np.cumsum(rng.normal(size=1500)))
    r1, r3 = _desc_frequency.compute(ml, ap, FS), _desc_frequency.compute(3 * ml, 3 * ap, FS)
    for k, v in r1.items():
        power = k.startswith(("total_power", "energy_content"))
        assert r3[k] == pytest.approx(9 * v if power else v, rel=1e-9), k


def test_mean_frequency_of_a_circle_and_a_sine() -> None:
    # Mean velocity / mean distance (Prieto et al. 1996). A circle of radius A at f0 turns
    # 2π·f0·A cm/s at radius A: v/(2π·r) = f0; sampled, each step is a chord 2A·sin(π·f0/fs).
    a_cm, f0 = 1.5, 0.5
    t = _t(60.0)
    ml, ap = a_cm * np.cos(2 * np.pi * f0 * t), a_cm * np.sin(2 * np.pi * f0 * t)
    r = _desc_frequency.compute(ml, ap, FS)
    chord = 2 * a_cm * math.sin(math.pi * f0 / FS) * FS
    assert r["mean_frequency_ML_AND_AP"] == pytest.approx(chord / (2 * math.pi * a_cm), rel=1e-9)
    # One axis: mean |v| = 4·f0·A, mean |x| = 2A/π, so v/(4√2·d) = π·f0/(2√2). Sampling misses
    # the extremes by at most half a step: 1 − cos(π·f0/fs) = 0.2 % of the path.
    for axis in ("ML", "AP"):
        assert r[f"mean_frequency_{axis}"] == pytest.approx(math.pi * f0 / (2 * math.sqrt(2)), rel=0.005)


# ---------------------------------------------------------------- frequency: white noise

def test_white_noise_has_a_flat_spectrum() -> None:
    # One-sided PSD 2σ²/fs on [0, fs/2]; over the band [0.15, 5] Hz every descriptor is a closed
    # form. A band B wide holds B·T independent bins of a T-long record: its power has a relative
    # standard deviation ≈ 1/√(B·T); the tolerances are 5 of those (Hann + overlap cost ~10 %).
    sigma_cm, duration_s = 0.5, 1200.0
    rng = np.random.default_rng(2029)
    n = int(duration_s * FS)
    ml, ap = rng.normal(0, sigma_cm, n), rng.normal(0, sigma_cm, n)
    r = _desc_frequency.compute(_centred(ml), _centred(ap), FS)
    level = 2 * sigma_cm ** 2 / FS  # cm²/Hz

    def tol(band_hz: float) -> float:
        return 5 / math.sqrt(band_hz * duration_s)

    m0, m1, m2 = HI - LO, (HI ** 2 - LO ** 2) / 2, (HI ** 3 - LO ** 3) / 3
    for axis in ("ML", "AP"):
        s = PSD + axis
        assert r["total_power" + s] == pytest.approx(level * (HI - LO), rel=tol(HI - LO))
        assert r["energy_content_below_05" + s] == pytest.approx(level * (0.5 - LO), rel=tol(0.5 - LO))
        assert r["energy_content_05_2" + s] == pytest.approx(level * 1.5, rel=tol(1.5))
        assert r["energy_content_above_2" + s] == pytest.approx(level * 3.0, rel=tol(3.0))
        assert r["frequency_quotient" + s] == pytest.approx(3.0 / (2.0 - LO), rel=tol(1.85) + tol(3.0))
        # A 2 % error in the cumulated power moves the quantiles by 2 % of the band, ≈ 0.1 Hz.
        assert r["power_frequency_50" + s] == pytest.approx((LO + HI) / 2, abs=0.1)
        assert r["power_frequency_95" + s] == pytest.approx(LO + 0.95 * (HI - LO), abs=0.1)
        assert r["centroid_frequency" + s] == pytest.approx(math.sqrt(m2 / m0), rel=0.02)
        assert r["frequency_dispersion" + s] == pytest.approx(math.sqrt(1 - m1 ** 2 / (m0 * m2)), rel=0.03)
    # Gaussian steps: E|Δx| = 2σ/√π, E|x| = σ·√(2/π), so v/(4√2·d) = fs/4 on each axis; on the
    # plane the speed and the radius are Rayleigh: σ√π·fs and σ√(π/2), v/(2π·r) = √2·fs/(2π).
    # Means of N = 30 000 samples: relative errors ~1/√N = 0.6 %; the tolerance is 2 %.
    assert r["mean_frequency_ML"] == pytest.approx(FS / 4, rel=0.02)
    assert r["mean_frequency_AP"] == pytest.approx(FS / 4, rel=0.02)
    assert r["mean_frequency_ML_AND_AP"] == pytest.approx(math.sqrt(2) * FS / (2 * math.pi), rel=0.02)


# ---------------------------------------------------------------- diffusion

def test_the_diffusion_plot_is_the_mean_square_displacement() -> None:
    x = _centred(np.cumsum(np.random.default_rng(3).normal(size=900)))
    t_s, msd = _desc_diffusion.diffusion_plot(x, FS)
    assert t_s.size == 300 and t_s[0] == pytest.approx(1 / FS)
    for k in (1, 7, 150, 300):  # by hand, lag by lag
        assert msd[k - 1] == pytest.approx(np.mean((x[k:] - x[:-k]) ** 2), rel=1e-10)


def _walks(count: int, duration_s: float, step_cm: float) -> list[dict[str, float]]:
    rng = np.random.default_rng(1993)
    n = int(duration_s * FS)
    return [_desc_diffusion.compute(*_centred(np.cumsum(rng.normal(0, step_cm, (n, 2)), axis=0)).T, FS)
            for _ in range(count)]


def test_a_random_walk_diffuses_with_exponent_one_half() -> None:
    # Steps of variance σ² every Δt: MSD(τ) = σ²·τ/Δt = 2D·τ with D = σ²/(2Δt) (Collins & De Luca).
    # The paper's diffusion coefficient is exp(intercept) of log MSD against log τ, the MSD at
    # τ = 1 s: 2D = σ²·fs, not D. Scaling = slope/2 = H = 0.5 in both regions.
    step_cm, duration_s, count = 0.05, 120.0, 40
    runs = _walks(count, duration_s, step_cm)
    two_d = step_cm ** 2 * FS
    for axis in ("ML", "AP"):
        s = "_Diffusion_" + axis
        short_h = np.array([r["short_time_scaling" + s] for r in runs])
        short_k = np.array([r["short_time_diffusion" + s] for r in runs])
        long_h = np.array([r["long_time_scaling" + s] for r in runs])
        # Short region (lags ≤ 2.5 s): the time-averaged MSD at lag τ has a relative variance
        # 2τ/(3T) (Qian et al. 1991), ≤ 1.4 % at 2.5 s of 120 s: per walk H within ±0.06, and the
        # mean of 40 walks within ±0.02 of 0.5, 2D within 5 %.
        assert np.all(np.abs(short_h - 0.5) < 0.06)
        assert short_h.mean() == pytest.approx(0.5, abs=0.02)
        assert short_k.mean() == pytest.approx(two_d, rel=0.05)
        # Long region (to T/3): that relative variance reaches ~0.3, so one walk's long H
        # scatters by ~0.13, and log MSD falls below log E[MSD] by half of it, a tilt of at most
        # −2/9 in slope: E[H_long] ∈ [0.5 − 1/9, 0.5]. Mean of 40 walks: standard error ~0.02.
        assert 0.5 - 1 / 9 - 0.06 < long_h.mean() < 0.5 + 0.06
        # Two parallel lines cross anywhere: the critical time is only bounded by its cap, T/3.
        tc = np.array([r["critical_time" + s] for r in runs])
        assert np.all(np.isfinite(tc) & (tc >= 0) & (tc <= duration_s / 3 + 1e-9))


def _ou(count: int, duration_s: float, tau_s: float, sigma_cm: float) -> list[dict[str, float]]:
    # Exact discretisation: x[k+1] = φ·x[k] + e, φ = exp(−Δt/τ), var e = σ²(1 − φ²).
    rng = np.random.default_rng(2021)
    n, phi = int(duration_s * FS), math.exp(-1 / (FS * tau_s))
    out = []
    for _ in range(count):
        e = rng.normal(0, sigma_cm * math.sqrt(1 - phi ** 2), (n, 2))
        x = np.empty((n, 2))
        x[0] = rng.normal(0, sigma_cm, 2)
        for k in range(1, n):
            x[k] = phi * x[k - 1] + e[k]
        out.append(_desc_diffusion.compute(*_centred(x).T, FS))
    return out


def test_an_ornstein_uhlenbeck_process_diffuses_then_saturates() -> None:
    # E[MSD(τ)] = 2σ²(1 − e^(−τ/T0)): ≈ 2σ²·τ/T0 for τ ≪ T0 (H = 0.5), → 2σ² for τ ≫ T0 (H = 0).
    # The two asymptotes cross at τ = T0, at the displacement 2σ². Local exponent:
    # H(τ) = ½·(τ/T0)·e^(−τ/T0)/(1 − e^(−τ/T0)).
    tau_s, sigma_cm, duration_s, count = 1.0, 0.5, 120.0, 12
    runs = _ou(count, duration_s, tau_s, sigma_cm)

    def h_local(t_s: float) -> float:
        u = t_s / tau_s
        return 0.5 * u * math.exp(-u) / (1 - math.exp(-u))

    plateau = 2 * sigma_cm ** 2
    for axis in ("ML", "AP"):
        s = "_Diffusion_" + axis
        mean = {k: float(np.mean([r[k + s] for r in runs])) for k in (
            "short_time_scaling", "long_time_scaling", "short_time_diffusion", "long_time_diffusion",
            "critical_time", "critical_displacement")}
        # The short line averages the local exponent over lags from 1/fs to ≥ 0.32 s; the least
        # residual picks the straightest (shortest) window: between H(0.32 s) = 0.42 and 0.5.
        assert h_local(0.32) - 0.02 < mean["short_time_scaling"] < 0.5
        # Beyond 2.5 s the local exponent is below H(2.5 s) = 0.11 and falls to 0.
        assert -0.03 < mean["long_time_scaling"] < h_local(2.5)
        # The log–log MSD is concave: the short line, extrapolated to 1 s, lies above the MSD
        # there, 2σ²(1 − e^(−1/T0)), and below the initial asymptote 2σ²·(1 s)/T0.
        assert plateau * (1 - math.exp(-1 / tau_s)) < mean["short_time_diffusion"] < plateau / tau_s
        # The long line is the plateau (exponent ≈ 0); E[MSD] approaches it from below.
        assert 0.8 * plateau < mean["long_time_diffusion"] < 1.05 * plateau
        # Finite windows bend both lines (short below its asymptote: later crossing; long below
        # the plateau: earlier crossing); the crossing stays within a factor 2 of T0, and the
        # displacement there within 20 % of 2σ².
        assert tau_s / 2 < mean["critical_time"] < 2 * tau_s
        assert mean["critical_displacement"] == pytest.approx(plateau, rel=0.2)


# ---------------------------------------------------------------- bad input

def test_bad_input_fails_in_one_line() -> None:
    t = _t(60.0)
    x = np.sin(2 * np.pi * t)
    for module in (_desc_frequency, _desc_diffusion):
        with pytest.raises(ValueError, match="same length"):
            module.compute(x, x[:-1], FS)
        with pytest.raises(ValueError, match="fs_hz"):
            module.compute(x, x, 0.0)
        with pytest.raises(ValueError, match="finite"):
            module.compute(np.where(t > 1, x, np.nan), x, FS)
        with pytest.raises(ValueError, match="does not move"):
            module.compute(np.zeros_like(x), x, FS)
    with pytest.raises(ValueError, match="stabilogram diffusion needs"):
        _desc_diffusion.compute(x[:150], x[:150], FS)

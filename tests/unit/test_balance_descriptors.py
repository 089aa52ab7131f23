"""psmat.balance.descriptors (preset quijoux2021, docs/spec.md §7): the entry point, the
preprocessing, the positional and dynamic families, each against a hand computation or a
closed form."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from psmat.balance import _desc_dynamic, _desc_positional, _preprocess, descriptors, prediction_ellipse_area

# docs/spec.md §7: the 72 names of the preset, written out.
_AXES = ("ML", "AP")
NAMES_OF_SECTION_7 = {
    "mean_value_ML", "mean_value_AP",
    "mean_distance_ML", "mean_distance_AP", "mean_distance_Radius",
    "maximal_distance_ML", "maximal_distance_AP", "maximal_distance_Radius",
    "rms_ML", "rms_AP", "rms_Radius",
    "range_ML", "range_AP", "range_ML_AND_AP",
    "range_ratio_ML_AND_AP", "planar_deviation_ML_AND_AP", "coefficient_sway_direction_ML_AND_AP",
    "confidence_ellipse_area_ML_AND_AP", "principal_sway_direction_ML_AND_AP",
    "mean_velocity_ML", "mean_velocity_AP", "mean_velocity_ML_AND_AP", "sway_area_per_second_ML_AND_AP",
    "phase_plane_parameter_ML", "phase_plane_parameter_AP", "LFS_ML_AND_AP", "fractal_dimension_ML_AND_AP",
    "zero_crossing_SPD_ML", "zero_crossing_SPD_AP",
    "peak_velocity_pos_SPD_ML", "peak_velocity_neg_SPD_ML", "peak_velocity_all_SPD_ML",
    "peak_velocity_pos_SPD_AP", "peak_velocity_neg_SPD_AP", "peak_velocity_all_SPD_AP",
    "mean_peak_Sway_Density", "mean_distance_peak_Sway_Density",
    "mean_frequency_ML", "mean_frequency_AP", "mean_frequency_ML_AND_AP",
    *(f"{name}_Power_Spectrum_Density_{axis}" for axis in _AXES for name in (
        "total_power", "power_frequency_50", "power_frequency_95", "frequency_mode", "centroid_frequency",
        "frequency_dispersion", "energy_content_below_05", "energy_content_05_2", "energy_content_above_2",
        "frequency_quotient")),
    *(f"{name}_Diffusion_{axis}" for axis in _AXES for name in (
        "short_time_diffusion", "long_time_diffusion", "critical_time", "critical_displacement",
        "short_time_scaling", "long_time_scaling")),
}

FS = 25.0
DT = 1 / FS
F = 0.625          # Hz
M = int(FS / F)    # 40 samples per period, a multiple of 4: the samples hit the peaks and the zeros
K = 10             # whole periods
N = K * M
T = np.arange(N) / FS
W = 2 * np.pi * F
# For the velocity: 50 samples per period, so that the zeros of A·ω·cos(ωt) fall between samples
# (a sample at a zero would leave its sign to rounding) while its peaks fall on samples.
F_V = 0.5
M_V = int(FS / F_V)
N_V = K * M_V
T_V = np.arange(N_V) / FS
W_V = 2 * np.pi * F_V


def _random_walk(seed: int = 3, n: int = 6000) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    t = np.cumsum(rng.uniform(0.005, 0.015, n))      # about 100 Hz, irregular
    return t, np.cumsum(rng.normal(0, 0.02, n)), np.cumsum(rng.normal(0, 0.02, n))


# --- the entry point -------------------------------------------------------------------------

def test_the_72_names_of_the_spec() -> None:
    assert len(NAMES_OF_SECTION_7) == 72
    out = descriptors(*_random_walk())
    assert set(out) == NAMES_OF_SECTION_7
    assert all(isinstance(v, float) for v in out.values())
    assert np.all(np.isfinite(list(out.values())))


def test_mean_value_is_the_raw_mean_and_the_rest_ignores_it() -> None:
    # a random walk moved to means 3 and −2 cm: mean_value reports them; the other
    # descriptors see the centred trace and do not move with the offset
    t, ml, ap = _random_walk(n=2000)
    ml, ap = ml - ml.mean(), ap - ap.mean()
    shifted = descriptors(t, ml + 3.0, ap - 2.0)
    centred = descriptors(t, ml, ap)
    assert shifted["mean_value_ML"] == pytest.approx(3.0, rel=1e-12)
    assert shifted["mean_value_AP"] == pytest.approx(-2.0, rel=1e-12)
    for name in ("rms_ML", "range_ML_AND_AP", "mean_velocity_ML_AND_AP", "mean_peak_Sway_Density"):
        assert shifted[name] == pytest.approx(centred[name], rel=1e-9)


def test_without_preset_the_families_see_the_trace_as_given() -> None:
    rng = np.random.default_rng(5)
    ml, ap = rng.normal(0, 1, 400), rng.normal(0, 1, 400)
    t = 7.0 + np.arange(400) / 40.0     # 40 Hz
    out = descriptors(t, ml, ap, preset=None)
    expect = _desc_positional.compute(ml - ml.mean(), ap - ap.mean(), 40.0)
    expect.update(_desc_dynamic.compute(ml - ml.mean(), ap - ap.mean(), 40.0))
    for name, value in expect.items():
        if name.startswith("mean_value"):
            continue
        assert out[name] == pytest.approx(value, rel=1e-12, nan_ok=True), name


def test_the_preset_keeps_a_slow_sine() -> None:
    # 0.5 Hz, 2 cm, sampled near 100 Hz with jitter: after SWARII (0.04 s boxcar: gain
    # sinc(0.5 Hz · 0.04 s) = 0.99974) and the 10 Hz low-pass it is still A/√2 in rms and its
    # mean velocity still 4·A·f (path 4A per period)
    rng = np.random.default_rng(8)
    t = np.cumsum(rng.uniform(0.008, 0.012, 4000))
    out = descriptors(t, 2 * np.sin(W * t), np.zeros_like(t) + rng.normal(0, 1e-3, t.size))
    assert out["rms_ML"] == pytest.approx(2 / np.sqrt(2), rel=5e-3)
    assert out["mean_velocity_ML"] == pytest.approx(4 * 2 * F, rel=1e-2)


@pytest.mark.parametrize("args, message", [
    ((np.arange(10.0), np.zeros(9), np.zeros(10)), "same length"),
    ((np.arange(100.0), np.r_[np.zeros(99), np.nan], np.zeros(100)), "non-finite"),
    ((np.r_[0.0, 0.1, 0.1, *np.arange(3, 100) / 10], np.zeros(100), np.zeros(100)), "increase strictly"),
    ((np.arange(10) / 25, np.arange(10.0), np.arange(10.0)), "needs at least 16"),
    ((np.arange(5.0), np.zeros((5, 2)), np.zeros(5)), "one-dimensional"),
])
def test_bad_input_in_one_line(args: tuple, message: str) -> None:
    with pytest.raises(ValueError, match=message) as err:
        descriptors(*args)
    assert "\n" not in str(err.value)


def test_preset_none_needs_uniform_times_and_a_known_preset() -> None:
    t, ml, ap = _random_walk(n=200)
    with pytest.raises(ValueError, match="uniform") as err:
        descriptors(t, ml, ap, preset=None)
    assert "\n" not in str(err.value)
    with pytest.raises(ValueError, match="preset must be"):
        descriptors(t, ml, ap, preset="prieto1996")


# --- preprocessing ---------------------------------------------------------------------------

def test_swarii_by_hand() -> None:
    # Output at t0 + k/25 s; window (τ − 0.02, τ + 0.02) clipped to [0, 0.19], cut at the
    # midpoints between the samples inside it:
    #  τ = 0.00: [0, 0.02], samples 0 (1) and 0.01 (2), cut 0.005: (1·0.005 + 2·0.015)/0.02 = 1.75
    #  τ = 0.04: (0.02, 0.06), samples 0.03 (3) and 0.045 (5), cut 0.0375:
    #            (3·0.0175 + 5·0.0225)/0.04 = 4.125
    #  τ = 0.08: (0.06, 0.10), samples 0.065 (2), 0.075 (4), 0.095 (6), cuts 0.07 and 0.085:
    #            (2·0.01 + 4·0.015 + 6·0.015)/0.04 = 4.25
    #  τ = 0.12: (0.10, 0.14) holds no sample: linear between 4.25 (0.08) and 6 (0.16) = 5.125
    #  τ = 0.16: (0.14, 0.18), the lone sample 0.165 (6) = 6; τ = 0.20 lies past the last sample
    t = np.array([0.000, 0.010, 0.030, 0.045, 0.065, 0.075, 0.095, 0.165, 0.190])
    x = np.array([1.0, 2.0, 3.0, 5.0, 2.0, 4.0, 6.0, 6.0, 8.0])
    grid, y = _preprocess.swarii(t, x)
    np.testing.assert_allclose(grid, [0.0, 0.04, 0.08, 0.12, 0.16], atol=1e-12)
    np.testing.assert_allclose(y, [1.75, 4.125, 4.25, 5.125, 6.0], rtol=1e-12)
    # columns are resampled alike
    _, y2 = _preprocess.swarii(t + 10.0, np.column_stack((x, -2 * x)))
    np.testing.assert_allclose(y2, np.column_stack((y, -2 * y)), rtol=1e-9)


def test_the_low_pass_keeps_1_hz_and_removes_12_hz() -> None:
    # digital Butterworth, 4th order, 10 Hz at 25 Hz, run twice: gain 1/(1 + (tan(πf/fs)/tan(π·10/fs))^8)
    # = 1 − 8e-12 at 1 Hz and 2e-6 at 12 Hz
    t = np.arange(1000) / FS
    slow, fast = np.sin(2 * np.pi * 1.0 * t), np.sin(2 * np.pi * 12.0 * t)
    inner = slice(100, -100)   # away from the ends, where filtfilt pads the signal
    np.testing.assert_allclose(_preprocess.lowpass(slow, FS)[inner], slow[inner], atol=1e-5)
    assert np.max(np.abs(_preprocess.lowpass(fast, FS)[inner])) < 1e-4
    mixed = _preprocess.lowpass(slow + fast, FS)
    np.testing.assert_allclose(mixed[inner], slow[inner], atol=1e-4)


# --- positional ------------------------------------------------------------------------------

def test_positional_on_a_sine_and_a_cosine() -> None:
    # ML = A sin(ωt), AP = B cos(ωt), K whole periods of M samples (M a multiple of 4)
    a, b = 2.0, 0.5
    ml, ap = a * np.sin(W * T), b * np.cos(W * T)
    out = _desc_positional.compute(ml, ap, FS)
    # rms of a sinusoid over whole periods: A/√2
    assert out["rms_ML"] == pytest.approx(a / np.sqrt(2), rel=1e-12)
    assert out["rms_AP"] == pytest.approx(b / np.sqrt(2), rel=1e-12)
    # rms of the radius: √(mean(A² sin² + B² cos²)) = √((A² + B²)/2); planar deviation the same
    assert out["rms_Radius"] == pytest.approx(np.sqrt((a * a + b * b) / 2), rel=1e-12)
    assert out["planar_deviation_ML_AND_AP"] == pytest.approx(np.sqrt((a * a + b * b) / 2), rel=1e-12)
    # mean |sin| over M samples of a period: Σ_k |sin(2πk/M)| = 2·cot(π/M)
    assert out["mean_distance_ML"] == pytest.approx(a * 2 / np.tan(np.pi / M) / M, rel=1e-12)
    assert out["mean_distance_AP"] == pytest.approx(b * 2 / np.tan(np.pi / M) / M, rel=1e-12)
    # the samples hit the peaks: max |x| = A, range 2A, range ratio A/B, diameter 2·max(A, B)
    assert out["maximal_distance_ML"] == pytest.approx(a, rel=1e-12)
    assert out["maximal_distance_Radius"] == pytest.approx(a, rel=1e-12)
    assert out["range_ML"] == pytest.approx(2 * a, rel=1e-12)
    assert out["range_AP"] == pytest.approx(2 * b, rel=1e-12)
    assert out["range_ratio_ML_AND_AP"] == pytest.approx(a / b, rel=1e-12)
    assert out["range_ML_AND_AP"] == pytest.approx(2 * a, rel=1e-12)
    # Σ sin·cos over whole periods is 0: no covariance
    assert out["coefficient_sway_direction_ML_AND_AP"] == pytest.approx(0.0, abs=1e-12)
    # the long axis is M-L: 90° from A-P
    assert out["principal_sway_direction_ML_AND_AP"] == pytest.approx(90.0, abs=1e-9)
    # 95 % confidence ellipse: 2π·F.95(2, N−2)·(N+1)(N−1)/(N(N−2))·√(A²/2·B²/2)
    coeff = (N + 1) * (N - 1) / (N * (N - 2))
    area = 2 * np.pi * stats.f.ppf(0.95, 2, N - 2) * coeff * a * b / 2
    assert out["confidence_ellipse_area_ML_AND_AP"] == pytest.approx(area, rel=1e-12)
    # the same ellipse as psmat's BDS prediction ellipse (ddof 1), but with population moments
    assert out["confidence_ellipse_area_ML_AND_AP"] == pytest.approx(
        prediction_ellipse_area(np.column_stack((ml, ap))) * (N - 1) / N, rel=1e-9)


def test_positional_on_a_circle() -> None:
    # a circle of radius r: the radius is r at every sample
    r = 1.5
    ml, ap = r * np.cos(W * T), r * np.sin(W * T)
    out = _desc_positional.compute(ml, ap, FS)
    for name in ("mean_distance_Radius", "maximal_distance_Radius", "rms_Radius", "planar_deviation_ML_AND_AP"):
        assert out[name] == pytest.approx(r, rel=1e-12), name
    assert out["range_ML_AND_AP"] == pytest.approx(2 * r, rel=1e-12)   # M even: antipodal samples


@pytest.mark.parametrize("angle_deg", [0.0, 30.0, 75.0])
def test_positional_on_a_line(angle_deg: float) -> None:
    # back and forth along a line at θ from the A-P axis: the principal direction is θ, the
    # coefficient of sway direction ±1 (1 for θ in (0°, 90°)), the ellipse flat (area 0)
    th = np.radians(angle_deg)
    s = np.sin(W * T)
    out = _desc_positional.compute(s * np.sin(th), s * np.cos(th), FS)
    assert out["principal_sway_direction_ML_AND_AP"] == pytest.approx(angle_deg, abs=1e-6)
    assert out["confidence_ellipse_area_ML_AND_AP"] == pytest.approx(0.0, abs=1e-6)
    if angle_deg > 0:
        assert out["coefficient_sway_direction_ML_AND_AP"] == pytest.approx(1.0, rel=1e-9)
        assert out["range_ML_AND_AP"] == pytest.approx(2.0, rel=1e-12)


# --- dynamic ---------------------------------------------------------------------------------

def _sg_gain(w: float) -> float:
    # the velocity is the derivative of a cubic fitted over 5 samples, (x₋₂ − 8x₋₁ + 8x₁ − x₂)/(12Δt);
    # on A·sin(ωt) it gives A·cos(ωt)·(8 sin ωΔt − sin 2ωΔt)/(6Δt), i.e. ω·(1 − (ωΔt)⁴/30 …)
    return (8 * np.sin(w * DT) - np.sin(2 * w * DT)) / (6 * DT)


def test_dynamic_on_a_sine() -> None:
    a = 2.0
    ml, ap = a * np.sin(W * T), 0.5 * np.sin(W * T + 0.3)
    out = _desc_dynamic.compute(ml, ap, FS)
    # path: 4A per period, less the missing last step from sin(−2π/M) back to 0; the
    # reference's duration is N/fs, so mean velocity → 4·A·f for a long trial
    path = 4 * a * K - a * np.sin(2 * np.pi / M)
    assert out["mean_velocity_ML"] == pytest.approx(path * FS / N, rel=1e-12)
    assert out["mean_velocity_ML"] == pytest.approx(4 * a * F, rel=1e-2)
    # phase plane: √(rms² + var(v)) = √(A²/2 + (Aω)²/2) (var of the velocity up to the edge fits)
    assert out["phase_plane_parameter_ML"] == pytest.approx(np.sqrt(a * a / 2 + (a * W) ** 2 / 2), rel=1e-3)
    # the velocity A·ω·cos(ωt) changes sign twice a period: 2K crossings in [0, K/f); its lobes
    # between two crossings (K negative, K − 1 positive, the first and last cut by the trial)
    # peak at A times the Savitzky–Golay gain
    out = _desc_dynamic.compute(a * np.sin(W_V * T_V), 0.5 * np.sin(W_V * T_V + 0.3), FS)
    assert out["zero_crossing_SPD_ML"] == 2 * K
    peak = a * _sg_gain(W_V)
    for name in ("pos", "neg", "all"):
        assert out[f"peak_velocity_{name}_SPD_ML"] == pytest.approx(peak, rel=1e-9), name


def test_dynamic_on_a_circle() -> None:
    # a circle of radius r at ω: each step is a chord 2r·sin(ωΔt/2) and sweeps a triangle of
    # area r²·sin(ωΔt)/2 about the centre: sway area per second = r²·sin(ωΔt)/(2Δt) → r²ω/2
    r = 1.5
    ml, ap = r * np.cos(W * T), r * np.sin(W * T)
    out = _desc_dynamic.compute(ml, ap, FS)
    path = (N - 1) * 2 * r * np.sin(W * DT / 2)
    assert out["mean_velocity_ML_AND_AP"] == pytest.approx(path * FS / N, rel=1e-12)
    assert out["sway_area_per_second_ML_AND_AP"] == pytest.approx(r * r * np.sin(W * DT) / (2 * DT), rel=1e-12)
    assert out["sway_area_per_second_ML_AND_AP"] == pytest.approx(r * r * W / 2, rel=5e-3)  # sin x/x, x = ωΔt
    # path over the 95 % ellipse, here a disc: area 2π·F.95·coeff·r²/2; fractal dimension
    # log N / log(N·d/path) with d the diameter of a disc of that area, √(4·area/π)
    coeff = (N + 1) * (N - 1) / (N * (N - 2))
    area = np.pi * stats.f.ppf(0.95, 2, N - 2) * coeff * r * r
    assert out["LFS_ML_AND_AP"] == pytest.approx(path / area, rel=1e-12)
    d = np.sqrt(4 * area / np.pi)
    assert out["fractal_dimension_ML_AND_AP"] == pytest.approx(np.log(N) / np.log(N * d / path), rel=1e-12)
    # both velocity components are sinusoids of amplitude r·gain: phase plane √(r²/2 + (r·ω)²/2)
    assert out["phase_plane_parameter_AP"] == pytest.approx(np.sqrt(r * r / 2 + (r * W) ** 2 / 2), rel=1e-3)


def test_sway_density_by_hand() -> None:
    # ML = 0 0 0 1 1 2 2 2 2 cm, AP = 0, at 2 Hz, circle 0.3 cm. Samples after sample i that
    # stay within the circle before the first that leaves it: 2 1 0 1 0 3 2 1 (the last sample
    # has none after it) → /2 Hz = 1, .5, 0, .5, 0, 1.5, 1, .5 s. Strict local maxima: sample 3
    # (0.5 s, at ML = 1) and sample 5 (1.5 s, at ML = 2): mean 1 s, 1 cm apart
    ml = np.array([0, 0, 0, 1, 1, 2, 2, 2, 2], dtype=float)
    ap = np.zeros_like(ml)
    np.testing.assert_allclose(_desc_dynamic.sway_density_s(np.column_stack((ml, ap)), 2.0),
                               [1, 0.5, 0, 0.5, 0, 1.5, 1, 0.5])
    out = _desc_dynamic.compute(ml, ap, 2.0)
    assert out["mean_peak_Sway_Density"] == pytest.approx(1.0)
    assert out["mean_distance_peak_Sway_Density"] == pytest.approx(1.0)


def test_a_still_trace_leaves_velocity_peaks_undefined() -> None:
    # no velocity, no crossing, no lobe: the count is 0 and the peaks NaN (no warning)
    out = _desc_dynamic.compute(np.zeros(50), np.zeros(50), FS)
    assert out["zero_crossing_SPD_ML"] == 0
    assert np.isnan(out["peak_velocity_all_SPD_ML"])

"""psmat.balance.sway against the BDS authors' published measures and hand calculations (docs/spec.md §7)."""

from __future__ import annotations

import numpy as np
import pytest

from psmat.balance import sway
from psmat.io import bds_trial, bds_trials_table

TRIALS = bds_trials_table()


def test_the_data_set_ships_24_trials() -> None:
    assert len(TRIALS) == 24


@pytest.mark.parametrize("row", TRIALS, ids=lambda r: r["Trial"])
def test_published_area_velocity_and_mean_frequency(row: dict) -> None:
    # Santos & Duarte (2016): COParea (95 % prediction ellipse, cm²), COPvelo (cm/s), COPmfreq (Hz)
    rec = bds_trial(row["Trial"])
    s = sway(rec.cop_cm, rec.rate_hz)
    assert s.area95_cm2 == pytest.approx(row["COParea"], rel=5e-3)
    assert s.velocity_cm_s == pytest.approx(row["COPvelo"], rel=5e-3)
    assert s.mean_freq_hz == pytest.approx(row["COPmfreq"], rel=2e-2)


def test_a_circle_by_hand() -> None:
    # 10 laps of a circle of radius 2 cm at 0.5 Hz, 100 Hz: path = 10 · 2π·2 cm over 20 s
    fs, n = 100.0, 2000
    t = np.arange(n) / fs
    cop = np.c_[2 * np.cos(2 * np.pi * 0.5 * t), 2 * np.sin(2 * np.pi * 0.5 * t)] + [5.0, -3.0]
    s = sway(cop, fs)
    chord = 2 * 2 * np.sin(np.pi * 0.5 / fs)  # one step along the circle
    assert s.path_cm == pytest.approx((n - 1) * chord, rel=1e-12)
    assert s.velocity_cm_s == pytest.approx((n - 1) * chord / (n / fs), rel=1e-12)
    assert s.range_ml_cm == pytest.approx(4.0, abs=1e-3)
    assert s.range_ap_cm == pytest.approx(4.0, abs=1e-3)
    # a full-lap sinusoid of amplitude A has variance A²/2 (population), times n/(n-1) for ddof 1
    assert s.sd_ml_cm == pytest.approx(np.sqrt(2.0 * n / (n - 1)), rel=1e-9)
    assert s.mean_freq_hz == pytest.approx(0.5, rel=0.02)


def test_mean_frequency_of_two_axes_is_power_weighted() -> None:
    fs, n = 100.0, 6000
    t = np.arange(n) / fs
    # M-L at 0.2 Hz with amplitude 1, A-P at 1.0 Hz with amplitude 2: powers 1 : 4
    cop = np.c_[np.sin(2 * np.pi * 0.2 * t), 2 * np.sin(2 * np.pi * 1.0 * t)]
    expected = (1 * 0.2 + 4 * 1.0) / 5
    assert sway(cop, fs).mean_freq_hz == pytest.approx(expected, rel=0.02)


def test_area_of_a_large_gaussian_sample_tends_to_the_chi_square_ellipse() -> None:
    # for n -> inf the 95 % prediction ellipse is the χ²(2) one: π · χ²_.95(2) · sqrt(det Σ)
    rng = np.random.default_rng(0)
    cov = np.array([[4.0, 1.0], [1.0, 1.0]])
    cop = rng.multivariate_normal([0, 0], cov, size=200_000)
    chi2_95 = -2 * np.log(0.05)  # χ² with 2 degrees of freedom: 1 - exp(-x/2)
    assert sway(cop, 100.0).area95_cm2 == pytest.approx(np.pi * chi2_95 * np.sqrt(np.linalg.det(cov)), rel=0.01)


@pytest.mark.parametrize("bad, fs, match", [
    (np.zeros((10, 3)), 100.0, "shape"),
    (np.zeros((3, 2)), 100.0, "at least 4"),
    (np.random.default_rng(0).normal(size=(50, 2)), 0.0, "fs_hz"),
    (np.array([[0.0, np.nan]] * 10), 100.0, "non-finite"),
])
def test_bad_input_is_one_clear_error(bad, fs, match) -> None:
    with pytest.raises(ValueError, match=match):
        sway(bad, fs)

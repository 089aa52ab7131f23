"""Noise model of thesis Table 2.4 / Fig. 2.12 (docs/spec.md §2 "Noise model")."""

from __future__ import annotations

import numpy as np
import pytest

from psmat import noise
from psmat.circuit import Circuit

# Table 2.4, typed in from the thesis (not read from the module under test)
R = np.array([100.0, 1e3, 10e3, 100e3, 220e3])
SIGMA_V_MV = np.array([1.0, 0.9, 1.1, 1.1, 1.1])
SIGMA_G = np.array([7.7e-5, 1.3e-6, 2.4e-7, 1.6e-7, 1.6e-7])
REL = SIGMA_G * R  # Fig. 2.12: sigma_g / g = sigma_g * R


def test_table_constants():
    np.testing.assert_array_equal(noise.TABLE_2_4_R_OHM, R)
    np.testing.assert_array_equal(noise.TABLE_2_4_SIGMA_V_MV, SIGMA_V_MV)
    np.testing.assert_array_equal(noise.TABLE_2_4_SIGMA_G_S, SIGMA_G)
    np.testing.assert_allclose(noise.TABLE_2_4_RELATIVE, REL, rtol=1e-15)
    with pytest.raises(ValueError):
        noise.TABLE_2_4_R_OHM[0] = 1.0  # read-only


def test_interpolation_hits_table_points():
    np.testing.assert_allclose(noise.relative_sigma(1.0 / R), REL, rtol=1e-12)
    np.testing.assert_allclose(noise.table_sigma_G(1.0 / R), SIGMA_G, rtol=1e-12)


def test_interpolation_is_linear_and_monotone_in_log_r():
    for k in range(len(R) - 1):
        t = np.linspace(0.0, 1.0, 101)
        r = np.exp(np.log(R[k]) + t * (np.log(R[k + 1]) - np.log(R[k])))
        rel = noise.relative_sigma(1.0 / r)
        np.testing.assert_allclose(rel, REL[k] + t * (REL[k + 1] - REL[k]), rtol=1e-9)
        d = np.diff(rel)
        assert np.all(d * np.sign(REL[k + 1] - REL[k]) >= -1e-15)
        assert rel.min() >= min(REL[k], REL[k + 1]) * (1 - 1e-12)
        assert rel.max() <= max(REL[k], REL[k + 1]) * (1 + 1e-12)


def test_held_constant_outside_table():
    np.testing.assert_allclose(noise.relative_sigma([1 / 10.0, 1 / 50.0]), REL[0], rtol=1e-15)
    np.testing.assert_allclose(noise.relative_sigma([1 / 1e6, 1e-9, 0.0]), REL[-1], rtol=1e-15)
    assert noise.table_sigma_G(0.0) == 0.0
    assert noise.relative_sigma(np.ones((2, 3)) * 1e-3).shape == (2, 3)


@pytest.mark.parametrize(
    "bad, exc",
    [([-1e-3], ValueError), ([np.nan], ValueError), ([np.inf], ValueError), ([1e-3 + 0j], TypeError), (["a"], TypeError)],
)
def test_bad_G(bad, exc):
    with pytest.raises(exc):
        noise.relative_sigma(np.array(bad))
    with pytest.raises(exc):
        noise.add_noise(np.array(bad), rng=0)


def test_add_noise_table_matches_sigma():
    G = np.array([1e-2, 3e-3, 1e-3, 1e-4, 1e-5, 4.5e-6])
    draws = noise.add_noise(np.broadcast_to(G, (40000, G.size)), rng=123)
    assert draws.shape == (40000, G.size)
    expected = G * np.interp(np.log(1 / G), np.log(R), REL)  # independent interpolation
    np.testing.assert_allclose(draws.std(axis=0), expected, rtol=0.05)
    np.testing.assert_allclose(draws.mean(axis=0), G, atol=0, rtol=0.002)
    np.testing.assert_array_equal(draws, noise.add_noise(np.broadcast_to(G, (40000, G.size)), rng=123))


@pytest.mark.parametrize("circuit", [Circuit(), Circuit.first_prototype()])
def test_add_noise_voltage_matches_circuit_sigma(circuit):
    G = np.array([1e-2, 1e-3, 1e-4, 1e-5])
    draws = noise.add_noise(np.broadcast_to(G, (40000, 4)), rng=5, model="voltage", sigma_v=1e-3, circuit=circuit)
    assert not np.isnan(draws).any()
    np.testing.assert_allclose(draws.std(axis=0), noise.voltage_sigma_G(G, 1e-3, circuit), rtol=0.05)


def test_add_noise_voltage_open_cell_goes_negative_unless_clipped():
    G = np.zeros(20000)
    draws = noise.add_noise(G, rng=1, model="voltage", sigma_v=1e-3)
    assert np.isfinite(draws).all()
    assert (draws < 0).mean() == pytest.approx(0.5, abs=0.03)  # symmetric about the open reading
    assert draws.std() == pytest.approx(noise.voltage_sigma_G(0.0, 1e-3), rel=0.05)
    clipped = noise.add_noise(G, rng=1, model="voltage", sigma_v=1e-3, clip_min=0.0)
    assert clipped.min() == 0.0
    np.testing.assert_array_equal(clipped, np.maximum(draws, 0.0))


def test_add_noise_voltage_short_side_is_nan_not_inf():
    # 1 Ω cell: the noise pushes V below the zero-resistance reading half the time or so
    c = Circuit(r_mux=145.0)
    draws = noise.add_noise(np.full(2000, 1.0), rng=2, model="voltage", sigma_v=5e-3, circuit=c)
    assert not np.isinf(draws).any()
    assert np.isnan(draws).any()


def test_add_noise_voltage_is_the_circuits_continued_inverse():
    # one home for the algebra: the noisy voltage goes through Circuit's own inverse, continued
    # past the open reading; a draw at or below 0 V is beyond a zero-resistance cell (NaN)
    c = Circuit(r_mux=0.0)
    G = np.array([0.0, 1e-6, 1e-3, 10.0])  # 10 S reads 1.5e-4 V: 1 mV of noise often crosses 0 V
    draws = noise.add_noise(np.broadcast_to(G, (5000, 4)), rng=3, model="voltage", sigma_v=1e-3, circuit=c)
    v = c.voltage(G) + np.random.default_rng(3).standard_normal((5000, 4)) * 1e-3  # the same draws
    below = v <= 0
    assert below[:, 3].mean() > 0.3 and not below[:, :3].any()
    assert np.isnan(draws[below]).all()
    np.testing.assert_array_equal(draws, c.conductance_from_voltage(v, extrapolate_open=True))
    # past the open reading, the resistance form undone by hand (R_mux = 0): G = 1/R_x - 1/R_adc < 0
    past = v[:, 0] >= c.v_open
    assert past.mean() > 0.3
    g_hand = (3.3 - v[past, 0]) / (2200.0 * v[past, 0]) - 1.0 / 6.9e6
    np.testing.assert_allclose(draws[past, 0], g_hand, rtol=0, atol=1e-18)  # |G| ~ 1e-7 S
    assert np.all(draws[past, 0] <= 0)


def test_add_noise_bad_arguments():
    with pytest.raises(ValueError, match="model"):
        noise.add_noise([1e-3], rng=0, model="pink")
    with pytest.raises(ValueError):
        noise.add_noise([1e-3], rng=0, model="voltage", sigma_v=-1.0)
    with pytest.raises(TypeError):
        noise.add_noise([1e-3], rng=0, model="voltage", circuit="improved")

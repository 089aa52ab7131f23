"""Uncertainty of IECM (thesis §2.3): eq. 2.11-2.14 against Monte Carlo (Fig. 2.11, 2.13)."""

from __future__ import annotations

import numpy as np
import pytest

import psmat


def test_inverse_jacobian_inverts_the_jacobian(rng):
    g = rng.uniform(1e-5, 1e-2, (4, 6))
    D = psmat.iecm.inverse_jacobian(g)
    np.testing.assert_allclose(D @ psmat.iecm.jacobian(g), np.eye(24), atol=1e-9)


def test_propagation_is_eq_2_11(rng):
    g = rng.uniform(1e-4, 1e-2, (3, 4))
    sG = rng.uniform(1e-7, 1e-6, g.shape)
    D = np.linalg.inv(psmat.iecm.jacobian(g))  # eq. 2.14, dense, independent of the C++ path
    expected = np.sqrt((D**2) @ sG.ravel() ** 2).reshape(g.shape)  # eq. 2.11
    np.testing.assert_allclose(psmat.iecm.propagate_uncertainty(g, sG), expected, rtol=1e-9)


def test_small_noise_monte_carlo_agrees(rng):
    # linear regime: tiny noise, the law of propagation is exact to first order
    g = rng.uniform(1e-3, 1e-2, (3, 3))
    sG = 1e-4 * psmat.iecm.forward(g)
    mc = psmat.iecm.monte_carlo_uncertainty(g, sG, draws=3000, rng=5)
    np.testing.assert_allclose(psmat.iecm.propagate_uncertainty(g, sG), mc, rtol=0.1)


def test_default_noise_model_is_table_2_4():
    g = np.full((3, 3), 1e-3)
    G = psmat.iecm.forward(g)
    np.testing.assert_allclose(
        psmat.iecm.propagate_uncertainty(g), psmat.iecm.propagate_uncertainty(g, psmat.noise.table_sigma_G(G)), rtol=1e-12
    )


@pytest.mark.slow
def test_fig_2_13_behaviour():
    # Thesis Fig. 2.13: random 16x16 in 1e-5..1e-2 S with the Table 2.4 noise model.
    # Propagation agrees with Monte Carlo for high conductances and overestimates for low ones;
    # relative uncertainty typically < 10 % above ~1e-3 S here (thesis: ~1e-4 S on real images).
    rng = np.random.default_rng(1)
    g = np.exp(rng.uniform(np.log(1e-5), np.log(1e-2), (16, 16)))
    prop = psmat.iecm.propagate_uncertainty(g)
    mc = psmat.iecm.monte_carlo_uncertainty(g, draws=400, rng=2)
    ratio = prop / mc
    high, low = g >= 1e-3, g < 3e-5
    # 400 draws: the SD estimate itself scatters by ~1/sqrt(800) = 3.5 %
    assert np.all(np.abs(ratio[high] - 1) < 0.15), ratio[high]
    assert np.median(ratio[low]) > 1.2 and np.mean(ratio[low] > 1) > 0.9
    assert np.median(prop[high] / g[high]) < 0.1
    assert np.median(prop[low] / g[low]) > 1  # low conductances are not reliable


def test_bad_sigma(rng):
    g = rng.uniform(1e-4, 1e-2, (3, 3))
    with pytest.raises(ValueError, match="sigma_G"):
        psmat.iecm.propagate_uncertainty(g, -1.0)
    with pytest.raises(ValueError, match="draws"):
        psmat.iecm.monte_carlo_uncertainty(g, draws=1)

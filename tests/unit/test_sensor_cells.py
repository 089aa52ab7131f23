"""Cell-to-cell variability: shared model vs shared + per-cell gain vs per-cell models."""

from __future__ import annotations

import numpy as np
import pytest

from psmat.sensor import fit_cells, protocols, simulate_run


@pytest.fixture(scope="module")
def run():
    # a short descending protocol on 5 cells whose gains vary by 15 % (log-normal), 0.2 % noise
    proto = protocols.descending_hysteresis(repetitions=2)
    return simulate_run(proto, cells=5, variability=0.15, noise_rel=0.002, rng=7)


def _pressure_rms(models, run):
    p_hat = models.inverse(run.g, run.dt)
    loaded = run.p > 1.0
    return float(np.sqrt(np.mean((p_hat[loaded] - run.p[loaded, None]) ** 2)))


def test_per_cell_gain_reduces_the_pressure_error(run):
    err = {mode: _pressure_rms(fit_cells(run.p, run.g, run.dt, mode=mode), run) for mode in ("shared", "gain", "per_cell")}
    # one shared model cannot absorb 15 % gain differences; a gain per cell (the variability the
    # simulation has) removes most of the error; a full model per cell does at least as well
    assert err["gain"] < 0.5 * err["shared"], err
    assert err["per_cell"] < 0.5 * err["shared"], err


def test_gains_are_recovered(run):
    m = fit_cells(run.p, run.g, run.dt, mode="gain")
    true = run.meta.get("gains")
    assert true is not None, "simulate_run records the cells' gains in meta"
    np.testing.assert_allclose(m.gains, np.asarray(true) / np.mean(true), rtol=0.01)


def test_bad_input(run):
    with pytest.raises(ValueError, match="mode"):
        fit_cells(run.p, run.g, run.dt, mode="magic")
    with pytest.raises(ValueError, match="same T"):
        fit_cells(run.p[:-1], run.g, run.dt)
    m = fit_cells(run.p, run.g, run.dt, mode="shared")
    with pytest.raises(ValueError, match="cells"):
        m.inverse(run.g[:, :2], run.dt)

"""The twin's physics (docs/spec.md §5): pressure → sensor model → crosstalk → measurement chain.

Checked by undoing each step with the independent inverse of that step (Circuit.conductance,
iecm.solve, MPICreep.inverse) and by the CoP, which the chain must not move."""

from __future__ import annotations

import numpy as np
import pytest

import psmat
from psmat.twin import MatPhysics, PsmSource, quiet_standing


@pytest.fixture(scope="module")
def scene():
    return quiet_standing(1.0, 20.0, (16, 16), seed=3)


def test_noise_free_chain_inverts_to_the_applied_pressure(scene):
    phys = MatPhysics(shape=(16, 16), dt=0.05, variability=0.0, noise_v=0.0)
    counts, truth = phys.counts(scene.pressure_psi, return_truth=True)
    G = phys.circuit.conductance(counts)
    # quantisation only: G within ~1 LSB of the true equivalent conductance where loaded
    loaded = truth.pressure_psi > 2.0
    assert np.median(np.abs(G[loaded] / truth.G[loaded] - 1)) < 0.02
    g = psmat.iecm.solve(G)
    p = phys.sensor.inverse(np.maximum(g - phys.g_rest, 0.0), 0.05)
    # pressure recovered on loaded cells, and the CoP within a fraction of a millimetre
    assert np.median(np.abs(p[loaded] - truth.pressure_psi[loaded])) < 0.2  # psi
    err = np.linalg.norm(psmat.balance.cop(p) - psmat.balance.cop(truth.pressure_psi), axis=1)
    assert err.max() < 0.05  # cm


def test_crosstalk_is_in_the_raw_image(scene):
    # without IECM the unloaded cells read conductance (ghosts, thesis §2.1.4)
    phys = MatPhysics(shape=(16, 16), dt=0.05, variability=0.0, noise_v=0.0)
    counts, truth = phys.counts(scene.pressure_psi[:1], return_truth=True)
    G = phys.circuit.conductance(counts)[0]
    empty = truth.pressure_psi[0] == 0
    assert (G[empty] > 10 * phys.g_rest).mean() > 0.2


def test_state_is_carried_between_chunks(scene):
    a = MatPhysics(shape=(16, 16), dt=0.05, noise_v=0.0, seed=1)
    b = MatPhysics(shape=(16, 16), dt=0.05, noise_v=0.0, seed=1)
    whole = a.counts(scene.pressure_psi)
    parts = np.concatenate([b.counts(scene.pressure_psi[:7]), b.counts(scene.pressure_psi[7:])])
    assert np.array_equal(whole, parts)


def test_cell_variability_is_lognormal_with_the_given_spread():
    phys = MatPhysics(shape=(64, 64), variability=0.15, seed=0)
    assert np.std(np.log(phys.gain)) == pytest.approx(0.15, rel=0.05)


def test_source_loops_the_scene(scene):
    src = PsmSource(scene, MatPhysics(shape=(16, 16), dt=0.05, noise_v=0.0, variability=0.0), block=8)
    frames = np.stack([src.next() for _ in range(2 * len(scene.t))])
    assert frames.shape == (40, 16, 16) and src.frames == 40


def test_bad_input(scene):
    phys = MatPhysics(shape=(16, 16))
    with pytest.raises(ValueError, match="pressure must be"):
        phys.counts(np.zeros((3, 8, 8)))
    with pytest.raises(ValueError, match=">= 0 psi"):
        phys.counts(-np.ones((1, 16, 16)))
    with pytest.raises(ValueError, match="dt"):
        MatPhysics(dt=0.0)

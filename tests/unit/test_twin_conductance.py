"""The twin's conductance frames (psmat.twin.swaying_feet, MatPhysics.conductance), its mat
pitch and the random array of thesis Fig. 2.13 (psmat.twin.random_array): the one synthetic
world of the tests, benchmarks and demos.

Expectations from physics: the load the sensor model's inverse reads back is the body weight
(Σ p·A, psi → Pa by hand), the CoP of the cell pressures is the continuous field's, an
unloaded cell conducts the leakage g_rest and nothing else, and at 100 Hz a person's sway
moves the load little from one frame to the next.
"""

from __future__ import annotations

import numpy as np
import pytest

from psmat import twin
from psmat.balance import cop
from psmat.bench.iecm_setup import scene as bench_scene
from psmat.sensor import MPICreep

PSI_IN_PA = 6894.757  # by definition
G_REST = 1e-7  # S, the twin's unloaded cell (10 MOhm)


@pytest.mark.parametrize("shape, pitch", [((16, 16), 2.0), ((32, 32), 1.0), ((64, 64), 0.5), ((16, 32), 1.0)])
def test_mat_pitch_keeps_the_thesis_32_cm_mat(shape, pitch):
    assert twin.mat_pitch_cm(shape) == pitch
    assert twin.MAT_SIZE_CM == 32.0


@pytest.mark.parametrize("n", [16, 32, 64])
def test_the_load_read_back_through_the_sensor_model_is_the_weight(n):
    # equal cell gains: g - g_rest is the sensor model's conductance of the cell pressure
    g, cop_true = twin.swaying_feet(30, (n, n), seed=2, weight_n=650.0, variability=0.0, return_cop_cm=True)
    p_psi = MPICreep.thesis().inverse(g - G_REST, 0.01)
    pitch_m = 0.32 / n
    force = p_psi.sum(axis=(1, 2)) * PSI_IN_PA * pitch_m**2
    np.testing.assert_allclose(force, 650.0, rtol=2e-3)  # the feet lie on the 32 cm mat
    # docs/spec.md §7 at cell centres (p·pitch, i·pitch) gives the continuous field's CoP
    np.testing.assert_allclose(cop(p_psi, 32.0 / n), cop_true, atol=0.02)


def test_consecutive_frames_are_close_and_the_background_is_the_leakage():
    g, cop_true = twin.swaying_feet(500, (16, 16), seed=1, return_cop_cm=True)
    assert g.shape == (500, 16, 16) and g.dtype == np.float64 and cop_true.shape == (500, 2)
    step = np.abs(np.diff(g, axis=0)) / g[:-1]
    assert step.max() < 0.05  # consecutive frames are close
    assert np.median(step.max(axis=(1, 2))) < 0.01
    assert np.abs(np.diff(cop_true, axis=0)).max() < 0.1  # < 1 mm per frame at 100 Hz
    assert 0.3 < np.ptp(cop_true[:, 1]) < 4.0  # a few mm of A-P sway over 5 s
    # the person stands at the mat's centre, (15, 15) cm for 16 cells at 2 cm
    assert np.all(np.abs(cop_true.mean(axis=0) - 15.0) < 1.0)
    # cells the feet never touch conduct g_rest only; the load moves under the feet
    quiet = np.all(g == G_REST, axis=0)
    assert 0.4 < quiet.mean() < 0.9
    assert np.all(g[:, ~quiet] > G_REST)
    assert np.ptp(g[:, ~quiet], axis=0).max() > 0
    # loaded cells reach the mS range of a Velostat cell under a foot (thesis Fig. 2.9)
    assert 1e-3 < g.max() < 2e-2


def test_swaying_feet_is_seeded():
    a = twin.swaying_feet(20, (8, 8), pitch_cm=4.0, seed=5)
    np.testing.assert_array_equal(a, twin.swaying_feet(20, (8, 8), pitch_cm=4.0, seed=5))
    assert not np.array_equal(a, twin.swaying_feet(20, (8, 8), pitch_cm=4.0, seed=6))


def test_a_short_recording_still_sways():
    # 0.6 s holds no frequency of the 0.2-1 Hz sway band on its own: it is the start of a longer scene
    _, c = twin.swaying_feet(60, seed=3, return_cop_cm=True)
    assert np.ptp(c, axis=0).min() > 0


def test_conductance_is_the_sensor_step_of_counts():
    scene = twin.quiet_standing(0.4, 50.0, seed=4)
    g = twin.MatPhysics((16, 16), dt=0.02, seed=9).conductance(scene.pressure_psi)
    _, truth = twin.MatPhysics((16, 16), dt=0.02, seed=9).counts(scene.pressure_psi, return_truth=True)
    np.testing.assert_array_equal(g, truth.g)
    # the sensor state carries on between calls, as in counts
    mat = twin.MatPhysics((16, 16), dt=0.02, seed=9)
    halves = np.concatenate([mat.conductance(scene.pressure_psi[:10]), mat.conductance(scene.pressure_psi[10:])])
    np.testing.assert_array_equal(halves, g)


def test_the_benchmark_frames_are_the_twin_s():
    # regression: the benchmark drew its frames from a second synthetic world, a
    # power-law stand-in with a 1e-6..1e-5 S background; now they are the twin's
    g, G = bench_scene(16, 5, 0)
    assert np.min(g) == G_REST
    assert np.all(G >= g)


@pytest.mark.parametrize(
    "call, exc, match",
    [
        (lambda: twin.swaying_feet(0), ValueError, "frames"),
        (lambda: twin.swaying_feet(2.5), ValueError, "frames"),
        (lambda: twin.swaying_feet(10, (16, 0)), ValueError, "shape"),
        (lambda: twin.swaying_feet(10, rate_hz=0.0), ValueError, "rate_hz"),
        (lambda: twin.swaying_feet(10, pitch_cm=-1.0), ValueError, "pitch_cm"),
        (lambda: twin.mat_pitch_cm((16, 16.0)), TypeError, "shape"),
        (lambda: twin.random_array((0, 4)), ValueError, "shape"),
        (lambda: twin.random_array((4, 4), (0.0, 1e-2)), ValueError, "low"),
        (lambda: twin.random_array((4, 4), (1e-2, 1e-3)), ValueError, "low <= high"),
        (lambda: twin.random_array((4, 4), 1e-3), ValueError, "pair"),
        (lambda: twin.random_array((4, 4), seed=-1), ValueError, "seed"),
    ],
)
def test_bad_inputs(call, exc, match):
    with pytest.raises(exc, match=match):
        call()


def test_random_array_spreads_over_the_decades():
    # thesis Fig. 2.13: 16x16 cells between 1e-5 and 1e-2 S; log-uniform puts a third in each decade
    g = twin.random_array((16, 16), seed=0)
    assert g.shape == (16, 16) and 1e-5 <= g.min() and g.max() <= 1e-2
    counts = np.histogram(np.log10(g), bins=[-5, -4, -3, -2])[0]
    assert counts.sum() == 256 and np.all(np.abs(counts - 256 / 3) < 25)
    # uniform in g: 90 % of the cells above a tenth of the range's top
    lin = twin.random_array((16, 16), (1e-5, 1e-2), log=False, seed=0)
    assert 0.85 < np.mean(lin > 1e-3) < 0.95
    np.testing.assert_array_equal(g, twin.random_array((16, 16), seed=0))
    assert not np.array_equal(g, twin.random_array((16, 16), seed=1))


def test_a_scene_gives_its_pressure_in_kpa_too() -> None:
    # docs/spec.md §1: psi inside, kPa at the API; 1 psi = 6.894757 kPa
    from psmat.twin import quiet_standing

    s = quiet_standing(0.2, 50.0, seed=1)
    np.testing.assert_allclose(s.pressure_kpa, s.pressure_psi * 6.894757, rtol=1e-15)
    # the cells carry the weight: Σ p·A = force, 1 kPa on 4 cm² is 0.4 N
    np.testing.assert_allclose(s.pressure_kpa.sum(axis=(1, 2)) * 0.4, s.cell_force_n(), rtol=1e-12)

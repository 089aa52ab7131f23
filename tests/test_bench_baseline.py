"""The NumPy/SciPy baseline (independent IECM cross-check), the synthetic scenes and the benchmark CLI."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

from psmat import scenes
from psmat.bench.baseline_numpy import (
    forward_numpy,
    jacobian_numpy,
    solve_fixed_point_numpy,
    solve_least_squares_scipy,
)


# ----------------------------------------------------------------------------- baseline forward

def test_forward_matches_reference(iecm_reference):
    assert {"4x4_random", "3x5_random", "16x16_random", "16x16_feet"} <= set(iecm_reference)
    for name, case in iecm_reference.items():
        g, G = np.array(case["g"]), np.array(case["G"])
        np.testing.assert_allclose(forward_numpy(g), G, rtol=1e-12, atol=0, err_msg=name)


def test_forward_batch_equals_frames(iecm_reference):
    g = np.array(iecm_reference["16x16_feet"]["g"])
    batch = np.stack([g, 2.0 * g, g[::-1]])
    G = forward_numpy(batch)
    assert G.shape == batch.shape
    for t in range(3):
        np.testing.assert_allclose(G[t], forward_numpy(batch[t]), rtol=1e-13)
    # Homogeneity: F(2 g) = 2 F(g).
    np.testing.assert_allclose(G[1], 2.0 * G[0], rtol=1e-12)


def test_forward_physics():
    # One 1 S cell, the rest tiny: G of that cell is close to 1 S and always below the cell
    # in parallel with everything else; G <= g + (paths through the rest) and G >= g.
    g = scenes.random_array(5, 4, rng=3)
    G = forward_numpy(g)
    assert np.all(G >= g * (1 - 1e-12))
    # 2x2 closed form: cell (0,0) in parallel with the series path (0,1)-(1,1)-(1,0).
    a, b, c, d = 1e-3, 2e-3, 3e-3, 4e-3
    G2 = forward_numpy(np.array([[a, b], [c, d]]))
    assert G2[0, 0] == pytest.approx(a + 1.0 / (1 / b + 1 / d + 1 / c), rel=1e-13)


def test_jacobian_matches_reference_and_finite_differences(iecm_reference):
    for name, case in iecm_reference.items():
        g = np.array(case["g"])
        J = jacobian_numpy(g)
        np.testing.assert_allclose(np.diag(J), 1.0, rtol=1e-12, err_msg=name)
        np.testing.assert_allclose(J[0], case["jacobian_row0"], rtol=1e-9, atol=1e-14, err_msg=name)
        np.testing.assert_allclose(J[:, -1], case["jacobian_col_last"], rtol=1e-9, atol=1e-14, err_msg=name)
    g = np.array(iecm_reference["4x4_random"]["g"])
    J = jacobian_numpy(g)
    h = 1e-6 * g.ravel()
    fd = np.empty_like(J)
    for b in range(g.size):
        gp, gm = g.ravel().copy(), g.ravel().copy()
        gp[b] += h[b]
        gm[b] -= h[b]
        fd[:, b] = (forward_numpy(gp.reshape(g.shape)) - forward_numpy(gm.reshape(g.shape))).ravel() / (2 * h[b])
    np.testing.assert_allclose(fd, J, rtol=1e-5, atol=1e-7)


# ----------------------------------------------------------------------------- baseline inverses

@pytest.fixture(scope="module")
def small_case():
    g = scenes.random_array(4, 4, low=1e-4, high=1e-2, rng=11)
    return g, forward_numpy(g)


def test_fixed_point_recovers_small_array(small_case):
    g, G = small_case
    g_hat, info = solve_fixed_point_numpy(G, beta=0.05, rtol=1e-12, max_iter=200_000)
    assert info["converged"]
    assert 0 < info["iterations"] < 200_000
    np.testing.assert_allclose(g_hat, g, rtol=1e-8)


def test_fixed_point_batch_and_oracle_stop(small_case):
    g, G = small_case
    batch = np.stack([G, 3.0 * G])
    g_hat, info = solve_fixed_point_numpy(batch, beta=0.05, rtol=0.0, max_iter=50)
    assert g_hat.shape == batch.shape
    assert np.all(info["iterations"] == 50) and not info["converged"].any()
    assert np.all(g_hat > 0)
    _, info = solve_fixed_point_numpy(G, rtol=0.0, max_iter=1_000_000, g_true=g, target_error=1e-3)
    assert info["converged"] and info["iterations"] < 1_000_000


@pytest.mark.parametrize("param", ["bounds", "log"])
def test_least_squares_recovers_small_array(small_case, param):
    g, G = small_case
    g_hat, res = solve_least_squares_scipy(G, param=param, residual="relative")
    assert res.success
    assert res.wall_time > 0
    np.testing.assert_allclose(g_hat, g, rtol=1e-7)


def test_least_squares_rejects_bad_options(small_case):
    _, G = small_case
    with pytest.raises(ValueError, match="param"):
        solve_least_squares_scipy(G, param="nope")
    with pytest.raises(ValueError, match="residual"):
        solve_least_squares_scipy(G, residual="nope")
    with pytest.raises(ValueError, match="one"):
        solve_least_squares_scipy(np.stack([G, G]))


# ----------------------------------------------------------------------------- scenes

@pytest.mark.parametrize("n", [16, 32, 64])
def test_two_feet_ranges(n):
    g = scenes.two_feet(n, n, rng=0)
    assert g.shape == (n, n) and g.dtype == np.float64
    assert g.min() >= 1e-6 * (1 - 1e-12)
    assert 5e-3 <= g.max() <= 2e-2                       # loaded cells reach ~1e-2 S
    loaded = g >= 1e-3
    assert 0.08 <= loaded.mean() <= 0.4                   # two feet on a 32 cm mat
    quiet = g < 1.0001e-5
    assert quiet.mean() >= 0.4                            # a quiet background around them
    # Same feet in cm at finer pitch: loaded area grows ~ with the cell count.
    if n > 16:
        coarse = (scenes.two_feet(16, 16, rng=0) >= 1e-3).sum()
        assert loaded.sum() == pytest.approx(coarse * (n / 16) ** 2, rel=0.35)


def test_two_feet_seeded_and_cop_offset():
    a = scenes.two_feet(rng=5)
    np.testing.assert_array_equal(a, scenes.two_feet(rng=np.random.default_rng(5)))
    assert not np.array_equal(a, scenes.two_feet(rng=6))
    # The CoP of the pressure moves by exactly the requested offset (no clipping at 1 cm).
    p0 = scenes.feet_pressure(16, 16)
    pitch = scenes.default_pitch(16, 16)
    X, Y = np.meshgrid((np.arange(16) + 0.5) * pitch, (np.arange(16) + 0.5) * pitch)
    w = scenes._cop_weights(p0, X, Y, np.array([[0.7, -1.2]]))[0]
    p = p0 * w
    shift = np.array([np.sum(p * X), np.sum(p * Y)]) / p.sum() - np.array([np.sum(p0 * X), np.sum(p0 * Y)]) / p0.sum()
    np.testing.assert_allclose(shift, [0.7, -1.2], atol=1e-10)
    assert p.sum() == pytest.approx(p0.sum(), rel=1e-12)
    # Pressure integrates to the body weight.
    assert p0.sum() * 1e3 * (pitch * 1e-2) ** 2 == pytest.approx(700.0, rel=1e-12)
    moved = scenes.two_feet(cop_offset_cm=(0.0, 1.0), rng=5)
    assert moved.shape == a.shape and not np.allclose(moved, a)


def test_swaying_feet_consecutive_frames_close():
    g, cop = scenes.swaying_feet(500, 16, 16, rng=1, return_cop=True)
    assert g.shape == (500, 16, 16) and cop.shape == (500, 2)
    assert g.min() >= 1e-6 * (1 - 1e-12) and g.max() <= 2e-2
    step = np.abs(np.diff(g, axis=0)) / g[:-1]
    assert step.max() < 0.05                               # consecutive frames are close
    assert np.median(step.max(axis=(1, 2))) < 0.01
    assert np.abs(np.diff(cop, axis=0)).max() < 0.1        # < 1 mm per frame at 100 Hz
    assert 0.3 < np.ptp(cop[:, 1]) < 4.0                    # ~1 cm excursions
    # Background cells do not move; the load does.
    quiet = scenes.feet_pressure(16, 16) == 0
    assert quiet.mean() > 0.4
    np.testing.assert_array_equal(g[:, quiet], np.broadcast_to(g[0, quiet], (500, quiet.sum())))
    assert np.ptp(g[:, ~quiet], axis=0).max() > 0
    np.testing.assert_array_equal(g, scenes.swaying_feet(500, 16, 16, rng=1))


def test_random_array():
    g = scenes.random_array(16, 16, rng=0)
    assert g.shape == (16, 16) and 1e-5 <= g.min() and g.max() <= 1e-2
    lin = scenes.random_array(3, 7, low=1.0, high=2.0, log=False, rng=0)
    assert lin.shape == (3, 7) and 1.0 <= lin.min() and lin.max() <= 2.0
    with pytest.raises(ValueError):
        scenes.random_array(1, 4)
    with pytest.raises(ValueError):
        scenes.random_array(4, 4, low=0.0)


# ----------------------------------------------------------------------------- benchmark CLI

def test_bench_cli_smoke(tmp_path):
    out = tmp_path / "bench.json"
    cmd = [sys.executable, "-m", "psmat.bench", "iecm", "--smoke", "--sizes", "16", "--frames", "20",
           "--json", str(out)]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    table = proc.stdout
    assert "machine:" in table and "| size |" in table
    newton = [line for line in table.splitlines() if line.startswith("| 16x16 | streaming | psmat newton")]
    assert newton, table
    printed_fps = float(newton[0].split("|")[6])
    data = json.loads(out.read_text())
    assert data["machine"]["numpy"] == np.__version__
    solvers = {r["solver"] for r in data["rows"]}
    assert any(s.startswith("numpy fixed point") for s in solvers)
    rows = [r for r in data["rows"] if r["solver"] == "psmat newton"]
    assert rows and all(r["err_loaded"] <= 1e-6 for r in rows)
    # the figures are what was timed: frames x calls / seconds, per core = / threads (no speed claim)
    for r in rows:
        assert r["fps"] == pytest.approx(r["frames"] * r["calls"] / r["seconds"], rel=1e-12)
        assert r["fps_per_core"] == pytest.approx(r["fps"] / r["threads"], rel=1e-12)
    first = next(r for r in rows if r["mode"] == "streaming" and r["threads"] == 1)
    assert printed_fps == pytest.approx(first["fps"], rel=1e-3)  # the table prints 4 significant digits


def test_sensor_bench_numpy_baseline_agrees_with_the_core():
    # the benchmark's NumPy direct/inverse models are independent implementations: they must
    # agree with the C++ model, so the throughput comparison compares like with like
    from psmat.bench.sensor import _numpy_direct, _numpy_inverse
    from psmat.sensor import MPICreep

    m = MPICreep.thesis()
    p = np.repeat(np.random.default_rng(0).uniform(0, 32, (20, 5)), 6, axis=0)
    g = m.direct(p, 0.5)
    np.testing.assert_allclose(_numpy_direct(m, p, 0.5), g, rtol=1e-12, atol=1e-18)
    np.testing.assert_allclose(_numpy_inverse(m, g, 0.5), p, atol=1e-9)

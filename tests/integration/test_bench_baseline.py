"""The NumPy/SciPy baseline (independent IECM cross-check) and the benchmark CLI (its frames: tests/unit/test_twin_conductance.py)."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

from psmat import twin
from psmat.bench.baselines import (
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
    g = twin.random_array((5, 4), seed=3)
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
    g = twin.random_array((4, 4), (1e-4, 1e-2), seed=11)
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
    assert res.success and res.njev >= 1  # it iterated: the initial guess is not the solution
    np.testing.assert_allclose(g_hat, g, rtol=1e-7)


def test_least_squares_rejects_bad_options(small_case):
    _, G = small_case
    with pytest.raises(ValueError, match="param"):
        solve_least_squares_scipy(G, param="nope")
    with pytest.raises(ValueError, match="residual"):
        solve_least_squares_scipy(G, residual="nope")
    with pytest.raises(ValueError, match="one"):
        solve_least_squares_scipy(np.stack([G, G]))


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
    assert data["settings"]["quick"] is False and data["settings"]["smoke"] is True  # as asked, not shadowed
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
    # the thesis' quick fixed point in NumPy on the noisy frames, and psmat's noisy streaming over it
    quick = [r for r in data["rows"] if r["solver"].startswith("numpy fixed point β=0.05, 25 it (thesis quick)")]
    assert len(quick) == 1 and quick[0]["iterations"] == 25 and quick[0]["frames"] == 20
    noisy = next(r for r in data["rows"] if r["solver"] == "psmat newton, noisy G (1 mV, 12 bit)"
                 and r["mode"] == "streaming")
    (speedup,) = data["speedups"]
    assert speedup["size"] == 16 and speedup["basis"] == "total" and speedup["goal"] is None
    assert speedup["ratio"] == pytest.approx(noisy["fps"] / quick[0]["fps"], rel=1e-12)
    assert f"- {speedup['line']}" in table.splitlines()


def test_sensor_bench_numpy_baseline_agrees_with_the_core():
    # the benchmark's NumPy direct/inverse models are independent implementations: they must
    # agree with the C++ model, so the throughput comparison compares like with like
    from psmat.bench.baselines import direct_numpy, inverse_numpy
    from psmat.sensor import MPICreep

    m = MPICreep.thesis()
    p = np.repeat(np.random.default_rng(0).uniform(0, 32, (20, 5)), 6, axis=0)
    g = m.direct(p, 0.5)
    np.testing.assert_allclose(direct_numpy(m, p, 0.5), g, rtol=1e-12, atol=1e-18)
    np.testing.assert_allclose(inverse_numpy(m, g, 0.5), p, atol=1e-9)

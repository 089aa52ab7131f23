"""The IECM benchmark's targets are docs/spec.md §10's, noisy rows included."""

from __future__ import annotations

import numpy as np
import pytest

import psmat.iecm as iecm
from psmat.bench.iecm import NOISY_RESIDUAL, apply_target, complementarity_residual, noisy_entries
from psmat.bench.iecm_baselines import measure_quick_fixed_point_numpy
from psmat.bench.iecm_setup import row, scene
from psmat.bench.iecm_speedup import speedup_over_numpy


def _noisy(size=16, fps=2500.0, threads=2, max_iterations=40, max_residual=1e-7, **kw):
    return row(size=size, mode="streaming", solver="psmat newton, noisy G (1 mV, 12 bit)", threads=threads,
                fps=fps, fps_per_core=fps / threads, max_iterations=max_iterations, max_residual=max_residual,
                noise_v=1e-3, **kw)


def test_noisy_rows_carry_the_spec_targets():
    # regression: the README said every docs/spec.md §10 IECM target was met while
    # the benchmark printed no target on the noisy rows (docs/spec.md §10: 16x16 >= 2000 fps/core, 32x32
    # >= 200 fps, 64x64 >= 100 fps (raised from 20), residual <= 1e-6, no frame over 50 iterations)
    met = _noisy(fps=5000.0)  # 2500 fps/core
    apply_target(met)
    assert met["target"] == ">= 2000 fps/core, residual <= 1e-06, <= 50 it" and met["target_met"] is True
    slow = _noisy(fps=371.6)  # 185.8 fps/core: below the target
    apply_target(slow)
    assert slow["target_met"] is False
    long = _noisy(fps=5000.0, max_iterations=51)
    apply_target(long)
    assert long["target_met"] is False
    loose = _noisy(fps=5000.0, max_residual=2e-6)
    apply_target(loose)
    assert loose["target_met"] is False
    r32 = _noisy(size=32, fps=210.0)
    apply_target(r32)
    assert r32["target"].startswith(">= 200 fps,") and r32["target_met"] is True
    r64 = _noisy(size=64, fps=float("nan"))  # stopped by its budget
    apply_target(r64)
    assert r64["target"].startswith(">= 100 fps,") and r64["target_met"] is False
    r64_old = _noisy(size=64, fps=45.0)  # met the earlier 20 fps, not the raised 100
    apply_target(r64_old)
    assert r64_old["target_met"] is False


def test_noise_free_targets_are_only_the_specs():
    cold = row(size=16, mode="cold", solver="psmat newton", threads=1, fps=400.0, fps_per_core=400.0,
                err_loaded=1e-9)
    apply_target(cold)
    assert cold["target"] == ">= 300 fps/core, err <= 1e-06" and cold["target_met"] is True
    inaccurate = row(size=16, mode="streaming", solver="psmat newton", threads=1, fps=4000.0,
                      fps_per_core=4000.0, err_loaded=2e-6)
    apply_target(inaccurate)
    assert inaccurate["target_met"] is False
    r32 = row(size=32, mode="streaming", solver="psmat newton", threads=2, fps=600.0, fps_per_core=300.0,
               err_loaded=1e-9)
    apply_target(r32)  # docs/spec.md §10 sets no noise-free 32x32 target
    assert r32["target"] == "" and r32["target_met"] is None


def test_noisy_entries_compare_the_old_solver_and_the_quick_fixed_point():
    # the noisy rows sit beside the earlier default (Fischer-Burmeister bounded_newton) and the thesis'
    # quick fixed point (25 iterations, beta 0.05) in the same run, and a cold start is reported
    entries = noisy_entries(16, 2000, heavy=False, ncpu=2)
    assert [e["mode"] for e in entries] == ["streaming", "cold", "streaming", "streaming"]
    assert entries[2]["method"] == "bounded_newton"
    assert entries[3]["method"] == "fixed_point"
    assert entries[3]["solve_options"] == dict(beta=0.05, max_iter=25, rtol=1e-14)
    heavy = noisy_entries(64, 20, heavy=True, ncpu=2)
    assert heavy[2]["frames"] == 4 and heavy[1]["frames"] == 4 and heavy[0]["frames"] == 20


def test_complementarity_residual_by_hand():
    g = np.full((3, 3), 1e-3)
    G = iecm.forward(g)
    assert complementarity_residual(g, G) <= 1e-12  # an exact solution
    # one cell reads 10 % more than the model gives: phi = sqrt(a^2 + b^2) - a - b with
    # a = g/G' and b = (G - G')/G' = -1/11 for that cell (g_floor negligible)
    G2 = G.copy()
    G2[1, 1] *= 1.1
    a, b = (1e-3 - 1e-12) / G2[1, 1], -0.1 / 1.1
    assert np.isclose(complementarity_residual(g, G2), np.hypot(a, b) - a - b, rtol=1e-9)


def test_complementarity_residual_counts_both_sides_slack():
    # g = G on a 3x3 array of equal cells: the parallel paths make F(G) > G, so a = (G - 1e-12)/G ~ 1 and
    # b = F(G)/G - 1 > 0 on every cell: both slack, phi < 0; the residual is |phi|, not the (negative) max
    g = np.full((3, 3), 1e-3)
    G = iecm.forward(g)
    a = (G - 1e-12) / G
    b = iecm.forward(G) / G - 1.0
    assert np.all(b > 0)
    assert np.isclose(complementarity_residual(G, G), np.max(np.abs(np.hypot(a, b) - a - b)), rtol=1e-12)
    assert complementarity_residual(G, G) > 0.1


def _quick(size=32, fps=500.0, threads=2, fps_per_core=None):
    return row(size=size, mode="cold", solver="numpy fixed point β=0.05, 25 it (thesis quick), noisy G",
               threads=threads, fps=fps, fps_per_core=fps / threads if fps_per_core is None else fps_per_core,
               noise_v=1e-3)


def test_speedup_over_the_numpy_quick_fixed_point_by_hand():
    # docs/spec.md §10: at 32x32 psmat's noisy streaming >= 5x the NumPy quick fixed point, in total frames/s
    met = speedup_over_numpy(_noisy(size=32, fps=2500.0), _quick(fps=500.0))
    assert met["ratio"] == 5.0 and met["basis"] == "total" and met["goal"] == 5.0 and met["goal_met"] is True
    assert "is 5.00×" in met["line"] and met["line"].endswith("goal >= 5×: met")
    short = speedup_over_numpy(_noisy(size=32, fps=1995.0), _quick(fps=500.0))
    assert short["ratio"] == 3.99 and short["goal_met"] is False and short["line"].endswith("goal >= 5×: MISSED")
    # totals, not per core: psmat 2000 fps on 2 threads against NumPy 500 fps counted on 1 core is 4x
    # (per core it would be 2x)
    total = speedup_over_numpy(_noisy(size=32, fps=2000.0, threads=2), _quick(fps=500.0, threads=1))
    assert total["ratio"] == 4.0
    # a row stopped by its budget has no rate: no ratio, the goal missed
    lost = speedup_over_numpy(_noisy(size=32, fps=float("nan")), _quick(fps=500.0))
    assert np.isnan(lost["ratio"]) and lost["goal_met"] is False and "no ratio" in lost["line"]
    # no goal at 16x16: the ratio is printed, nothing marked
    r16 = speedup_over_numpy(_noisy(size=16, fps=5000.0), _quick(size=16, fps=1000.0))
    assert r16["ratio"] == 5.0 and r16["goal"] is None and r16["goal_met"] is None and "goal" not in r16["line"]


def test_speedup_rejects_rows_that_do_not_compare():
    with pytest.raises(ValueError, match="one size"):
        speedup_over_numpy(_noisy(size=16), _quick(size=32))
    noise_free = row(size=32, mode="streaming", solver="psmat newton", threads=2, fps=900.0)
    with pytest.raises(ValueError, match="noisy"):
        speedup_over_numpy(noise_free, _quick(size=32))


def test_quick_numpy_row_solves_the_noisy_frames_of_psmats_row():
    # with no update the method returns its start g0 = G, so the row's residual is that of G on the
    # first 3 noisy frames of the 5-frame recording psmat's noisy rows solve (its frame 0 primes)
    _, G = scene(8, 6, seed=0, noise_v=1e-3)
    start = measure_quick_fixed_point_numpy(8, 3, 5, seed=0, min_time=0.0, max_time=10.0, cores=2, iterations=0)
    assert start["iterations"] == 0 and start["max_residual"] == complementarity_residual(G[1:4], G[1:4])
    r = measure_quick_fixed_point_numpy(8, 3, 5, seed=0, min_time=0.0, max_time=10.0, cores=2)
    assert r["mode"] == "cold" and r["noise_v"] == 1e-3 and r["frames"] == 3 and r["threads"] == 2
    assert r["iterations"] == 25 and r["max_iterations"] == 25  # every frame exactly 25 updates
    assert r["fps"] == pytest.approx(r["frames"] * r["calls"] / r["seconds"], rel=1e-12)
    assert r["fps_per_core"] == pytest.approx(r["fps"] / 2, rel=1e-12)
    # docs/spec.md §10's anchor: the quick fixed point stops far from the bounded problem's solution
    assert r["max_residual"] > NOISY_RESIDUAL
    with pytest.raises(ValueError, match="frames"):
        measure_quick_fixed_point_numpy(8, 6, 5, seed=0, min_time=0.0, max_time=10.0, cores=2)

"""Inverse IECM: recovery of known arrays (noise-free G = F(g)) by every method."""

from __future__ import annotations

import sys
import threading
import warnings
from pathlib import Path

import numpy as np
import pytest

import psmat

TOL = {"newton": 1e-7, "active_set": 1e-7, "bounded_newton": 1e-7, "lm": 1e-7, "bounded_lsq": 1e-7, "fixed_point": 1e-4}


def _opts(method, g):
    # fixed point (eq. 2.10) is stable for beta < 2/lambda_max(dG/dg) and contracts by
    # 1 - beta*lambda_min per iteration: take beta = 1/lambda_max at the solution
    if method != "fixed_point":
        return {}
    lam_max = np.linalg.eigvals(psmat.iecm.jacobian(g)).real.max()
    return {"beta": 1.0 / lam_max, "max_iter": 100000, "rtol": 1e-9}


@pytest.mark.parametrize("method", psmat.iecm.METHODS)
@pytest.mark.parametrize("shape", [(4, 4), (3, 5), (2, 7), (8, 5)])
def test_recovers_random_arrays(method, shape, rng):
    g = np.exp(rng.uniform(np.log(1e-4), np.log(1e-2), shape))
    G = psmat.iecm.forward(g)
    sol, info = psmat.iecm.solve(G, method=method, return_info=True, **_opts(method, g))
    assert info.all_converged, info.status
    np.testing.assert_allclose(sol, g, rtol=TOL[method])


@pytest.mark.parametrize("method", ["newton", "active_set", "bounded_newton", "lm", "bounded_lsq"])
def test_recovers_reference_cases_cold(method, iecm_reference):
    for name, case in iecm_reference.items():
        g, G = np.array(case["g"]), np.array(case["G"])
        sol = psmat.iecm.solve(G, method=method)
        big = g >= 1e-4
        np.testing.assert_allclose(sol[big], g[big], rtol=1e-6, err_msg=name)
        np.testing.assert_allclose(sol, g, rtol=1e-3, err_msg=name)  # even the quiet background


def test_strong_ghost_three_loaded_corners():
    # §2.3.3 resistor board: three corners at 100 Ohm, the fourth corner empty; the measured
    # G of the empty corner is dominated by the path through the three loaded ones.
    g = np.full((6, 6), 1e-5)  # 100 kOhm
    g[0, 0] = g[0, -1] = g[-1, 0] = 1e-2
    g[-1, -1] = 1e-6  # empty corner, 1 MOhm
    G = psmat.iecm.forward(g)
    assert G[-1, -1] > 100 * g[-1, -1]  # the ghost: a strong reading where nothing is
    for method in ("newton", "bounded_newton", "lm", "bounded_lsq"):
        sol = psmat.iecm.solve(G, method=method)
        np.testing.assert_allclose(sol, g, rtol=1e-6, err_msg=method)


def test_warm_start_needs_fewer_iterations(iecm_reference):
    g = np.array(iecm_reference["16x16_feet"]["g"])
    g2 = g * (1 + 0.01 * np.sin(np.arange(g.size)).reshape(g.shape))  # the next frame, 1% away
    G2 = psmat.iecm.forward(g2)
    _, cold = psmat.iecm.solve(G2, return_info=True)
    sol, warm = psmat.iecm.solve(G2, g0=g, return_info=True)
    assert warm.iterations < cold.iterations
    np.testing.assert_allclose(sol, g2, rtol=1e-6)


@pytest.mark.parametrize("warm_start", [True, False])
def test_batch_equals_frame_by_frame(warm_start, rng):
    base = rng.uniform(1e-4, 1e-2, (5, 6))
    g = base * (1 + 0.02 * rng.standard_normal((12, 5, 6))).clip(0.5)
    G = psmat.iecm.forward(g)
    sol, info = psmat.iecm.solve(G, warm_start=warm_start, threads=2, return_info=True)
    assert sol.shape == g.shape and info.iterations.shape == (12,)
    assert info.all_converged
    np.testing.assert_allclose(sol, g, rtol=1e-7)
    for t in (0, 5, 11):
        np.testing.assert_allclose(sol[t], psmat.iecm.solve(G[t]), rtol=1e-8)


def test_report_fields_are_consistent(iecm_reference):
    G = np.array(iecm_reference["16x16_random"]["G"])
    _, info = psmat.iecm.solve(G, return_info=True, rtol=1e-10)
    assert info.converged and info.status == "converged"
    assert info.residual <= 1e-10
    assert info.evaluations >= info.iterations >= 1
    # a budget too small to converge is reported as such, with a warning
    with pytest.warns(RuntimeWarning, match="did not converge"):
        _, info = psmat.iecm.solve(G, method="fixed_point", max_iter=3, return_info=True)
    assert not info.converged and info.status == "max_iterations" and info.iterations == 3
    assert info.residual > 1e-10


def test_fixed_point_is_slow_on_feet(iecm_reference):
    # docs/spec.md §3: the thesis' fixed point with beta = 0.05 needs thousands of iterations on
    # two-feet images (Jacobian eigenvalues spread over ~0.005..15); measured, not assumed.
    case = iecm_reference["16x16_feet"]
    g, G = np.array(case["g"]), np.array(case["G"])
    J = psmat.iecm.jacobian(g)
    lam = np.linalg.eigvals(J).real
    assert lam.min() < 0.05 and lam.max() > 5
    with pytest.warns(RuntimeWarning):
        sol, info = psmat.iecm.solve(G, method="fixed_point", beta=0.05, max_iter=500, return_info=True)
    big = g >= 1e-4
    assert np.max(np.abs(sol[big] / g[big] - 1)) > 1e-3  # far from the 1e-6 Newton reaches
    newton = psmat.iecm.solve(G)
    assert np.max(np.abs(newton[big] / g[big] - 1)) < 1e-6


def test_noisy_G_gives_the_bounded_solution(rng):
    # Noise can make G unreachable by positive g (quiet cells want g < 0). Newton hands over
    # to the complementarity problem: free cells reproduce G exactly, cells at the bound are
    # those that the model over-predicts even when empty.
    g = np.full((6, 6), 1e-6)
    g[:3, :3] = 5e-3
    G = psmat.iecm.forward(g)
    Gn = G * (1 + 0.02 * rng.standard_normal(G.shape))
    for method in ("newton", "bounded_newton"):
        sol, info = psmat.iecm.solve(Gn, method=method, return_info=True)
        assert info.converged and info.status == "bounded" and info.at_bound > 0
        assert np.all(sol > 0)
        floor = sol <= 1e-12 * (1 + 1e-9)
        assert int(floor.sum()) == info.at_bound
        Fs = psmat.iecm.forward(sol)
        np.testing.assert_allclose(Fs[~floor], Gn[~floor], rtol=1e-9)  # free cells: exact
        assert np.all(Fs[floor] >= Gn[floor] * (1 - 1e-9))  # bound cells: over-predicted
        assert np.all(np.abs(sol[:3, :3] / 5e-3 - 1) < 0.2)  # the load survives the noise
    # least squares (eq. 2.9) lands close to it on the loaded cells
    lsq = psmat.iecm.solve(Gn, method="bounded_lsq", max_iter=1000)
    np.testing.assert_allclose(lsq[:3, :3], sol[:3, :3], rtol=0.02)


def _runs_while_call_is_in_progress(call) -> bool:
    """Whether this thread runs Python while ``call`` runs in another thread.

    With a switch interval far longer than the test, the interpreter never takes the GIL from
    the worker: this thread gets it back (returns from ``start()``) only when the worker
    releases it - inside ``call`` if that releases the GIL, else when the worker ends. What
    this thread then sees is an ordering of events, not a time.
    """
    events = []

    def work():
        events.append("in")
        call()
        events.append("out")

    old = sys.getswitchinterval()
    sys.setswitchinterval(1000.0)
    try:
        t = threading.Thread(target=work)
        t.start()
        seen = list(events)
        t.join()
    finally:
        sys.setswitchinterval(old)
    assert events == ["in", "out"]
    return seen == ["in"]


def test_compiled_solver_releases_the_gil(iecm_reference):
    # one long call into the C++ core (3000 fixed-point iterations) in a worker thread
    G = np.array(iecm_reference["16x16_feet"]["G"])

    def long_solve():
        with warnings.catch_warnings():  # max_iterations by design: rtol cannot be met
            warnings.simplefilter("ignore", RuntimeWarning)
            psmat.iecm.reference.fixed_point(G, beta=0.05, max_iter=3000, rtol=1e-300)

    assert _runs_while_call_is_in_progress(long_solve)
    # the check can fail: a builtin that keeps the GIL (a C loop over a range) is caught
    assert not _runs_while_call_is_in_progress(lambda: sum(range(3_000_000)))


def test_batch_from_a_thread_matches(iecm_reference):
    # the batch path (C++ worker threads, GIL released while waiting) from a Python thread
    G = np.array(iecm_reference["16x16_feet"]["G"])
    frames = np.repeat(G[None], 50, axis=0)
    out = {}
    t = threading.Thread(target=lambda: out.setdefault("g", psmat.iecm.solve(frames, threads=2)))
    t.start()
    t.join(timeout=60)
    assert not t.is_alive()
    np.testing.assert_allclose(out["g"], np.repeat(psmat.iecm.solve(G)[None], 50, axis=0), rtol=1e-8)


def test_noisy_recording_every_frame_converges():
    # What a real mat gives: swaying feet through the measurement chain (1 mV, 12 bits).
    # Quiet cells end at the bound; every frame must still converge (regression: the
    # projected active-set solver stalled on a few frames), and the loaded cells must be
    # recovered to the noise level predicted by eq. 2.11.
    g = psmat.twin.swaying_feet(60, (16, 16), seed=3)
    c = psmat.Circuit()
    G = c.conductance(c.counts(psmat.iecm.forward(g), noise_v=1e-3, rng=4))
    sol, info = psmat.iecm.solve(G, threads=2, return_info=True)
    assert info.all_converged, dict(zip(*np.unique(info.status, return_counts=True)))
    assert np.all(sol > 0)
    loaded = g >= 1e-3
    rel_err = np.abs(sol[loaded] / g[loaded] - 1)
    sigma = psmat.iecm.propagate_uncertainty(g[0])[loaded[0]] / g[0][loaded[0]]
    assert np.median(rel_err) < 2 * np.median(sigma)


def test_warm_start_32x32_regression():
    # an earlier build lost this warm-started 32x32 frame (and every later frame of its chunk);
    # frames 14 and 15 of the benchmark scene of that report, kept as data since that
    # synthetic scene (psmat.scenes, a power-law stand-in) is gone: the twin is the one synthetic world
    with np.load(Path(__file__).resolve().parents[1] / "data" / "iecm_warm_start_32x32.npz") as f:
        g_prev, g = f["g_prev"], f["g"]
    G = psmat.iecm.forward(g)
    sol, info = psmat.iecm.solve(G, g0=g_prev, return_info=True)
    assert info.converged
    big = g >= 1e-4
    np.testing.assert_allclose(sol[big], g[big], rtol=1e-6)


def test_a_frame_a_batch_and_a_stream_report_in_one_bound_type(rng):
    # the core reports each frame as a psmat._core.SolveReport with a psmat._core.Status, whether
    # alone, in a batch or in a stream; SolveInfo's status strings are the names of that enum
    from psmat import _core

    g = rng.uniform(1e-4, 1e-2, (3, 4, 5))
    G = psmat.iecm.forward(g)
    opts = _core.iecm.SolveOptions()
    _, rep = _core.iecm.solve_frame(G[0], opts)
    job = _core.iecm.BatchJob(G, opts, True, 2)
    job.start()
    assert job.wait(-1.0)
    stream = _core.iecm.StreamSolver(4, 5, opts, 1, 4)
    stream.push(G[0])
    _, _, rep_stream = stream.pop(-1.0)
    stream.close()
    reports = [rep, *job.reports(), rep_stream]
    assert len(reports) == 5
    for r in reports:
        assert type(r) is _core.SolveReport and isinstance(r.status, _core.Status)
        assert r.status == _core.Status.converged and r.converged and r.residual <= 1e-10
        assert isinstance(r.iterations, int) and isinstance(r.residual, float) and isinstance(r.used_fallback, bool)
    assert sorted(_core.Status.__members__) == sorted(
        ["converged", "max_iterations", "stalled", "singular", "least_squares", "bounded"])
    _, info = psmat.iecm.solve(G, return_info=True)
    assert info.status.tolist() == ["converged"] * 3 and info.iterations.dtype.kind == "i"

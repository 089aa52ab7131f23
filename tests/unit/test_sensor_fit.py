"""Identification of the sensor model (thesis §2.5.1): variable projection and annealing."""

from __future__ import annotations

import numpy as np
import pytest

import psmat
from psmat.sensor import MPICreep, fit


def _experiments(rng, sigma):
    # two independent experiments: a descending-hysteresis-like staircase with reversals and
    # a random staircase, 2 Hz, both starting from rest
    up_down = np.concatenate([np.r_[np.arange(0, top + 1, 2), np.arange(top, -1, -2)] for top in (32, 24, 16, 8)])
    p1 = np.repeat(np.tile(up_down, 2), 12).astype(float)
    p2 = np.repeat(rng.uniform(0, 32, 120) * (rng.random(120) > 0.3), 12)
    true = MPICreep.thesis()
    g = [true.direct(p, 0.5) + sigma * rng.standard_normal(p.shape) for p in (p1, p2)]
    return [p1, p2], g, true


def test_varpro_reaches_the_noise_floor(rng):
    sigma = 5e-5  # S
    ps, gs, true = _experiments(rng, sigma)
    res = fit(ps, gs, 0.5, method="varpro")
    # SSE_N of a correct model is the noise variance; 9 parameters on ~4000 samples barely dent it
    assert res.sse_n == pytest.approx(sigma**2, rel=0.05)
    # eq. 2.26 averaged over experiments, recomputed independently with the model
    each = [np.mean((res.model.direct(p, 0.5) - g) ** 2) for p, g in zip(ps, gs)]
    np.testing.assert_allclose(res.sse_n_each, each, rtol=1e-10)
    assert res.sse_n == pytest.approx(np.mean(each), rel=1e-12)
    # identifiable combinations come back close to the truth. r_1 = 0 makes the first OSP
    # operator y = p, collinear with a1 p: only a1 + rho (the initial slope, b_1 = rho) is
    # pinned directly, the split only through the tau-weighted higher operators. Creep is
    # barely identifiable from ~30 min of data: not asserted.
    fp, tp = res.model.params, true.params
    assert fp["a1"] + fp["rho"] == pytest.approx(tp["a1"] + tp["rho"], rel=0.02)
    for k in ("tau", "a2", "a3"):
        assert fp[k] == pytest.approx(tp[k], rel=0.1), k
    assert res.model.invertibility_problem() == ""


def test_varpro_noise_free_is_exact(rng):
    ps, gs, true = _experiments(rng, 0.0)
    res = fit(ps, gs, 0.5, method="varpro")
    assert res.sse_n < 1e-6 * np.mean([np.mean(g**2) for g in gs])
    # compensation: the fitted model's inverse recovers the applied pressure
    np.testing.assert_allclose(res.model.inverse(gs[1], 0.5), ps[1], atol=0.05)


@pytest.mark.slow
def test_anneal_is_reproducible_and_reaches_varpro(rng):
    sigma = 5e-5
    ps, gs, _ = _experiments(rng, sigma)
    a = fit(ps, gs, 0.5, method="anneal", seed=3, max_evals=600, refine=False, chains=2)
    b = fit(ps, gs, 0.5, method="anneal", seed=3, max_evals=600, refine=False, chains=2)
    assert a.sse_n == b.sse_n and a.model.params == b.model.params  # seeded, even with threads
    c = fit(ps, gs, 0.5, method="anneal", seed=5, max_evals=600, refine=False, chains=2)
    assert c.model.params != a.model.params  # the seed matters
    assert len(a.details["chain_sse_n"]) == 2 and a.sse_n == pytest.approx(min(a.details["chain_sse_n"]))
    best = fit(ps, gs, 0.5, method="varpro").sse_n
    # annealing over (tau, creep rates) with the linear part exact: the benchmark's target,
    # within 1 % of the best SSE_N (docs/spec.md §10)
    reduced = fit(ps, gs, 0.5, method="anneal", seed=3)
    assert reduced.sse_n <= 1.01 * best
    assert reduced.model.invertibility_problem() == ""
    # annealing over all 9 parameters is the thesis' literal method, not the best one:
    # within a few per cent on this small problem (the benchmark reports it on the full
    # protocols); SSE_N here is dominated by the noise floor sigma^2
    full = fit(ps, gs, 0.5, method="anneal_full", seed=3, max_evals=20000)
    assert full.sse_n <= 1.05 * best
    assert full.model.invertibility_problem() == ""


def test_separable_cost_is_eq_2_26(rng):
    # the C++ variable-projection cost at z equals SSE_N of the model it returns, recomputed
    # with the direct model, averaged over the experiments
    ps, gs, true = _experiments(rng, 5e-5)
    sp = psmat._core.sensor.SeparableProblem(ps, gs, [0.5, 0.5], 6, 32.0, 2)
    for z in ([0.27, -3.1, -5.0], [0.8, -1.0, -2.5]):
        cost, theta, why = sp.solve(z)
        m = MPICreep(*theta[:5], l=theta[5:7], w=theta[7:])
        each = [np.mean((m.direct(p, 0.5) - g) ** 2) for p, g in zip(ps, gs)]
        assert cost == pytest.approx(np.mean(each), rel=1e-9)
        assert theta[1] == z[0] and np.allclose(np.log10(theta[5:7]), z[1:])
        assert why == m.invertibility_problem()


def _non_invertible_data(rng):
    # a response whose polynomial part bends down between ~15 and ~28 psi faster than the
    # play part rises: no invertible model of this family fits it exactly
    m = MPICreep(rho=1e-5, tau=0.3, a1=2e-5, a2=3e-6, a3=-1.2e-7, l=(1e-3,), w=(1e-6,))
    assert "not positive" in m.invertibility_problem()
    up_down = np.concatenate([np.r_[np.arange(0, top + 1, 2), np.arange(top, -1, -2)] for top in (32, 24, 16, 8)])
    p = np.repeat(np.tile(up_down, 2), 12).astype(float)
    return p, m.direct(p, 0.5) + 1e-7 * rng.standard_normal(p.shape)


def test_linear_parameters_are_solved_under_the_invertibility_constraints(rng):
    from scipy.optimize import LinearConstraint, minimize
    from scipy.sparse import csr_matrix

    from psmat.sensor import constrained_coefficients, slope_constraints

    p, g = _non_invertible_data(rng)
    sp = psmat._core.sensor.SeparableProblem([p], [g], [0.5], 6, 32.0, 1)
    z = np.array([0.3, -3.0])
    cost_free, _, why = sp.solve(z)
    assert why  # the unconstrained optimum cannot be inverted
    A, b = sp.design(z)
    margin = 1e-4 * np.ptp(g) / 32.0
    c = constrained_coefficients(A, b, 0.3, 6, 32.0, margin,
                                 lambda c: not MPICreep(*sp.theta(z, c)[:5], l=sp.theta(z, c)[5:6],
                                                        w=sp.theta(z, c)[6:]).invertibility_problem())
    cost = float(np.sum((A @ c - b) ** 2))
    # an independent solver (scipy, not NLopt) on the same QP with a finer grid
    n = np.linalg.norm(A, axis=0)
    As, M = A / n, slope_constraints(0.3, 6, 32.0, A.shape[1], 257) / n
    H, f, bb = As.T @ As, As.T @ b, b @ b
    x0 = np.zeros(A.shape[1])
    x0[0] = 10 * margin * n[0]
    # trust-constr (an interior-point method): SLSQP stopped short of the bound on some builds.
    # The constraints as a sparse matrix: its projections then factor the sparse augmented
    # system instead of a dense QR of the ~1000 x ~1000 slack Jacobian (the same iterates and result).
    ref = minimize(lambda x: (x @ H @ x - 2 * f @ x + bb) / bb, x0, jac=lambda x: 2 * (H @ x - f) / bb,
                   hess=lambda x: 2 * H / bb, method="trust-constr",
                   constraints=[LinearConstraint(csr_matrix(M / margin), lb=1.0)],
                   options=dict(gtol=1e-12, xtol=1e-12, maxiter=2000))
    assert (M @ ref.x).min() >= margin * (1 - 1e-6)
    cost_ref = float(np.sum((A @ (ref.x / n) - b) ** 2))
    assert cost_free < cost <= cost_ref * (1 + 1e-3)
    # the fitted model is usable for compensation: its slope bound is >= margin on the
    # constraint grid and positive everywhere between
    th = sp.theta(z, c)
    assert (slope_constraints(0.3, 6, 32.0, A.shape[1], 65) @ c).min() >= margin * (1 - 1e-6)
    assert (slope_constraints(0.3, 6, 32.0, A.shape[1], 8001) @ c).min() > 0
    assert MPICreep(*th[:5], l=th[5:6], w=th[6:]).invertibility_problem() == ""


def test_fit_of_non_invertible_data_returns_an_invertible_model(rng):
    p, g = _non_invertible_data(rng)
    res = fit(p, g, 0.5, method="varpro", n_creep=1)
    assert res.model.invertibility_problem() == ""
    assert res.details["constrained_solves"] > 0
    p_hat = res.model.inverse(res.model.direct(p, 0.5), 0.5)  # and the inverse runs
    np.testing.assert_allclose(p_hat, p, atol=1e-6)


def test_fit_rejects_bad_input(rng):
    p = np.linspace(0, 10, 50)
    g = MPICreep.thesis().direct(p, 0.5)
    with pytest.raises(ValueError, match="same length"):
        fit(p, g[:-1], 0.5)
    with pytest.raises(ValueError, match="finite"):
        fit(p, np.where(p > 5, np.nan, g), 0.5)
    with pytest.raises(ValueError, match=">= 0 psi"):
        fit(-p, g, 0.5)
    with pytest.raises(ValueError, match="dt"):
        fit(p, g, 0.0)
    with pytest.raises(ValueError, match="method"):
        fit(p, g, 0.5, method="magic")
    with pytest.raises(ValueError, match="max_evals"):
        fit(p, g, 0.5, method="anneal", max_evals=0)
    with pytest.raises(ValueError, match="one p and one g"):
        fit([p, p], [g], 0.5)


def test_fit_figures(tmp_path, rng):
    from psmat.sensor.plots import plot_fit, plot_pressure_recovery

    ps, gs, true = _experiments(rng, 5e-5)
    a = plot_fit(true, ps[0], gs[0], 0.5, tmp_path / "fit.png", title="thesis model")
    b = plot_pressure_recovery(true, ps[0], gs[0], 0.5, tmp_path / "pressure.png")
    for f in (a, b):
        assert f.stat().st_size > 10_000 and f.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_anneal_shows_progress(capsys):
    p = np.repeat(np.r_[0, 8, 16, 8, 0, 24, 0], 12).astype(float)
    g = MPICreep.thesis().direct(p, 0.5)
    fit(p, g, 0.5, method="anneal", max_evals=500, refine=False, chains=1, progress=True)
    err = capsys.readouterr().err
    assert "annealing" in err and "500" in err  # the bar counted the evaluations
    fit(p, g, 0.5, method="anneal", max_evals=500, refine=False, chains=1, progress=False)
    assert "annealing" not in capsys.readouterr().err

"""The reference methods of psmat.iecm.reference, and psmat.iecm.solve dispatching to them by name."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import psmat
from psmat.iecm import reference


def _feet_like(rng, shape=(6, 7)):
    """Cell conductances (S) with a loaded block over a quiet background, as a foot on the mat."""
    g = np.exp(rng.uniform(np.log(1e-6), np.log(1e-5), shape))
    g[1:3, 1:3] = rng.uniform(2e-3, 8e-3, (2, 2))
    return g


def test_the_reference_names_are_the_methods_solve_does_not_recommend():
    assert set(reference.METHODS) == set(psmat.iecm.METHODS) - set(psmat.iecm.RECOMMENDED)
    assert psmat.iecm.RECOMMENDED == ("newton", "active_set")
    assert "fixed_point" in psmat.iecm.METHODS  # docs/spec.md §9
    for name in reference.METHODS:
        assert callable(getattr(reference, name)), name


@pytest.mark.parametrize("name", ["bounded_newton", "lm", "bounded_lsq"])
def test_each_reference_method_recovers_g_and_is_what_solve_runs(name, rng):
    g = _feet_like(rng)
    G = psmat.iecm.forward(g)  # noise-free: g is the exact answer
    sol, info = getattr(reference, name)(G, return_info=True)
    assert info.all_converged and info.method == name
    big = g >= 1e-4  # the loaded cells; the quiet ones are ghost-dominated (G barely depends on them)
    np.testing.assert_allclose(sol[big], g[big], rtol=1e-6)
    np.testing.assert_allclose(sol, g, rtol=1e-3)
    same, info2 = psmat.iecm.solve(G, method=name, return_info=True)
    np.testing.assert_array_equal(same, sol)  # the same deterministic computation
    assert info2.method == name and int(info2.iterations) == int(info.iterations)


def test_fixed_point_with_beta_below_two_over_lambda_max_converges(rng):
    # eq. 2.10 contracts every mode when beta < 2 / lambda_max(dG/dg); here beta = 1 / lambda_max
    g = _feet_like(rng, (4, 4))
    G = psmat.iecm.forward(g)
    beta = 1.0 / np.linalg.eigvals(psmat.iecm.jacobian(g)).real.max()
    sol = reference.fixed_point(G, beta=beta, max_iter=100000, rtol=1e-9)
    np.testing.assert_allclose(sol, g, rtol=1e-4)
    np.testing.assert_array_equal(psmat.iecm.solve(G, method="fixed_point", beta=beta, max_iter=100000, rtol=1e-9),
                                  sol)


def test_a_batch_of_noisy_frames_by_the_bounded_newton_is_the_active_set_solution(rng):
    # the complementarity problem has one solution (dG/dg is a P-matrix): both methods find it
    g = _feet_like(rng, (5, 5))
    G = psmat.iecm.forward(g) * (1 + 0.02 * rng.standard_normal((4, 5, 5)))
    ref, info = reference.bounded_newton(G, threads=2, return_info=True)
    fast = psmat.iecm.solve(G, method="active_set", threads=2)
    assert info.all_converged and info.iterations.shape == (4,)
    assert np.any(info.status == "bounded")
    big = g >= 1e-4
    np.testing.assert_allclose(ref[:, big], fast[:, big], rtol=1e-7)


def test_unconverged_frames_warn_at_the_caller_whichever_path(rng):
    G = psmat.iecm.forward(_feet_like(rng, (4, 4)))
    for call in (lambda: reference.fixed_point(G, max_iter=2),
                 lambda: psmat.iecm.solve(G, method="fixed_point", max_iter=2),
                 lambda: psmat.iecm.solve(G, method="newton", max_iter=1, fallback=False)):
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            call()
        assert [w.category for w in caught] == [RuntimeWarning]
        assert caught[0].filename == __file__  # this test's line, not a line inside psmat.iecm


def test_solve_refuses_an_unknown_method_and_bad_options_for_every_method(rng):
    G = psmat.iecm.forward(_feet_like(rng, (3, 3)))
    with pytest.raises(ValueError, match="unknown method 'gauss_seidel'"):
        psmat.iecm.solve(G, method="gauss_seidel")
    for name in psmat.iecm.METHODS:  # beta is checked even where only fixed_point uses it, as before
        with pytest.raises(ValueError, match="beta"):
            psmat.iecm.solve(G, method=name, beta=-1.0)

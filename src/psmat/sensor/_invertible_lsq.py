"""Linear parameters of the sensor model under the invertibility constraints (docs/spec.md §4).

For fixed tau the model's slope along any loading path is bounded below by

    s(x) = min_j (a1 + rho S_j) + 2 a2 x + 3 a3 x^2,     S_j = sum_{i<=j} e^{-tau r_i}

(eq. 2.17-2.18: the play part contributes a1 + sum of the active b_i, the polynomial its
derivative), which must stay positive on [0, p_max] for the inverse to exist. S_j increases
with j, so the minimum over j is at j = 1 or j = N, and each s(x) >= margin is *linear* in
c = (a1, a2, a3, rho, w_j): the variable-projection subproblem becomes a small convex QP,

    min ||A c - b||^2   subject to   a1 + rho S_j + 2 a2 x_k + 3 a3 x_k^2 >= margin,
                                      j in {1, N}, x_k on a grid of [0, p_max],

and, for the exact inverse to be stable through the creep state (``MPICreep`` C++
``check_invertible``), sum_j |w_j| below that slope: with every sign pattern sigma,

    a1 + rho S_j + 2 a2 x_k + 3 a3 x_k^2 - sum_j sigma_j w_j >= margin,

still linear. Solved here with NLopt's SLSQP; the grid is refined until the model's own
check (``MPICreep.invertibility_problem``) passes.
"""

from __future__ import annotations

import numpy as np

__all__ = ["constrained_coefficients", "slope_constraints"]


def slope_constraints(tau: float, n_ops: int, p_max: float, n_linear: int, grid: int) -> np.ndarray:
    """Rows M of ``M c >= margin`` for c = (a1, a2, a3, rho, w_j) (see the module docstring)."""
    import itertools

    r = np.arange(n_ops) / n_ops * p_max
    S = np.cumsum(np.exp(-tau * r))
    x = np.linspace(0.0, p_max, grid)
    n_creep = n_linear - 4
    rows = []
    for Sj in (S[0], S[-1]):
        for sigma in itertools.product((1.0, -1.0), repeat=n_creep):
            M = np.zeros((grid, n_linear))
            M[:, 0] = 1.0
            M[:, 1] = 2.0 * x
            M[:, 2] = 3.0 * x**2
            M[:, 3] = Sj
            M[:, 4:] = -np.asarray(sigma)
            rows.append(M)
    return np.vstack(rows)


def constrained_coefficients(A: np.ndarray, b: np.ndarray, tau: float, n_ops: int, p_max: float,
                             margin: float, is_invertible) -> np.ndarray:
    """Least-squares c = (a1, a2, a3, rho, w_j) with a positive model slope.

    Parameters
    ----------
    A, b : arrays
        Weighted design matrix and right-hand side (``SeparableProblem.design``).
    tau : float
        The play weights' decay (eq. 2.18).
    margin : float
        Smallest slope allowed, S/psi (> 0: a slope of exactly zero cannot be inverted).
    is_invertible : callable
        ``is_invertible(c) -> bool``: the model's own check, used to refine the grid.
    """
    import nlopt

    n = A.shape[1]
    norms = np.linalg.norm(A, axis=0)
    norms[norms == 0] = 1.0
    As = A / norms
    H = As.T @ As
    f = As.T @ b
    bb = float(b @ b)
    scale = max(bb, 1e-300)

    best = {"value": np.inf, "x": None}

    def objective(x, grad):
        Hx = H @ x
        if grad.size:
            grad[:] = 2.0 * (Hx - f) / scale
        value = float((x @ Hx - 2.0 * f @ x + bb) / scale)
        if value < best["value"] and np.all(Ms_now[0] @ x >= margin * (1 - 1e-9)):
            best["value"], best["x"] = value, np.array(x)  # best feasible point seen
        return value

    Ms_now = [None]

    c = None
    for grid in (65, 257, 1025):
        Ms = slope_constraints(tau, n_ops, p_max, n, grid) / norms
        Ms_now[0] = Ms
        best["value"], best["x"] = np.inf, None

        def constraints(result, x, grad, Ms=Ms):
            result[:] = (margin - Ms @ x) / margin  # <= 0 when the slope is >= margin
            if grad.size:
                grad[:] = -Ms / margin

        opt = nlopt.opt(nlopt.LD_SLSQP, n)
        opt.set_min_objective(objective)
        opt.add_inequality_mconstraint(constraints, [1e-9] * Ms.shape[0])
        opt.set_xtol_rel(1e-12)
        opt.set_ftol_abs(1e-15)
        opt.set_maxeval(2000)
        x0 = np.zeros(n)
        x0[0] = 10.0 * margin * norms[0]  # a1 alone: a feasible start
        try:
            x = np.asarray(opt.optimize(x0))
        except (nlopt.RoundoffLimited, nlopt.runtime_error, RuntimeError):
            # SLSQP stopped on round-off or failed (far corners of the search box): keep its
            # best feasible point, else the feasible start (a1 alone)
            x = best["x"] if best["x"] is not None else x0
        c = x / norms
        if is_invertible(c):
            return c
    raise RuntimeError("could not find invertible linear parameters for this tau "
                       "(the constrained least squares did not converge)")

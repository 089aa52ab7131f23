"""Identification of the sensor model from pneumatic experiments (thesis §2.5.1, SPEC §4).

Minimises SSE_N (eq. 2.26) averaged over independent experiments (the sensor rests between
them, so each is simulated from rest) over theta = (rho, tau, a1, a2, a3, l_j, w_j).

``method="varpro"``
    Separable least squares (variable projection). Given tau and the creep rates l_j the
    model is linear in (a1, a2, a3, rho, w_j):
        g = a1 p + a2 p^2 + a3 p^3 + rho * sum_i e^{-tau r_i} y_{r_i}[p] + sum_j w_j y_c[p; l_j]
    so only (tau, log10 l_j) are searched (a coarse grid, then NLopt BOBYQA), the rest is an
    exact linear solve. Fast and reproducible.
``method="anneal"``
    The thesis' method: simulated annealing in C++ over all parameters (scaled, creep rates
    in log10), seeded, then local refinement with NLopt (BOBYQA).
Both reject parameters for which the model cannot be inverted (SPEC §4).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from .. import _core
from .mpi_creep import MPICreep

__all__ = ["fit", "FitResult"]


@dataclass
class FitResult:
    """Outcome of :func:`fit`.

    Attributes
    ----------
    model : MPICreep
        The identified model.
    sse_n : float
        Mean over experiments of SSE_N (eq. 2.26), S^2.
    sse_n_each : numpy.ndarray
        SSE_N of each experiment, S^2.
    method, seed : str, int
    wall_time : float
        Seconds.
    evaluations : int
        Model simulations (objective evaluations).
    details : dict
        Method-specific figures (annealing acceptance, the grid, NLopt's result code).
    """

    model: MPICreep
    sse_n: float
    sse_n_each: np.ndarray
    method: str
    seed: int
    wall_time: float
    evaluations: int
    details: dict = field(default_factory=dict)

    def summary(self) -> str:
        return (f"{self.method} (seed {self.seed}): SSE_N {self.sse_n:.4g} S^2 "
                f"(per experiment {np.array2string(self.sse_n_each, precision=3)}), "
                f"{self.evaluations} evaluations, {self.wall_time:.2f} s")


def _experiments(p, g, dt):
    ps = [p] if isinstance(p, np.ndarray) and np.ndim(p) == 1 else list(p)
    gs = [g] if isinstance(g, np.ndarray) and np.ndim(g) == 1 else list(g)
    if len(ps) != len(gs) or not ps:
        raise ValueError("give one p and one g per experiment (arrays, or lists of arrays)")
    dts = list(np.broadcast_to(np.asarray(dt, dtype=float), (len(ps),)))
    out_p, out_g = [], []
    for k, (pk, gk, dk) in enumerate(zip(ps, gs, dts)):
        pk, gk = np.asarray(pk, dtype=float), np.asarray(gk, dtype=float)
        if pk.ndim != 1 or pk.shape != gk.shape or pk.size < 10:
            raise ValueError(f"experiment {k}: p and g must be 1-D, of the same length >= 10")
        if not (np.all(np.isfinite(pk)) and np.all(np.isfinite(gk))):
            raise ValueError(f"experiment {k}: p and g must be finite (drop missing samples first)")
        if np.any(pk < 0):
            raise ValueError(f"experiment {k}: p must be >= 0 psi")
        if not (np.isfinite(dk) and dk > 0):
            raise ValueError(f"experiment {k}: dt must be > 0 s")
        out_p.append(pk)
        out_g.append(gk)
    return out_p, out_g, [float(d) for d in dts]


def _rate_bounds(p, dt):
    # creep rates: faster than the sampling makes no sense; slower than ~1/10 of the longest
    # experiment cannot be told from a constant (SPEC §4: bounded by the experiment length)
    longest = max(len(x) * d for x, d in zip(p, dt))
    return np.log10(0.1 / longest), np.log10(1.0 / min(dt))


def fit(p, g, dt, method: str = "varpro", seed: int = 0, *, n_ops: int = 6, p_max: float = 32.0,
        n_creep: int = 2, max_evals: int = 60000, refine: bool = True,
        chains: int | None = None, progress: bool | None = None) -> FitResult:
    """Identify the MPI + creep model from one or several pneumatic experiments.

    Parameters
    ----------
    p, g : array or list of arrays
        Applied pressure (psi) and measured conductance (S) of one experiment, or lists of
        several independent experiments (each simulated from rest).
    dt : float or list of float
        Sampling period(s) in s.
    method : {"varpro", "anneal"}
    seed : int
        Seed of the annealing (and of nothing else: varpro is deterministic).
    n_ops, p_max, n_creep
        Model structure (thesis: 6 operators, 32 psi, 2 creep operators).
    max_evals : int
        Annealing budget per chain (objective evaluations).
    chains : int, optional
        Independent annealing chains run in parallel (seeds seed, seed+1, ...); the best is
        kept. Default: one per core.
    progress : bool, optional
        Progress bar of the annealing (default: when writing to a terminal).
    refine : bool
        Finish with NLopt (BOBYQA) from the best point found.
    """
    if method not in ("varpro", "anneal"):
        raise ValueError(f"method must be 'varpro' or 'anneal', got {method!r}")
    if n_creep < 0 or int(n_creep) != n_creep:
        raise ValueError("n_creep must be an integer >= 0")
    ps, gs, dts = _experiments(p, g, dt)
    t0 = time.perf_counter()
    if method == "varpro":
        theta, evals, details = _varpro(ps, gs, dts, n_ops, p_max, n_creep, refine)
    else:
        if chains is None:
            chains = _core.iecm.hardware_threads()
        if int(chains) != chains or chains < 1:
            raise ValueError("chains must be a positive integer")
        theta, evals, details = _anneal(ps, gs, dts, n_ops, p_max, n_creep, max_evals, seed, refine, int(chains),
                                        progress)
    each = np.asarray(_core.sensor.sse_n_each(theta, ps, gs, dts, n_ops, p_max))
    nc = n_creep
    model = MPICreep(*theta[:5], l=theta[5:5 + nc], w=theta[5 + nc:], n_ops=n_ops, p_max=p_max)
    return FitResult(model=model, sse_n=float(each.mean()), sse_n_each=each, method=method, seed=seed,
                     wall_time=time.perf_counter() - t0, evaluations=evals, details=details)


# ------------------------------------------------------------------------ variable projection

def _varpro(ps, gs, dts, n_ops, p_max, n_creep, refine):
    import nlopt

    r = np.arange(n_ops) / n_ops * p_max
    plays = [np.asarray(_core.sensor.play_basis(x, r)) for x in ps]
    weights = [1.0 / np.sqrt(len(ps) * len(x)) for x in ps]  # rows weighted: mean of SSE_N
    lo_l, hi_l = _rate_bounds(ps, dts)
    evals = 0

    def linear(z):
        """Exact coefficients for z = (tau, log10 l_1 > ... > log10 l_nc); (cost, theta)."""
        nonlocal evals
        evals += 1
        tau, logl = z[0], np.asarray(z[1:])
        l = 10.0 ** logl
        rows, rhs = [], []
        for x, y, play, d, wgt in zip(ps, gs, plays, dts, weights):
            cols = [x, x**2, x**3, play @ np.exp(-tau * r)]
            if n_creep:
                cols += list(np.asarray(_core.sensor.creep_basis(x, l, d)).T)
            rows.append(np.column_stack(cols) * wgt)
            rhs.append(y * wgt)
        A, b = np.vstack(rows), np.concatenate(rhs)
        norms = np.linalg.norm(A, axis=0)
        norms[norms == 0] = 1.0
        c = np.linalg.lstsq(A / norms, b, rcond=None)[0] / norms
        a1, a2, a3, rho = c[:4]
        theta = np.concatenate([[rho, tau, a1, a2, a3], l, c[4:]])
        cost = float(np.sum((A @ c - b) ** 2))  # = mean over experiments of SSE_N
        m = MPICreep(*theta[:5], l=theta[5:5 + n_creep], w=theta[5 + n_creep:], n_ops=n_ops, p_max=p_max)
        if m.invertibility_problem():
            cost *= 1e6  # unusable for compensation: push the search away
        return cost, theta

    # coarse grid over tau and ordered creep rates, then BOBYQA from the best few points
    taus = np.linspace(0.02, 1.2, 9)
    grids = np.linspace(lo_l, hi_l, 7)
    starts = []
    import itertools

    for tau in taus:
        for logl in itertools.combinations(grids[::-1], n_creep):
            starts.append((linear([tau, *logl])[0], [tau, *logl]))
    starts.sort(key=lambda s: s[0])
    best_cost, best_z = starts[0]
    if refine:
        lower = [0.0] + [lo_l] * n_creep
        upper = [3.0] + [hi_l] * n_creep
        for _, z0 in starts[:3]:
            opt = nlopt.opt(nlopt.LN_BOBYQA, 1 + n_creep)
            opt.set_lower_bounds(lower)
            opt.set_upper_bounds(upper)
            opt.set_min_objective(lambda z, grad: np.log(linear(z)[0]))
            opt.set_xtol_abs(1e-7)
            opt.set_maxeval(400)
            z = opt.optimize(list(np.clip(z0, lower, upper)))
            cost = linear(z)[0]
            if cost < best_cost:
                best_cost, best_z = cost, list(z)
    cost, theta = linear(best_z)
    return theta, evals, {"grid_points": len(starts), "nonlinear": {"tau": best_z[0], "log10_l": best_z[1:]}}


# ------------------------------------------------------------------------ simulated annealing

def _space(ps, dts, n_creep):
    """Scaled search space x = (rho, tau, s = a1 + rho, a2, a3, log10 l_j, w_j).

    rho and s in 1e-4 S/psi, a2 in 1e-6, a3 in 1e-8, w in 1e-6. The initial slope s replaces
    a1 because y_{r_1} = p (r_1 = 0) makes a1 and rho collinear (see fit.hpp); s > 0 is also
    the first invertibility condition.
    """
    lo_l, hi_l = _rate_bounds(ps, dts)
    scale = np.array([1e-4, 1.0, 1e-4, 1e-6, 1e-8] + [1.0] * n_creep + [1e-6] * n_creep)
    log10 = [False] * 5 + [True] * n_creep + [False] * n_creep
    lo = np.array([0.0, 0.0, 0.0, -50.0, -100.0] + [lo_l] * n_creep + [-50.0] * n_creep)
    hi = np.array([20.0, 2.0, 20.0, 50.0, 100.0] + [hi_l] * n_creep + [50.0] * n_creep)
    x0 = np.array([1.0, 0.3, 2.0, 0.0, 0.0] + list(np.linspace(hi_l - 1, lo_l + 1, n_creep)) + [1.0] * n_creep)
    return x0, lo, hi, scale, log10


def _anneal(ps, gs, dts, n_ops, p_max, n_creep, max_evals, seed, refine, chains, progress=None):
    from concurrent.futures import ThreadPoolExecutor, wait

    import nlopt
    from tqdm.auto import tqdm

    x0, lo, hi, scale, log10 = _space(ps, dts, n_creep)
    counters = [_core.sensor.Counter() for _ in range(chains)]

    def chain(k):  # the C++ annealing releases the GIL: chains run on separate cores
        return _core.sensor.anneal_fit(ps, gs, dts, n_ops, p_max, x0, lo, hi, scale, log10,
                                       int(max_evals), 1.0, 1e-3, int(seed) + k, counters[k])

    total = chains * int(max_evals)
    with ThreadPoolExecutor(max_workers=chains) as pool, tqdm(
        total=total, unit="eval", desc="annealing", leave=False, disable=None if progress is None else not progress
    ) as bar:
        futures = [pool.submit(chain, k) for k in range(chains)]
        while wait(futures, timeout=0.2).not_done:
            bar.update(sum(c.value for c in counters) - bar.n)
        bar.update(total - bar.n)
        results = [f.result() for f in futures]
    res = min(results, key=lambda r: r["sse_n"])
    x_best, evals = np.asarray(res["x"]), sum(int(r["evaluations"]) for r in results)
    details = {"anneal_sse_n": float(res["sse_n"]), "chains": chains,
               "chain_sse_n": [float(r["sse_n"]) for r in results],
               "acceptance": res["accepted"] / max(1, int(res["evaluations"]))}
    if refine:
        count = 0

        def objective(x, grad):
            nonlocal count
            count += 1
            th = np.asarray(_core.sensor.theta_from_x(np.asarray(x), scale, log10))
            m = MPICreep(*th[:5], l=th[5:5 + n_creep], w=th[5 + n_creep:], n_ops=n_ops, p_max=p_max)
            if m.invertibility_problem():
                return 1e3
            return float(np.log(np.mean(_core.sensor.sse_n_each(th, ps, gs, dts, n_ops, p_max)) + 1e-300))

        opt = nlopt.opt(nlopt.LN_BOBYQA, len(x0))
        opt.set_lower_bounds(lo)
        opt.set_upper_bounds(hi)
        opt.set_min_objective(objective)
        opt.set_xtol_rel(1e-8)
        opt.set_maxeval(20000)
        x = opt.optimize(list(x_best))
        if opt.last_optimum_value() < np.log(res["sse_n"]):
            x_best = np.asarray(x)
        evals += count
        details["nlopt_result"] = int(opt.last_optimize_result())
    theta = np.asarray(_core.sensor.theta_from_x(x_best, scale, log10))
    return theta, evals, details

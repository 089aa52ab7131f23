"""Identification of the sensor model from pneumatic experiments (thesis §2.5.1, docs/spec.md §4).

Minimises SSE_N (eq. 2.26) averaged over independent experiments (the sensor rests between
them, so each is simulated from rest) over theta = (rho, tau, a1, a2, a3, l_j, w_j).

``method="varpro"``
    Separable least squares (variable projection). Given tau and the creep rates l_j the
    model is linear in (a1, a2, a3, rho, w_j):
        g = a1 p + a2 p^2 + a3 p^3 + rho * sum_i e^{-tau r_i} y_{r_i}[p] + sum_j w_j y_c[p; l_j]
    so only (tau, log10 l_j) are searched (a coarse grid, then NLopt BOBYQA), the rest is an
    exact linear solve (C++ ``SeparableProblem``) — under the invertibility constraints
    when the unconstrained solution cannot be inverted (:mod:`.invertible_lsq`). Fast and
    reproducible.
``method="anneal"``
    The thesis' method, simulated annealing (C++, seeded, one chain per core), on the same
    reduced problem: the annealing searches (tau, log10 l_j), the linear parameters are
    solved exactly at every step; then NLopt BOBYQA refines.
``method="anneal_full"``
    The thesis' method literally: annealing over all parameters (scaled, creep rates in
    log10, the initial slope a1 + rho instead of a1), then BOBYQA over all of them. Kept as
    the faithful baseline; on the full protocols it stops tens of percent above the best.
All reject parameters for which the model cannot be inverted (docs/spec.md §4).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from .. import _core
from ._invertible_lsq import constrained_coefficients
from ._mpi_creep import MPICreep

__all__ = ["fit", "FitResult", "ReducedProblem", "annealing_space"]


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
    wall_time_s : float
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
    wall_time_s: float
    evaluations: int
    details: dict = field(default_factory=dict)

    def summary(self) -> str:
        return (f"{self.method} (seed {self.seed}): SSE_N {self.sse_n:.4g} S^2 "
                f"(per experiment {np.array2string(self.sse_n_each, precision=3)}), "
                f"{self.evaluations} evaluations, {self.wall_time_s:.2f} s")


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
    # experiment cannot be told from a constant (docs/spec.md §4: bounded by the experiment length)
    longest = max(len(x) * d for x, d in zip(p, dt))
    return np.log10(0.1 / longest), np.log10(1.0 / min(dt))


def fit(p, g, dt, method: str = "varpro", seed: int = 0, *, n_ops: int = 6, p_max: float = 32.0,
        n_creep: int = 2, max_evals: int | None = None, refine: bool = True,
        chains: int | None = None, progress: bool | None = None) -> FitResult:
    """Identify the MPI + creep model from one or several pneumatic experiments.

    Parameters
    ----------
    p, g : array or list of arrays
        Applied pressure (psi) and measured conductance (S) of one experiment, or lists of
        several independent experiments (each simulated from rest).
    dt : float or list of float
        Sampling period(s) in s.
    method : {"varpro", "anneal", "anneal_full"}
    seed : int
        Seed of the annealing (and of nothing else: varpro is deterministic).
    n_ops, p_max, n_creep
        Model structure (thesis: 6 operators, 32 psi, 2 creep operators).
    max_evals : int, optional
        Annealing budget per chain (objective evaluations); default 3000 for "anneal"
        (3 searched parameters), 60000 for "anneal_full" (9).
    chains : int, optional
        Independent annealing chains run in parallel (seeds seed, seed+1, ...); the best is
        kept. Default: one per core.
    progress : bool, optional
        Progress bar of the annealing (default: when writing to a terminal).
    refine : bool
        Finish with NLopt (BOBYQA) from the best point found.
    """
    if method not in ("varpro", "anneal", "anneal_full"):
        raise ValueError(f"method must be 'varpro', 'anneal' or 'anneal_full', got {method!r}")
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
        if max_evals is None:
            max_evals = 3000 if method == "anneal" else 60000
        if int(max_evals) != max_evals or max_evals < 1:
            raise ValueError("max_evals must be a positive integer")
        run = _anneal if method == "anneal" else _anneal_full
        theta, evals, details = run(ps, gs, dts, n_ops, p_max, n_creep, int(max_evals), seed, refine, int(chains),
                                    progress)
    each = np.asarray(_core.sensor.sse_n_each(theta, ps, gs, dts, n_ops, p_max))
    nc = n_creep
    model = MPICreep(*theta[:5], l=theta[5:5 + nc], w=theta[5 + nc:], n_ops=n_ops, p_max=p_max)
    return FitResult(model=model, sse_n=float(each.mean()), sse_n_each=each, method=method, seed=seed,
                     wall_time_s=time.perf_counter() - t0, evaluations=evals, details=details)


# ------------------------------------------------------------------------ variable projection

class ReducedProblem:
    """The separable problem in z = (tau, log10 l_j) (C++ ``SeparableProblem``), with the
    linear parameters solved exactly under the invertibility constraints."""

    def __init__(self, ps, gs, dts, n_ops, p_max, n_creep):
        self.sp = _core.sensor.SeparableProblem(ps, gs, dts, n_ops, p_max, n_creep)
        self.n_ops, self.p_max, self.n_creep = n_ops, p_max, n_creep
        lo_l, hi_l = _rate_bounds(ps, dts)
        self.lower = np.array([0.0] + [lo_l] * n_creep)
        self.upper = np.array([3.0] + [hi_l] * n_creep)
        # smallest slope accepted: 1 % of the data's mean slope (S/psi). The exact inverse
        # divides by this slope and feeds its estimate back through the creep state, so a
        # slope near zero would make compensation unstable, not just slow to converge.
        self.margin = 1e-2 * max(float(np.ptp(np.concatenate(gs))) / p_max, 1e-300)
        self.evals = 0
        self.constrained = 0

    def model(self, theta) -> MPICreep:
        nc = self.n_creep
        return MPICreep(*theta[:5], l=theta[5:5 + nc], w=theta[5 + nc:], n_ops=self.n_ops, p_max=self.p_max)

    def __call__(self, z) -> tuple[float, np.ndarray]:
        """(mean SSE_N, theta) at z with the best invertible linear parameters."""
        self.evals += 1
        z = np.asarray(z, dtype=float)
        cost, theta, why = self.sp.solve(z)
        if not why:
            return float(cost), np.asarray(theta)
        self.constrained += 1
        A, b = self.sp.design(z)
        c = constrained_coefficients(A, b, z[0], self.n_ops, self.p_max, self.margin,
                                     lambda c: not self.model(self.sp.theta(z, c)).invertibility_problem())
        return float(np.sum((A @ c - b) ** 2)), np.asarray(self.sp.theta(z, c))

    def refine(self, z0, max_evals: int = 400) -> tuple[float, np.ndarray]:
        """NLopt BOBYQA on log(cost) from z0; returns (cost, z)."""
        import nlopt

        opt = nlopt.opt(nlopt.LN_BOBYQA, len(z0))
        opt.set_lower_bounds(list(self.lower))
        opt.set_upper_bounds(list(self.upper))
        opt.set_min_objective(lambda z, grad: np.log(self(z)[0] + 1e-300))
        opt.set_xtol_abs(1e-7)
        opt.set_maxeval(max_evals)
        z = opt.optimize(list(np.clip(z0, self.lower, self.upper)))
        return self(z)[0], np.asarray(z)


def _varpro(ps, gs, dts, n_ops, p_max, n_creep, refine):
    import itertools

    red = ReducedProblem(ps, gs, dts, n_ops, p_max, n_creep)
    # coarse grid over tau and ordered creep rates, then BOBYQA from the best few points
    taus = np.linspace(0.02, 1.2, 9)
    grids = np.linspace(red.lower[-1] if n_creep else 0, red.upper[-1] if n_creep else 0, 7)
    starts = []
    for tau in taus:
        for logl in itertools.combinations(grids[::-1], n_creep):
            starts.append((red([tau, *logl])[0], [tau, *logl]))
    starts.sort(key=lambda s: s[0])
    best_cost, best_z = starts[0]
    if refine:
        for _, z0 in starts[:3]:
            cost, z = red.refine(z0)
            if cost < best_cost:
                best_cost, best_z = cost, list(z)
    cost, theta = red(best_z)
    return theta, red.evals, {"grid_points": len(starts), "constrained_solves": red.constrained,
                              "nonlinear": {"tau": best_z[0], "log10_l": list(best_z[1:])}}


# ------------------------------------------------------------------------ simulated annealing

def annealing_space(ps, dts, n_creep):
    """Scaled search space x = (rho, tau, s = a1 + rho, a2, a3, log10 l_j, w_j).

    rho and s in 1e-4 S/psi, a2 in 1e-6, a3 in 1e-8, w in 1e-6. The initial slope s replaces
    a1 because y_{r_1} = p (r_1 = 0) makes a1 and rho collinear (see fit.hpp); s > 0 is also
    the first invertibility condition. Returns ``(x0, lower, upper, scale, log10)``: the start,
    the box, each coordinate's unit and whether it is a log10 (``_core.sensor.theta_from_x``
    maps x to theta).
    """
    lo_l, hi_l = _rate_bounds(ps, dts)
    scale = np.array([1e-4, 1.0, 1e-4, 1e-6, 1e-8] + [1.0] * n_creep + [1e-6] * n_creep)
    log10 = [False] * 5 + [True] * n_creep + [False] * n_creep
    lo = np.array([0.0, 0.0, 0.0, -50.0, -100.0] + [lo_l] * n_creep + [-50.0] * n_creep)
    hi = np.array([20.0, 2.0, 20.0, 50.0, 100.0] + [hi_l] * n_creep + [50.0] * n_creep)
    x0 = np.array([1.0, 0.3, 2.0, 0.0, 0.0] + list(np.linspace(hi_l - 1, lo_l + 1, n_creep)) + [1.0] * n_creep)
    return x0, lo, hi, scale, log10


def _run_chains(chain, chains, total, progress, counters):
    """Run ``chain(k)`` for k < chains on threads (the C++ releases the GIL) with a progress bar."""
    from concurrent.futures import ThreadPoolExecutor, wait

    from psmat._progress import tqdm

    with ThreadPoolExecutor(max_workers=chains) as pool, tqdm(
        total=total, unit="eval", desc="annealing", leave=False, disable=None if progress is None else not progress
    ) as bar:
        futures = [pool.submit(chain, k) for k in range(chains)]
        while wait(futures, timeout=0.2).not_done:
            bar.update(sum(c.value for c in counters) - bar.n)
        bar.update(total - bar.n)
        return [f.result() for f in futures]


def _anneal(ps, gs, dts, n_ops, p_max, n_creep, max_evals, seed, refine, chains, progress=None):
    """Annealing over z = (tau, log10 l_j) with the linear parameters projected out."""
    red = ReducedProblem(ps, gs, dts, n_ops, p_max, n_creep)
    z0 = np.array([0.3] + list(np.linspace(red.upper[-1] - 1, red.lower[-1] + 1, n_creep)) if n_creep else [0.3])
    counters = [_core.sensor.Counter() for _ in range(chains)]

    def chain(k):
        return _core.sensor.anneal_separable(red.sp, z0, red.lower, red.upper, int(max_evals), 0.5, 1e-3,
                                             int(seed) + k, counters[k])

    results = _run_chains(chain, chains, chains * int(max_evals), progress, counters)
    res = min(results, key=lambda r: r["sse_n"])
    z = np.asarray(res["x"])
    evals = sum(int(r["evaluations"]) for r in results)
    details = {"anneal_sse_n": float(res["sse_n"]), "chains": chains, "space": "tau, log10 l (linear part exact)",
               "chain_sse_n": [float(r["sse_n"]) for r in results],
               "acceptance": res["accepted"] / max(1, int(res["evaluations"]))}
    if refine:
        cost, z_ref = red.refine(z)
        if cost < red(z)[0]:
            z = z_ref
    cost, theta = red(z)
    details["constrained_solves"] = red.constrained
    return theta, evals + red.evals, details


def _anneal_full(ps, gs, dts, n_ops, p_max, n_creep, max_evals, seed, refine, chains, progress=None):
    """The thesis' literal method: annealing over all parameters (scaled, creep rates in log10)."""
    import nlopt

    x0, lo, hi, scale, log10 = annealing_space(ps, dts, n_creep)
    counters = [_core.sensor.Counter() for _ in range(chains)]

    def chain(k):  # the C++ annealing releases the GIL: chains run on separate cores
        return _core.sensor.anneal_fit(ps, gs, dts, n_ops, p_max, x0, lo, hi, scale, log10,
                                       int(max_evals), 1.0, 1e-3, int(seed) + k, counters[k])

    results = _run_chains(chain, chains, chains * int(max_evals), progress, counters)
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

"""Sensor-model benchmark (docs/spec.md §10): ``python -m psmat.bench sensor [--quick] [--seed K]``.

1. Throughput of the C++ direct and inverse MPI + creep model on 256 cells, beside a NumPy
   implementation vectorised over cells (a Python loop over samples) run in the same process
   (:mod:`psmat.bench.baselines.sensor_numpy`).
2. Identification on the full descending + ascending hysteresis protocols (docs/spec.md §4, 10
   repetitions each, 2 Hz) of a simulated cell (thesis model + 0.5 % noise): variable
   projection, simulated annealing (C++, one chain per core) + NLopt over the reduced
   problem (tau, creep rates; linear parameters exact) and over all 9 parameters (the
   thesis' literal method), and ``scipy.optimize.dual_annealing`` on each of those two
   objectives and boxes, each with its wall time and SSE_N relative to the best SSE_N
   found in the run. ``--seed`` seeds the annealers (C++ and scipy); the data stay the same,
   so runs with different seeds show how far the annealing's result depends on its seed.
"""

from __future__ import annotations

import argparse
import json
import sys
import time

import numpy as np

from .baselines.sensor_numpy import direct_numpy, inverse_numpy
from .machine import machine_info

__all__ = ["main", "run", "identification_data"]


def _throughput(quick: bool, log) -> list[dict]:
    from ..sensor import MPICreep

    m = MPICreep.thesis()
    rng = np.random.default_rng(0)
    T = 400 if quick else 4000
    p = np.repeat(rng.uniform(0, 32, (T // 10, 256)), 10, axis=0)
    rows = []

    def timed(fn, *a):
        t0 = time.perf_counter()
        out = fn(*a)
        return out, time.perf_counter() - t0

    g, t_d = timed(m.direct, p, 0.5)
    p_back, t_i = timed(m.inverse, g, 0.5)
    n = min(T, 200 if quick else 1000)
    g_np, t_dn = timed(direct_numpy, m, p[:n], 0.5)
    p_np, t_in = timed(inverse_numpy, m, g[:n], 0.5)
    rows.append(dict(kernel="direct", impl="psmat C++ (1 thread)", cell_samples_per_s=p.size / t_d,
                     check=f"|g - g_numpy| max {np.max(np.abs(g[:n] - g_np)):.1e} S"))
    rows.append(dict(kernel="direct", impl="NumPy, vectorised over cells", cell_samples_per_s=p[:n].size / t_dn, check=""))
    rows.append(dict(kernel="inverse", impl="psmat C++ (1 thread)", cell_samples_per_s=p.size / t_i,
                     check=f"|p - inverse(direct(p))| max {np.max(np.abs(p_back - p)):.1e} psi"))
    rows.append(dict(kernel="inverse", impl="NumPy bisection, vectorised over cells", cell_samples_per_s=p[:n].size / t_in,
                     check=f"|p - p_numpy| max {np.max(np.abs(p_np - p[:n])):.1e} psi"))
    for r_ in rows:
        log(f"  {r_['kernel']:<8} {r_['impl']:<42} {r_['cell_samples_per_s']:.3g} cell-samples/s  {r_['check']}")
    return rows


def identification_data(quick: bool = False) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """The identification data: descending and ascending protocols (psi) at 2 Hz and the
    thesis cell's conductances (S) with 0.5 % noise, fixed whatever the annealing seed."""
    from ..sensor import MPICreep, protocols

    reps = 2 if quick else 10
    true = MPICreep.thesis()
    rng = np.random.default_rng(1)
    ps = [protocols.descending_hysteresis(repetitions=reps).p_psi, protocols.ascending_hysteresis(repetitions=reps).p_psi]
    gs = [(g := true.direct(p, 0.5)) * (1 + 0.005 * rng.standard_normal(g.shape)) for p in ps]
    return ps, gs


def _identification(quick: bool, seed: int, log) -> tuple[list[dict], dict]:
    from scipy.optimize import dual_annealing

    from .. import _core
    from ..sensor import MPICreep, ReducedProblem, annealing_space, fit

    reps = 2 if quick else 10
    true = MPICreep.thesis()
    ps, gs = identification_data(quick)
    data = dict(samples=[len(p) for p in ps], hours=sum(len(p) for p in ps) * 0.5 / 3600)
    log(f"  data: descending + ascending x{reps} at 2 Hz: {data['samples']} samples ({data['hours']:.2f} h), 0.5 % noise")
    rows = []
    evals = 1000 if quick else 3000
    evals_full = 6000 if quick else 30000

    res = fit(ps, gs, 0.5, method="varpro")
    rows.append(dict(method="varpro (grid + NLopt BOBYQA)", sse_n=res.sse_n, seconds=res.wall_time_s, evaluations=res.evaluations))
    res = fit(ps, gs, 0.5, method="anneal", seed=seed, max_evals=evals)
    chains = res.details["chains"]
    rows.append(dict(method=f"anneal C++ reduced ({chains} chains x {evals}) + BOBYQA", sse_n=res.sse_n,
                     seconds=res.wall_time_s, evaluations=res.evaluations))
    res = fit(ps, gs, 0.5, method="anneal_full", seed=seed, max_evals=evals_full)
    rows.append(dict(method=f"anneal C++ all 9 ({chains} chains x {evals_full}) + BOBYQA", sse_n=res.sse_n,
                     seconds=res.wall_time_s, evaluations=res.evaluations))

    # scipy's dual_annealing on the same two objectives and boxes, same budgets
    red = ReducedProblem(ps, gs, [0.5, 0.5], 6, 32.0, 2)
    t0 = time.perf_counter()
    da = dual_annealing(lambda z: np.log(red(z)[0]), list(zip(red.lower, red.upper)), maxfun=chains * evals, seed=seed)
    rows.append(dict(method=f"scipy dual_annealing reduced (maxfun {chains * evals})", sse_n=float(np.exp(da.fun)),
                     seconds=time.perf_counter() - t0, evaluations=red.evals))

    x0, lo, hi, scale, log10 = annealing_space(ps, [0.5, 0.5], 2)
    count = 0

    def objective(x):
        nonlocal count
        count += 1
        th = np.asarray(_core.sensor.theta_from_x(np.asarray(x), scale, log10))
        m = MPICreep(*th[:5], l=th[5:7], w=th[7:])
        if m.invertibility_problem():
            return 1e3
        return float(np.log(np.mean(_core.sensor.sse_n_each(th, ps, gs, [0.5, 0.5], 6, 32.0))))

    t0 = time.perf_counter()
    da = dual_annealing(objective, list(zip(lo, hi)), x0=x0, maxfun=chains * evals_full, seed=seed)
    rows.append(dict(method=f"scipy dual_annealing all 9 (maxfun {chains * evals_full})", sse_n=float(np.exp(da.fun)),
                     seconds=time.perf_counter() - t0, evaluations=count))
    best = min(r_["sse_n"] for r_ in rows)
    for r_ in rows:
        r_["vs_best"] = r_["sse_n"] / best - 1
        log(f"  {r_['method']:<58} SSE_N {r_['sse_n']:.5g} S^2 (+{100 * r_['vs_best']:.2f} % vs best)  "
            f"{r_['seconds']:.1f} s, {r_['evaluations']} evaluations")
    data["noise_floor_sse_n"] = float(np.mean([np.mean((0.005 * true.direct(p, 0.5)) ** 2) for p in ps]))
    log(f"  noise floor (mean of (0.5 % g)^2): {data['noise_floor_sse_n']:.5g} S^2")
    return rows, data


def run(quick: bool = False, seed: int = 0, log=print) -> dict:
    """Run the benchmark (module docstring); ``seed`` seeds the annealers. Returns the figures."""
    info = machine_info()
    log(f"sensor model benchmark - machine: {info.get('cpu', '?')}, {info.get('usable_cpus', '?')} cores; "
        f"annealing seed {seed}")
    log("throughput (256 cells):")
    thr = _throughput(quick, log)
    log("identification:")
    ident, data = _identification(quick, seed, log)
    return {"machine": info, "seed": seed, "throughput": thr, "identification": ident, "data": data}


def build_parser(prog: str = "python -m psmat.bench sensor") -> argparse.ArgumentParser:
    """The benchmark's options (its help: this module's docstring, every default and unit)."""
    from .._help import HelpFormatter, plain

    ap = argparse.ArgumentParser(prog=prog, description=plain(__doc__), formatter_class=HelpFormatter)
    ap.add_argument("--quick", action="store_true", help="small data and budgets (about a minute)")
    ap.add_argument("--seed", type=int, default=0, help="seed of the annealers, C++ and scipy; "
                    "the data do not change with it")
    ap.add_argument("--json", metavar="PATH", help="also write the figures to this JSON file")
    ap.add_argument("--overwrite", action="store_true", help="replace an existing --json file")
    return ap


def main(argv: list[str] | None = None, prog: str = "python -m psmat.bench sensor") -> int:
    ap = build_parser(prog)
    args = ap.parse_args(argv)
    if args.seed < 0:
        ap.error(f"--seed must be >= 0, got {args.seed}")
    from .._atomic import OutputRefused, check_outputs, open_atomic

    try:  # before any work: an existing file only with --overwrite
        check_outputs([args.json], overwrite=args.overwrite)
    except OutputRefused as exc:
        print(f"{prog}: {exc}", file=sys.stderr)
        return 1
    t_start = time.perf_counter()
    res = run(quick=args.quick, seed=args.seed)
    print(f"wall time of the whole benchmark: {time.perf_counter() - t_start:.0f} s")
    if args.json:
        with open_atomic(args.json, "w") as f:
            json.dump(res, f, indent=1, default=float)
    return 0

"""Strong scaling of a study run (docs/spec.md §10, §12): ``python -m psmat.bench study --scaling 2,4,8,16 [--dask]``.

The same simulated study is run from scratch once per worker count — ``results/`` (with the
session cache under it) removed before each run and joblib's process pool shut down, so every
run computes every session and starts its own workers — first on this machine's pool
(:func:`psmat.study.run_study` with ``workers=n``), then with ``dask=True`` on a Dask
``distributed.LocalCluster(n_workers=n, threads_per_worker=1, processes=True)`` on 127.0.0.1
(``run_study(scheduler=address)``), started before its run's clock (its start is recorded apart)
and closed after it. Its workers start with Dask's environment, glibc's malloc set as in the
pool's workers (:func:`worker_environ`: with Dask's own setting, sessions took ~10 % longer than
in the pool).

For each run: its wall time (s, this process's clock around ``run_study``), its CPU time (s, the
stages of its ``results/timings.csv`` summed: the session, page and figure tasks' CPU in their
workers plus this process's), the speed-up over the first (smallest) count of the same kind,
the parallel efficiency = speed-up / (n / n_first), and the serial part (the wall time less the
session stage's). Over each kind's runs the least-squares fit T(n) = S + P/n gives the serial
seconds S, the parallel seconds P and S's share of the largest count's run. The goal of
docs/spec.md §10 (from 2 to 16 workers at least 80 % parallel efficiency) is marked met or
MISSED when the counts hold 2 and 16. ``metrics.csv`` must be byte-identical across all runs;
a difference is a problem line. Each run prints one line as it ends (``run done: ...``, flushed:
with when its first session started and how far apart its workers' last sessions ended),
so that a benchmark stopped half-way, on a machine lent for a few minutes, keeps what it measured.
"""

from __future__ import annotations

import contextlib
import hashlib
import os
import shutil
import time
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import Any

from .._cpus import usable_cpus

__all__ = ["parse_counts", "fit_serial_parallel", "stage_times", "first_and_second_cpu", "run_scaling",
           "format_scaling", "worker_environ", "local_cluster", "GOAL"]

#: docs/spec.md §10: from 2 to 16 workers at least 80 % parallel efficiency
GOAL = (2, 16, 0.80)
KINDS = {"pool": "pool", "dask": "Dask LocalCluster"}


def parse_counts(text: str) -> list[int]:
    """``"2,4,8,16"`` as worker counts, smallest first.

    Raises
    ------
    ValueError
        A count that is not a whole number of at least 1, a count given twice, or none.
    """
    parts = [p.strip() for p in text.split(",")]
    try:
        counts = [int(p) for p in parts]
    except ValueError:
        raise ValueError(f"--scaling takes worker counts separated by commas, such as 2,4,8,16, not {text!r}") \
            from None
    if not counts or min(counts) < 1:
        raise ValueError(f"--scaling: every worker count must be at least 1 (got {text})")
    if len(set(counts)) != len(counts):
        raise ValueError(f"--scaling: a worker count is given twice ({text})")
    return sorted(counts)


def fit_serial_parallel(counts: Sequence[int], times_s: Sequence[float]) -> tuple[float, float]:
    """Least-squares fit of ``T(n) = S + P / n`` to wall times measured at worker counts ``n``.

    Parameters
    ----------
    counts : sequence of int
        Worker counts of the runs.
    times_s : sequence of float
        Their wall times (s).

    Returns
    -------
    (S, P) : tuple of float
        The serial seconds S (what no worker count shortens) and the parallel seconds P (one
        worker's share of the work that splits), in s; from two counts the exact solution.

    Raises
    ------
    ValueError
        Fewer than two different counts, or lengths that differ.
    """
    if len(counts) != len(times_s):
        raise ValueError("one time per worker count")
    if len(set(counts)) < 2:
        raise ValueError("the fit T(n) = S + P/n needs runs at two different worker counts at least")
    x = [1.0 / n for n in counts]
    mx, my = sum(x) / len(x), sum(times_s) / len(times_s)
    sxx = sum((xi - mx) ** 2 for xi in x)
    p = sum((xi - mx) * (yi - my) for xi, yi in zip(x, times_s)) / sxx
    return my - p * mx, p


def stage_times(path: Path) -> dict[str, dict[str, float]]:
    """The stages of a run's ``timings.csv``: ``{stage: {"wall_s": s, "cpu_s": s}}``."""
    import csv

    with path.open(newline="", encoding="utf-8") as f:
        return {r["stage"]: {"wall_s": float(r["wall_s"]), "cpu_s": float(r["cpu_s"])} for r in csv.DictReader(f)}


def _sessions_by_worker(path: Path) -> dict[str, list[tuple[float, float, float]]]:
    """A run's computed sessions from its ``session_timings.csv``, by worker (its address on a
    cluster, else its pid): ``(start_s, wall_s, cpu_s)`` each, in the order they started."""
    import csv

    by_worker: dict[str, list[tuple[float, float, float]]] = {}
    with path.open(newline="", encoding="utf-8") as f:
        for r in csv.DictReader(f):
            if r["result"] == "computed" and r["start_s"] and r["wall_s"] and r["cpu_s"]:
                by_worker.setdefault(r["worker"] or r["pid"], []).append(
                    (float(r["start_s"]), float(r["wall_s"]), float(r["cpu_s"])))
    for runs in by_worker.values():
        runs.sort()
    return by_worker


def session_spread(path: Path) -> tuple[float, float] | None:
    """From a run's ``session_timings.csv``: when its first session started (s after the run
    began: the pool's or cluster's start-up) and how far apart its workers' last sessions ended
    (s: the tail an order of the sessions leaves); None without computed sessions."""
    by_worker = _sessions_by_worker(path)
    if not by_worker:
        return None
    last = [max(start + wall for start, wall, _ in runs) for runs in by_worker.values()]
    return min(runs[0][0] for runs in by_worker.values()), max(last) - min(last)


def first_and_second_cpu(path: Path) -> tuple[float, float | None, int] | None:
    """From a run's ``session_timings.csv``: the mean CPU time (s) of each worker's first session and
    of its second (None when no worker ran two), and how many worker processes ran sessions; None
    without computed sessions. A worker's first session pays what is loaded or allocated once per
    process; with more workers it is a larger share of the sessions (a 16-worker run of 126
    sessions: 1 in 8, a 2-worker run: 1 in 63), so a per-session CPU time that grows with the count
    may be that, not the machine. The second sessions are the measure: the run hands out the most
    expected work first (:mod:`psmat.study` (``_order.py``)), so a worker's first two sessions are
    alike, and its later ones cheaper (the thesis-size study on the 2-core machine, 2 workers: the
    first sessions 3.33 and 3.61 s, the second 3.07 and 3.30 s, all rotation trials; the mean of
    all later ones 2.41 s). More processes than workers means workers were replaced during the
    run (joblib's loky replaces one whose memory grew 300 MB past its size after its first task),
    each replacement paying its start again."""
    by_worker = _sessions_by_worker(path)
    if not by_worker:
        return None
    first = [runs[0][2] for runs in by_worker.values()]
    second = [runs[1][2] for runs in by_worker.values() if len(runs) > 1]
    return sum(first) / len(first), (sum(second) / len(second) if second else None), len(by_worker)


def _stop_pool() -> None:
    """Shut joblib's reusable loky executor, so the next run starts its own workers as a first run
    does (otherwise a run would find the previous run's workers started, their imports done)."""
    try:
        from joblib.externals.loky import reusable_executor
    except ImportError:  # pragma: no cover - joblib is a psmat requirement
        return
    executor = getattr(reusable_executor, "_executor", None)
    if executor is not None:
        executor.shutdown(wait=True)


def _one_run(root: Path, kind: str, n: int, scheduler: str | None, progress: bool) -> dict[str, Any]:
    """One run from scratch: its times, its counts and its ``metrics.csv`` (bytes and SHA-256)."""
    from ..study import run_study

    shutil.rmtree(root / "results", ignore_errors=True)
    t0 = time.perf_counter()
    if scheduler is None:
        report = run_study(root, workers=n, progress=progress)
    else:
        report = run_study(root, scheduler=scheduler, progress=progress)
    wall = time.perf_counter() - t0
    stages = stage_times(root / "results" / "timings.csv")
    cpu = sum(s["cpu_s"] for s in stages.values())
    metrics = report.metrics.read_bytes()
    spread = session_spread(root / "results" / "session_timings.csv")
    split = first_and_second_cpu(root / "results" / "session_timings.csv")
    return {"kind": kind, "workers": n, "wall_s": wall, "cpu_s": cpu if cpu > 0 else None,
            "first_session_s": None if spread is None else spread[0],
            "tail_s": None if spread is None else spread[1],
            "first_cpu_s": None if split is None else split[0], "second_cpu_s": None if split is None else split[1],
            "processes": None if split is None else split[2],
            "serial_s": max(0.0, wall - stages["sessions"]["wall_s"]), "stages": stages,
            "sessions": report.sessions, "computed": report.computed, "reused": report.reused, "failed": report.failed,
            "problems": list(report.problems), "metrics_sha256": hashlib.sha256(metrics).hexdigest(),
            "_metrics": metrics}


def worker_environ() -> dict[str, Any]:
    """The environment the bench's Dask workers start with: Dask's own (``distributed.nanny.
    pre-spawn-environ``: one BLAS/OpenMP thread) with glibc's malloc set as psmat's own pool
    workers set it (:data:`psmat._malloc.ENVIRONMENT`: freed memory kept for the next task).

    Dask sets ``MALLOC_TRIM_THRESHOLD_=65536``, which also turns off glibc's adaptive mmap
    threshold, so every temporary array above 128 KiB is mapped and unmapped again; a study's
    sessions then took ~10 % longer on a Dask worker than in the process pool (3 volunteers x 3
    trials x 60 s, one worker, this project's 2-core machine: 2.75-2.90 s a session against
    2.52-2.64 s; without the variable 2.46-2.48 s; with it set to 128 MiB still 2.75-2.80 s, the
    mmap threshold staying at 128 KiB). The pool's workers keep freed memory since; these
    variables do the same in a process that starts with them.
    """
    import dask

    from .._malloc import ENVIRONMENT

    env = dict(dask.config.get("distributed.nanny.pre-spawn-environ", default={}) or {})
    env.update(ENVIRONMENT)
    return env


@contextlib.contextmanager
def local_cluster(n: int) -> Iterator[Any]:
    """A LocalCluster of ``n`` single-threaded worker processes on 127.0.0.1, started with
    :func:`worker_environ`, closed on exit."""
    import logging

    import dask
    import distributed

    from .._malloc import ENVIRONMENT

    # A worker's environment is this process's os.environ over its nanny's pre-spawn environment,
    # and a nanny writes that environment into os.environ: a cluster started here earlier with
    # Dask's defaults leaves MALLOC_TRIM_THRESHOLD_ behind, which would win over worker_environ's.
    # The malloc variables are taken out of os.environ while this cluster lives, and this
    # process's own put back after it (removed where it had none).
    saved = {k: os.environ.pop(k, None) for k in ENVIRONMENT}
    try:
        with dask.config.set({"distributed.nanny.pre-spawn-environ": worker_environ()}):
            # the scheduler's HTTP server (health, metrics; no dashboard) on a free loopback port: its
            # default, 8787, is taken when two clusters start at once (a warning; an error in the tests)
            with distributed.LocalCluster(n_workers=n, threads_per_worker=1, processes=True, host="127.0.0.1",
                                          dashboard_address=None,
                                          scheduler_kwargs={"dashboard_address": "127.0.0.1:0"},
                                          silence_logs=logging.ERROR) as cluster:
                yield cluster
    finally:
        for k, v in saved.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v


def _dask_run(root: Path, n: int, progress: bool) -> dict[str, Any]:
    """One run on a fresh LocalCluster of ``n`` single-threaded worker processes (:func:`local_cluster`),
    closed after it."""
    t0 = time.perf_counter()
    with local_cluster(n) as cluster:
        started = time.perf_counter() - t0
        run = _one_run(root, "dask", n, cluster.scheduler_address, progress)
    run["cluster_start_s"] = started
    return run


def _rate(runs: list[dict[str, Any]]) -> None:
    """Speed-up and efficiency of each run against the first of the list (same kind)."""
    first = runs[0]
    for r in runs:
        r["speedup"] = first["wall_s"] / r["wall_s"]
        r["efficiency"] = r["speedup"] / (r["workers"] / first["workers"])


def _fit(runs: list[dict[str, Any]]) -> dict[str, float] | None:
    if len(runs) < 2:
        return None
    s, p = fit_serial_parallel([r["workers"] for r in runs], [r["wall_s"] for r in runs])
    return {"serial_s": s, "parallel_s": p, "serial_share_at_largest": s / runs[-1]["wall_s"]}


def _goal(runs: list[dict[str, Any]]) -> float | None:
    """Efficiency from 2 to 16 workers (docs/spec.md §10) when both were run, else None."""
    lo, hi, _ = GOAL
    by = {r["workers"]: r["wall_s"] for r in runs}
    if lo not in by or hi not in by:
        return None
    return (by[lo] / by[hi]) / (hi / lo)


def _metrics_check(runs: list[dict[str, Any]]) -> list[str]:
    """Problem lines: each run whose ``metrics.csv`` differs from the first run's (first differing line)."""
    first = runs[0]
    problems = []
    for r in runs[1:]:
        if r["_metrics"] == first["_metrics"]:
            continue
        a, b = first["_metrics"].splitlines(), r["_metrics"].splitlines()
        line = next((i + 1 for i, (x, y) in enumerate(zip(a, b)) if x != y), min(len(a), len(b)) + 1)
        problems.append(f"metrics.csv of {_name(r)} differs from {_name(first)}'s (first at line {line})")
    return problems


def _said(r: dict[str, Any]) -> dict[str, Any]:
    """``r``, once its line is printed (flushed: a long benchmark stopped half-way keeps the runs it made)."""
    spread = "" if r.get("tail_s") is None else \
        (f"; first session at {r['first_session_s']:.2f} s, the workers' last sessions ended "
         f"{r['tail_s']:.2f} s apart")
    print(f"run done: {_name(r)}: {r['wall_s']:.2f} s wall, serial part {r['serial_s']:.2f} s, "
          f"{r['computed']} sessions computed{spread}", flush=True)
    return r


def _first_second(r: dict[str, Any]) -> str:
    """`` (16 processes; a worker's first session 4.41 s, its second 3.52 s)`` of a run
    (:func:`first_and_second_cpu`), or ""."""
    if r.get("first_cpu_s") is None:
        return ""
    second = "" if r.get("second_cpu_s") is None else f", its second {r['second_cpu_s']:.2f} s"
    n = r.get("processes")
    return f" ({n} process{'es' if n != 1 else ''}; a worker's first session {r['first_cpu_s']:.2f} s{second})"


def _name(r: dict[str, Any]) -> str:
    return f"{KINDS[r['kind']]}, {r['workers']} worker{'s' if r['workers'] != 1 else ''}"


def run_scaling(root: str | os.PathLike[str], counts: Sequence[int], dask: bool = False,
                progress: bool = True, pool: bool = True, load_probe: bool = True) -> dict[str, Any]:
    """Run the study in ``root`` from scratch at each worker count, on the pool and with ``dask``
    on a LocalCluster; the runs, fits, goal and checks as plain data (:func:`format_scaling`).

    Parameters
    ----------
    root : path
        A study folder (:func:`psmat.study.find_study`); its ``results/`` is removed before each run.
    counts : sequence of int
        Worker counts, run in the order given (the first is the reference of speed-up and efficiency).
    dask : bool
        Also run each count on a Dask LocalCluster (skipped, with a note, without Dask distributed).
    progress : bool
        The runs' progress bars (on stderr).
    pool : bool
        False: the LocalCluster's runs only (with ``dask``), say to measure the two kinds in two
        sittings on a machine lent for a few minutes.
    load_probe : bool
        First measure how much slower one session runs with each count of processes at once
        (:func:`psmat.bench.load_probe.probe_load`: the machine's own ceiling), under ``"load"``.
    """
    root = Path(root)
    counts = list(counts)
    cpus = usable_cpus()
    out: dict[str, Any] = {"counts": counts, "usable_cpus": cpus, "problems": []}
    if not pool and not dask:
        raise ValueError("nothing to run: the pool's runs left out and no Dask runs asked for")
    if load_probe:
        from ..study import find_study
        from .load_probe import format_probe, probe_load
        from .study_task import session_args

        out["load"] = probe_load(session_args(find_study(root))[0], counts)
        print("\n".join(format_probe(out["load"])), flush=True)
    kinds = {}
    if pool:
        runs = []
        for n in counts:
            _stop_pool()
            runs.append(_said(_one_run(root, "pool", n, None, progress)))
        _stop_pool()
        kinds["pool"] = runs
    if dask:
        try:
            import distributed  # noqa: F401
        except ImportError:
            out["dask_skipped"] = "Dask distributed is not installed (pip install 'psmat[cluster]')"
        else:
            kinds["dask"] = [_said(_dask_run(root, n, progress)) for n in counts]
    runs = [r for rs in kinds.values() for r in rs]
    for kind, rs in kinds.items():
        _rate(rs)
        out[f"{kind}_fit"] = _fit(rs)
        out[f"{kind}_goal_efficiency"] = _goal(rs)
    for r in runs:
        if r["computed"] != r["sessions"] or r["failed"]:
            out["problems"].append(f"{_name(r)}: {r['computed']} sessions computed, {r['reused']} reused, "
                                   f"{r['failed']} failed (every session should be computed)")
    out["problems"] += _metrics_check(runs)
    out["metrics_identical"] = all(r["_metrics"] == runs[0]["_metrics"] for r in runs)
    out["runs"] = [{k: v for k, v in r.items() if not k.startswith("_")} for r in runs]
    return out


def _f(x: float | None, spec: str) -> str:
    return "—" if x is None else format(x, spec)


def format_scaling(s: dict[str, Any], sessions: int | None = None) -> str:
    """The scaling runs as a Markdown table, then the fits, the goal and the checks."""
    runs = s["runs"]
    lines = ["", "strong scaling: each run from scratch (results/ and its session cache removed, a new pool or "
             "cluster); speed-up and efficiency against the first count of the same kind",
             "",
             "| run | workers | wall time (s) | CPU time (s) | speed-up | efficiency | serial part (s) | serial % |",
             "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: |"]
    for r in runs:
        lines.append(f"| {KINDS[r['kind']]} | {r['workers']} | {r['wall_s']:.2f} | {_f(r['cpu_s'], '.2f')} | "
                     f"{r['speedup']:.2f} | {r['efficiency']:.2f} | {r['serial_s']:.2f} | "
                     f"{100 * r['serial_s'] / r['wall_s']:.1f} % |")
    lines.append("")
    over = [n for n in s["counts"] if n > s["usable_cpus"]]
    if over:
        lines.append(f"warning: {', '.join(map(str, over))} workers exceed the {s['usable_cpus']} CPUs this process "
                     "may use: their efficiency measures oversubscription, not scaling")
    if sessions is not None and s["counts"][-1] > sessions:
        lines.append(f"note: the pool runs at most one process per session ({sessions} sessions here)")
    if "dask_skipped" in s:
        lines.append(f"Dask: skipped, {s['dask_skipped']}")
    kinds = [k for k in KINDS if f"{k}_fit" in s]
    for kind in kinds:
        fit = s[f"{kind}_fit"]
        if fit is None:
            lines.append(f"{KINDS[kind]}: fit T(n) = S + P/n needs two worker counts at least")
        else:
            lines.append(f"{KINDS[kind]}: least-squares fit T(n) = S + P/n: S = {fit['serial_s']:.2f} s, "
                         f"P = {fit['parallel_s']:.2f} s; S is {100 * fit['serial_share_at_largest']:.1f} % of "
                         f"the {s['counts'][-1]}-worker run")
    lo, hi, target = GOAL
    for kind in kinds:
        eff = s[f"{kind}_goal_efficiency"]
        if eff is not None:
            lines.append(f"{KINDS[kind]}: docs/spec.md §10 goal, from {lo} to {hi} workers >= {target:.0%} parallel "
                         f"efficiency: {eff:.2f} ({'met' if eff >= target else 'MISSED'})")
        else:
            mine = [r for r in runs if r["kind"] == kind]
            lines.append(f"{KINDS[kind]}: {lo}->{hi} goal not measured here: counts "
                         f"{','.join(map(str, s['counts']))}; efficiency at {mine[-1]['workers']} workers against "
                         f"{mine[0]['workers']}: {mine[-1]['efficiency']:.2f}")
    per = [f"{KINDS[r['kind']]} {r['workers']}: {r['stages']['sessions']['cpu_s'] / r['computed']:.2f} s"
           + _first_second(r) for r in runs if r.get("stages") and r.get("computed")]
    if per:
        lines.append(f"the session tasks' CPU time per session (s, in their workers): {', '.join(per)}")
    if s.get("load") is not None:
        from .load_probe import format_probe

        lines += format_probe(s["load"])
        ceiling = s["load"]["ceiling"].get(hi) if s["load"]["runs"][0]["processes"] == lo else None
        for kind in kinds:
            eff = s[f"{kind}_goal_efficiency"]
            if eff is not None and ceiling is not None:
                lines.append(f"{KINDS[kind]}: {lo}->{hi} efficiency {eff:.2f} against this machine's ceiling "
                             f"{ceiling:.2f}: {eff / ceiling:.2f} of what its cores under load allow")
    if "dask" in kinds and "pool" in kinds:
        by = {r["workers"]: r["wall_s"] for r in runs if r["kind"] == "pool"}
        ratios = ", ".join(f"{n}: {by[n] / r['wall_s']:.2f}" for r in runs if r["kind"] == "dask"
                           for n in [r["workers"]])
        lines.append(f"Dask LocalCluster speed-up over the pool at the same count: {ratios} "
                     "(its cluster's start is not in its time)")
    if s["metrics_identical"]:
        lines.append(f"metrics.csv byte-identical across all {len(runs)} runs "
                     f"(sha256 {runs[0]['metrics_sha256'][:16]}…)")
    lines += [f"problem: {p}" for p in s["problems"]]
    return "\n".join(lines)

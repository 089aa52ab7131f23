"""Balance-study benchmark (docs/spec.md §10, thesis-size study): ``python -m psmat.bench study``.

``python -m psmat.bench study [--volunteers 42] [--seconds 60] [--rate 100] [--workers 2 | --scaling 2,4,8,16]
[--dask | --dask-only] [--dir PATH] [--seed K] [--no-baseline] [--json PATH] [--quick]``

What is measured
----------------
A simulated balance study (:func:`psmat.synth.simulate_study`: three trials per
volunteer through mats the processing does not know; docs/spec.md §7) of the thesis' size by default —
42 volunteers × 3 trials × 60 s at 100 Hz = 756 000 frames, 16×16 — is processed end to end:

* **psmat** — :func:`psmat.study.run_study` with ``workers`` processes: every variant of
  docs/spec.md §7 (each session through the one chain, IECM on noisy frames, the inverse sensor
  model, eq. 3.3, the 8×8 emulation, alignment, metrics), the per-session result files,
  ``metrics.csv``, the summary, figures and report. The results folder is emptied first, so
  nothing is reused.
* **resume** — the same call again: every session is found finished (the cost of the cache).
* **baseline** — the thesis' approach: a plain ``multiprocessing.Pool(workers)`` mapping the
  same per-session function over the sessions, nothing written, in the same run.

**Where the time goes**: the run's own ``results/timings.csv`` (docs/spec.md §12) gives each
stage — before the sessions (finding the files, the keys), the session tasks, after the
sessions (SCHC-DYN, metrics.csv, summary, figures), the report — and the serial part, everything
but the session tasks, with its share of the run; a serial part that grows with the study
bounds what more cores can gain. The parallel fraction p (Amdahl) is estimated from the run:
the session tasks' CPU seconds summed over the workers against them plus the serial part's
wall time, with the speed-up that p allows on 16 cores. ``--quick`` runs a tiny study (1 volunteer, 4 s at 50 Hz).

**The order of the sessions** (:mod:`psmat.bench.study_order`): the run's own session times
replayed on 2, 4, 8 and 16 workers in the order it hands them out (the most expected work
first) beside the order before it (the largest file first), the longest first with the times
known, and the even split: when the last session would end in each.

The simulation itself is timed apart and is not part of the docs/spec.md §10 figure (≤ 180 s end to
end on 2 cores). ``--dir`` keeps the simulated study between runs (it is reused when it
holds the same number of sessions). The two figures are compared in the same process, on the
same machine, one after the other.

Strong scaling
--------------
``--scaling 2,4,8,16`` (instead of ``--workers``) simulates the study once, then runs it from
scratch at each worker count, smallest first (``results/`` and its session cache removed, a new
pool each time; no rerun and no baseline): per count its wall and CPU time, the speed-up over
the smallest count, the parallel efficiency (speed-up / (n / n_smallest)) and the serial part;
then the least-squares fit T(n) = S + P/n, and the goal of docs/spec.md §10 — from 2 to 16
workers at least 80 % parallel efficiency — marked met or MISSED when 2 and 16 were run.
``--dask`` runs the same counts on a Dask ``LocalCluster`` of single-threaded worker processes
(``psmat study run --scheduler``), one cluster per count, started before the clock and closed
after. ``metrics.csv`` must be byte-identical across every run; a count above this process's
CPUs is run but flagged, its efficiency then measuring oversubscription
(:mod:`psmat.bench.study_scaling`). ``--dask-only`` runs the LocalCluster's counts alone, so that
the two kinds can be measured in two sittings (``--dir`` keeps the study for the second).

Before the runs, a **load probe** (:mod:`psmat.bench.load_probe`; ``--no-load-probe`` skips it)
times one session processed by n processes at once, for each count n: the ratio of its time at
the smallest count to its time at n is the efficiency that this machine's cores under load allow
a perfectly parallel study, the ceiling beside which the runs' efficiency is read. The session
tasks' CPU time per session is printed for each run too. On a 16-core machine:

    python -m psmat.bench study --scaling 2,4,8,16 --dask
"""

from __future__ import annotations

import argparse
import json
import multiprocessing as mp
import shutil
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from .machine import machine_info
from .study_scaling import stage_times
from .study_task import process_one, session_args
from .study_order import format_orders, replay_orders

__all__ = ["main", "run", "parallel_fraction"]

TARGET_S = 180.0  # docs/spec.md §10: a thesis-size study in <= 180 s on 2 cores


def _frames(layout: Any) -> int:
    from ..io import load_session

    return sum(load_session(i.session).n_frames for i in layout.items)


def run(volunteers: int = 42, seconds: float = 60.0, rate_hz: float = 100.0, workers: int = 2, seed: int = 0,
        study_dir: str | None = None, baseline: bool = True, scaling: list[int] | None = None,
        dask: bool = False, pool: bool = True, load_probe: bool = True) -> dict[str, Any]:
    """Simulate (or reuse) a study and time its processing; the figures as a dict. With
    ``scaling`` (worker counts) its runs at each count instead (``workers`` and ``baseline``
    unused; ``dask``: on a LocalCluster too, and with ``pool`` False only there; ``load_probe``: the
    machine's ceiling measured first), under ``"scaling"`` (:func:`psmat.bench.study_scaling.run_scaling`)."""
    from ..study import find_study
    from ..study import run_study
    from ..synth import simulate_study

    tmp = None
    if study_dir is None:
        tmp = tempfile.mkdtemp(prefix="psmat-bench-study-")
        root = Path(tmp) / "study"
    else:
        root = Path(study_dir)
    try:
        out: dict[str, Any] = {"volunteers": volunteers, "seconds": seconds, "rate_hz": rate_hz, "workers": workers,
                               "seed": seed, "machine": machine_info()}
        reuse = (root / "sessions").is_dir() and len(list((root / "sessions").glob("*.h5"))) == 3 * volunteers
        t0 = time.perf_counter()
        if not reuse:
            if root.exists():
                raise SystemExit(f"{root} exists and does not hold a {volunteers}-volunteer study; give another --dir")
            simulate_study(root, volunteers=volunteers, duration_s=seconds, seed=seed, rate_hz=rate_hz, progress=True)
        out["simulate_s"] = None if reuse else time.perf_counter() - t0
        layout = find_study(root)
        out["sessions"] = len(layout.items)
        out["frames"] = _frames(layout)
        if scaling is not None:
            from .study_scaling import run_scaling

            out["workers"] = None
            out["scaling"] = run_scaling(root, scaling, dask=dask, pool=pool, load_probe=load_probe)
            return out

        shutil.rmtree(root / "results", ignore_errors=True)
        t0 = time.perf_counter()
        report = run_study(root, workers=workers, progress=True)
        out["psmat_s"] = time.perf_counter() - t0
        out["stages"] = stage_times(root / "results" / "timings.csv")
        out["psmat_report"] = {"computed": report.computed, "reused": report.reused, "failed": report.failed}
        out["order"] = replay_orders(root)  # from this run's session times, before the rerun's replace them
        t0 = time.perf_counter()
        again = run_study(root, workers=workers, progress=False)
        out["resume_s"] = time.perf_counter() - t0
        out["resume_stages"] = stage_times(root / "results" / "timings.csv")
        out["resume_computed"] = again.computed

        if baseline:
            items = session_args(layout)
            t0 = time.perf_counter()
            with mp.get_context("spawn").Pool(workers) as pool:
                rows = sum(pool.map(process_one, items, chunksize=1))
                pool.close()  # the workers exit on their own (the with-block alone terminates them)
                pool.join()
            out["baseline_s"] = time.perf_counter() - t0
            out["baseline_rows"] = rows
        return out
    finally:
        if tmp is not None:
            shutil.rmtree(tmp, ignore_errors=True)


#: the bench's lines: (label, the stages of timings.csv it sums)
STAGE_LINES = (("before the sessions (files, keys)", ("discover", "keys")),
               ("sessions (tasks in the workers)", ("sessions",)),
               ("after the sessions (DYN, tables, figures)", ("reports", "after_sessions", "figures")),
               ("report (report.md)", ("report",)))


def stage_lines(r: dict[str, Any], key: str, total_s: float) -> list[str]:
    """Each stage's wall time of one run, and its serial part (all but the sessions) and share."""
    st = r[key]
    lines = [f"  {label:<42}{sum(st[s]['wall_s'] for s in names):>10.2f}" for label, names in STAGE_LINES]
    serial = max(0.0, total_s - st["sessions"]["wall_s"])
    lines.append(f"  {'serial part (all but the session tasks)':<42}{serial:>10.2f}"
                 f"{100 * serial / total_s if total_s > 0 else 0.0:>10.1f} %")
    if st["sessions"]["cpu_s"] > 0:
        lines.append(f"  {'sessions: CPU summed over the workers':<42}{st['sessions']['cpu_s']:>10.2f}")
        p = parallel_fraction(st["sessions"]["cpu_s"], serial)
        if p is not None:
            lines.append(f"  {'parallel fraction (Amdahl, from this run)':<42}{p:>10.3f}"
                         f"   (Amdahl: at most {1 / (1 - p + p / 16) if p < 1 else 16:.1f}x "
                         "on 16 cores)")
    return lines


def parallel_fraction(session_cpu_s: float, serial_s: float) -> float | None:
    """Amdahl's parallel fraction p of a run estimated from its own times: the session tasks'
    CPU seconds summed over the workers, ``session_cpu_s``, are the work that runs in parallel,
    the run's serial part ``serial_s`` (its wall time less the session stage's) the rest, so
    one core would take ``session_cpu_s + serial_s`` and ``p = session_cpu_s / (session_cpu_s +
    serial_s)``. An estimate: CPU time ignores a loaded machine's waiting in the sessions, while
    the serial part's wall time counts it. None without session work."""
    if session_cpu_s <= 0 or serial_s < 0:
        return None
    return session_cpu_s / (session_cpu_s + serial_s)


def _header(r: dict[str, Any]) -> list[str]:
    """The study, the machine and the simulation's time."""
    workers = f"{r['workers']} workers" if r.get("scaling") is None else \
        f"workers {','.join(map(str, r['scaling']['counts']))}"
    lines = [
        f"balance study (simulation): {r['volunteers']} volunteers x 3 trials x {r['seconds']:g} s at "
        f"{r['rate_hz']:g} Hz = {r['sessions']} sessions, {r['frames']} frames, 16x16; {workers}",
        f"machine: {r['machine']}",
    ]
    if r.get("simulate_s") is not None:
        lines.append(f"simulation (not part of the target): {r['simulate_s']:.1f} s")
    return lines


def format_report(r: dict[str, Any]) -> str:
    """The benchmark's figures as a plain-text table (with ``--scaling``, its scaling table)."""
    if r.get("scaling") is not None:
        from .study_scaling import format_scaling

        return "\n".join(_header(r)) + "\n" + format_scaling(r["scaling"], r["sessions"])
    frames = r["frames"]
    lines = _header(r)
    lines += [
        f"{'run':<44}{'time (s)':>10}{'frames/s':>11}",
        f"{'psmat study run (all variants, results written)':<44}{r['psmat_s']:>10.1f}{frames / r['psmat_s']:>11.0f}",
        *stage_lines(r, "stages", r["psmat_s"]),
        f"{'psmat study run again (every session reused)':<44}{r['resume_s']:>10.2f}{'':>11}",
        *stage_lines(r, "resume_stages", r["resume_s"]),
    ]
    if r.get("order") is not None:
        lines += format_orders(r["order"])
    if "baseline_s" in r:
        lines.append(f"{'baseline: multiprocessing.Pool over sessions':<44}{r['baseline_s']:>10.1f}"
                     f"{frames / r['baseline_s']:>11.0f}")
    scale = 756_000 / frames
    verdict = "met" if r["psmat_s"] * scale <= TARGET_S else "missed"
    lines.append(f"docs/spec.md §10 target: 756 000 frames in <= {TARGET_S:.0f} s on 2 cores; this run scaled to 756 000 "
                 f"frames: {r['psmat_s'] * scale:.0f} s ({verdict}{'' if scale == 1 else ', extrapolated linearly'})")
    return "\n".join(lines)


def build_parser(prog: str = "python -m psmat.bench study") -> argparse.ArgumentParser:
    """The benchmark's options (its help: this module's docstring, every default and unit)."""
    from .._help import HelpFormatter, plain

    p = argparse.ArgumentParser(prog=prog, description=plain(__doc__), formatter_class=HelpFormatter)
    p.add_argument("--volunteers", type=int, default=42, help="volunteers of the simulated study, 3 trials each")
    p.add_argument("--seconds", type=float, default=60.0, help="length of each trial (s)")
    p.add_argument("--rate", type=float, default=100.0, help="the mats' frame rate (Hz)")
    counts = p.add_mutually_exclusive_group()
    # default None, shown as 2: argparse would not see "--workers 2 --scaling ..." as a conflict if the value
    # given were the default object itself
    counts.add_argument("--workers", type=int, default=None,
                        help="processes, for psmat and for the baseline's pool (default: 2)")
    counts.add_argument("--scaling", metavar="N1,N2,...", default=None,
                        help="strong scaling instead of one run: the study from scratch at each worker count, "
                             "such as 2,4,8,16 (not with --workers; no rerun, no baseline)")
    p.add_argument("--dask", action="store_true",
                   help="with --scaling: the same counts on a Dask LocalCluster too (needs Dask distributed)")
    p.add_argument("--dask-only", action="store_true",
                   help="with --scaling: the LocalCluster's runs alone, without the pool's (to split a "
                        "measurement in two sittings)")
    p.add_argument("--no-load-probe", action="store_true",
                   help="with --scaling: skip the probe of how much slower one session runs with every count "
                        "of processes at once (the machine's own ceiling on efficiency; two sessions' time per "
                        "count)")
    p.add_argument("--seed", type=int, default=0, help="seed of the simulated study")
    p.add_argument("--dir", metavar="PATH", default=None,
                   help="keep the simulated study here, reused when it matches (default: a temporary folder)")
    p.add_argument("--no-baseline", action="store_true", help="skip the multiprocessing.Pool baseline")
    p.add_argument("--json", metavar="PATH", default=None, help="also write the figures to this JSON file")
    p.add_argument("--overwrite", action="store_true", help="replace an existing --json file")
    p.add_argument("--quick", action="store_true",
                   help="a tiny study: 1 volunteer, 4 s at 50 Hz, 1 worker (overrides those options)")
    return p


def main(argv: list[str] | None = None, prog: str = "python -m psmat.bench study") -> int:
    a = build_parser(prog).parse_args(argv)
    a.workers = 2 if a.workers is None else a.workers
    if a.quick:
        a.volunteers, a.seconds, a.rate, a.workers = 1, 4.0, 50.0, 1
    if a.volunteers < 1 or a.seconds <= 0 or a.rate <= 0 or a.workers < 1:
        print(f"{prog}: --volunteers, --seconds, --rate and --workers must be positive",
              file=sys.stderr)
        return 2
    scaling = None
    if a.scaling is not None:
        from .study_scaling import parse_counts

        try:
            scaling = parse_counts(a.scaling)
        except ValueError as exc:
            print(f"{prog}: {exc}", file=sys.stderr)
            return 2
    elif a.dask or a.dask_only:
        print(f"{prog}: --dask and --dask-only go with --scaling (the worker counts to run on a LocalCluster)",
              file=sys.stderr)
        return 2
    if a.dask_only:
        try:
            import distributed  # noqa: F401
        except ImportError:
            print(f"{prog}: --dask-only needs Dask distributed (pip install 'psmat[cluster]')", file=sys.stderr)
            return 2
    from .._atomic import OutputRefused, check_outputs, write_text_atomic

    try:  # before any work: an existing file only with --overwrite
        check_outputs([a.json], overwrite=a.overwrite)
    except OutputRefused as exc:
        print(f"{prog}: {exc}", file=sys.stderr)
        return 1
    r = run(a.volunteers, a.seconds, a.rate, a.workers, a.seed, a.dir, not a.no_baseline, scaling,
            a.dask or a.dask_only, not a.dask_only, not a.no_load_probe)
    print(format_report(r))
    if a.json:
        write_text_atomic(a.json, json.dumps(r, indent=2, default=str))
    return 0

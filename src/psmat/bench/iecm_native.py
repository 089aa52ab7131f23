"""The gain of ``-march=native``: the same IECM rows against two builds of psmat, in one run.

``python -m psmat.bench iecm --compare-native PORTABLE_PYTHON NATIVE_PYTHON [--sizes 16,32] [--quick]``
``python -m psmat.bench iecm --compare-simd [--sizes 32,64]``: this installation's dense kernels
capped at AVX2 (``PSMAT_SIMD=avx2``) against the widest vector unit it has and the CPU runs.

Each argument is the Python interpreter of an environment holding one build of psmat (the
default portable build, and one installed with ``PSMAT_NATIVE=ON``; README.md, *Installation*).
Every measurement runs :func:`psmat.bench.iecm.measure_psmat` in a child process of that
interpreter, so each build solves with its own compiled ``psmat._core``. The rows are the
streaming rows of the IECM benchmark per array size: noise-free G and noisy G (1 mV, 12 bits),
same frames (same seed), same threads. The two builds alternate, row by row, ``repeats``
times, and the median fps of each is reported, with the spread, so that a load change on the
machine affects both alike.
"""

from __future__ import annotations

import json
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

from .iecm_setup import HEAVY_CELLS, NOISY_LABEL, settings
from .machine import machine_info

__all__ = ["BUILDS", "SIMD_RUNS", "rows_for", "run_child", "compare", "format_comparison"]

#: Labels of the two builds, in the order of ``--compare-native``.
BUILDS = ("portable", "native")
#: ``--compare-simd``: label -> environment of the child (the same interpreter and build).
SIMD_RUNS = {"PSMAT_SIMD=avx2": {"PSMAT_SIMD": "avx2"}, "widest": {}}

# Runs in the child: one measure_psmat row as JSON on the last line of stdout, with where the
# package and its compiled core were imported from.
_CHILD = """
import json, sys, warnings
warnings.simplefilter("ignore")
import psmat, psmat._core
from psmat.bench.iecm import measure_psmat
row = measure_psmat(**json.loads(sys.argv[1]))
print(json.dumps({"row": row, "psmat": psmat.__file__, "core": psmat._core.__file__,
                  "version": psmat.__version__, "simd": psmat._core.iecm.simd_kernels()}))
"""


def rows_for(size: int, frames: int, threads: int, seed: int, min_time: float, budget: float) -> list[dict]:
    """Keyword arguments of :func:`psmat.bench.iecm.measure_psmat` for one array size.

    Parameters
    ----------
    size : int
        Array size N (N x N cells).
    frames : int
        Frames per streaming row.
    threads : int
        Threads of every row.
    seed : int
        Scene seed (same frames in both builds).
    min_time, budget : float
        Seconds of timed work per row, and its cap (s).
    """
    heavy = size * size > HEAVY_CELLS
    base = dict(size=size, mode="streaming", threads=threads, frames=frames, seed=seed, min_time=min_time,
                max_time=budget, warmup=not heavy, prime="truth" if heavy else "solve")
    return [dict(base, label="psmat newton"),
            dict(base, label=NOISY_LABEL, noise_v=1e-3, prime="solve")]


# Runs in the child: where psmat's compiled core is imported from, as JSON on the last line.
_PROBE = """
import json, psmat._core
print(json.dumps({"core": psmat._core.__file__}))
"""


def run_child(python: str, kwargs: dict | None, timeout: float, env_set: dict | None = None) -> dict:
    """One row measured by the psmat installed for ``python`` (a child process).

    Returns ``{"row": ..., "psmat": ..., "core": ..., "version": ..., "simd": ...}``; with
    ``kwargs`` None only ``{"core": ...}``, nothing measured. ``env_set``: variables set for the
    child (``PSMAT_SIMD``). Raises ``RuntimeError`` with the child's last error line when it
    fails or runs past ``timeout`` s.
    """
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PYTHONHOME", "PSMAT_SIMD")}
    env.update(env_set or {})
    args = [python, "-c", _PROBE] if kwargs is None else [python, "-c", _CHILD, json.dumps(kwargs)]
    with tempfile.TemporaryDirectory(prefix="psmat-bench-") as cwd:  # nothing importable from here
        try:
            out = subprocess.run(args, cwd=cwd, env=env, capture_output=True, text=True, timeout=timeout)
        except subprocess.TimeoutExpired:
            raise RuntimeError(f"{python}: no result within {timeout:.0f} s") from None
    if out.returncode != 0:
        last = (out.stderr.strip().splitlines() or [f"exit code {out.returncode}"])[-1]
        raise RuntimeError(f"{python}: {last}")
    return json.loads(out.stdout.strip().splitlines()[-1])


def compare(pythons: dict[str, str], sizes, frames: int | None, threads: int | None, *, quick: bool = False,
            repeats: int = 3, seed: int = 0, envs: dict[str, dict] | None = None, log=print) -> dict:
    """Measure the rows of :func:`rows_for` with every build, alternating, ``repeats`` times.

    Parameters
    ----------
    pythons : dict
        Build label -> Python interpreter of that build.
    envs : dict, optional
        Build label -> environment variables set for its children: one build run in several
        ways (:data:`SIMD_RUNS`). Without it the labels must import different builds.
    sizes : iterable of int
        Array sizes.
    frames : int or None
        Frames per row (default: the IECM benchmark's, a quarter with ``quick``).
    threads : int or None
        Threads per row (default: all usable cores).

    Returns
    -------
    dict
        ``{"machine", "builds": {label: {"python", "psmat", "core", "version"}}, "rows": [...]}``;
        each row holds ``size``, ``solver``, ``threads``, ``frames`` and per build the list
        ``runs`` of measured rows.
    """
    # refused before anything is measured: one build under two labels is no comparison
    cores = [run_child(python, None, timeout=120.0)["core"] for python in pythons.values()]
    if envs is None and len(set(cores)) < len(cores):
        raise RuntimeError(f"the builds import the same psmat._core ({cores[0]}): give two environments")
    info = machine_info()
    threads = threads or info["usable_cpus"]
    min_time, budget = (0.3, 60.0) if quick else (1.0, 150.0)
    builds: dict[str, dict] = {}
    rows = []
    for size in sizes:
        T = int(frames) if frames is not None else settings(size, quick, False)["frames"]
        for kw in rows_for(size, T, threads, seed, min_time, budget):
            entry = dict(size=size, solver=kw["label"], threads=threads, frames=T,
                         runs={label: [] for label in pythons})
            for k in range(repeats):
                for label, python in pythons.items():
                    res = run_child(python, kw, timeout=budget + 120.0, env_set=(envs or {}).get(label))
                    seen = builds.setdefault(label, {"python": python, "psmat": res["psmat"], "core": res["core"],
                                                     "version": res["version"], "simd": res["simd"]})
                    if seen["core"] != res["core"]:
                        raise RuntimeError(f"{label}: psmat._core moved from {seen['core']} to {res['core']}")
                    entry["runs"][label].append(res["row"])
                    log(f"  {size}x{size} {kw['label']:<38} {label:<8} run {k + 1}/{repeats}: "
                        f"{res['row']['fps']:.4g} fps", file=sys.stderr, flush=True)
            rows.append(entry)
    return {"machine": info, "builds": builds, "rows": rows, "repeats": repeats, "seed": seed}


def _median_spread(values: list[float]) -> tuple[float, float, float]:
    return statistics.median(values), min(values), max(values)


def format_comparison(result: dict) -> str:
    """Markdown table: per row, each build's median fps (min-max) and the ratio of medians."""
    m = result["machine"]
    labels = list(result["builds"])
    lines = [f"IECM: {' vs '.join(labels)} build — {m['date']}",
             f"machine: {m['cpu']}, {m['usable_cpus']} usable of {m['logical_cpus']} logical CPUs; {m['platform']}"]
    for label, b in result["builds"].items():
        lines.append(f"{label}: psmat {b['version']}, {b['python']} -> {Path(b['core']).name} in "
                     f"{Path(b['core']).parent}; dense kernels: {b.get('simd', 'unknown')}")
    lines += [f"frames: two feet swaying on the digital twin (seed {result['seed']}), streaming, threads as shown; "
              f"fps: median of {result['repeats']} runs per build (min-max), the builds alternating", ""]
    head = "| size | solver | threads | frames | " + " | ".join(f"{x} fps" for x in labels)
    head += f" | {labels[-1]}/{labels[0]} | mean iters | max residual |"
    lines += [head, "| --- | --- | ---: | ---: | " + " | ".join("---:" for _ in labels) + " | ---: | --- | --- |"]
    for r in result["rows"]:
        cells, med = [], {}
        for label in labels:
            fps = [x["fps"] for x in r["runs"][label]]
            med[label], lo, hi = _median_spread(fps)
            cells.append(f"{med[label]:.4g} ({lo:.4g}-{hi:.4g})")
        ratio = med[labels[-1]] / med[labels[0]]
        iters = " / ".join(f"{r['runs'][x][0]['iterations']:.2f}" for x in labels)
        noisy = r["runs"][labels[0]][0]["noise_v"] > 0
        resid = " / ".join(f"{r['runs'][x][0]['max_residual']:.1e}" for x in labels) if noisy else "—"
        lines.append(f"| {r['size']}x{r['size']} | {r['solver']} | {r['threads']} | {r['frames']} | "
                     + " | ".join(cells) + f" | {ratio:.2f} | {iters} | {resid} |")
    lines.append("")
    lines.append(f"- mean iters, max residual: {' / '.join(labels)} (the same work in both builds; "
                 "the residual of noisy G is the complementarity residual, docs/spec.md §3)")
    return "\n".join(lines)

"""Import cost: how long ``import psmat`` and ``psmat --help`` take, beside ``import numpy``.

Each command runs in a fresh Python process (the interpreter this benchmark runs on), so
every figure includes the interpreter's own start, as a person typing it pays it. The
commands take turns, round after round, so that a busy moment of the machine falls on all
of them alike; the first round warms the file cache and is not counted. The figure is the
median of the rounds' wall times, with the fastest and slowest beside it.

* ``python -c pass``: the interpreter alone;
* ``python -c "import numpy"``: the baseline (psmat's goal: at most 3 times this);
* ``python -c "import psmat"``: the package loads its subpackages only when one is used;
* ``psmat --help``: the console script (``python -m psmat --help`` where none is installed);
  the command line lists its commands without importing what they run.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys
import sysconfig
import time

__all__ = ["main", "build_parser", "commands", "measure", "GOAL"]

#: ``import psmat`` and ``psmat --help`` should take at most this many times ``import numpy``
GOAL = 3.0
BASELINE = "import numpy"


def commands() -> dict[str, list[str]]:
    """The commands timed, by the name the report gives them, each as an argument list."""
    py = sys.executable
    script = shutil.which("psmat", path=sysconfig.get_path("scripts"))
    helps = [script, "--help"] if script else [py, "-m", "psmat", "--help"]
    return {
        "python -c pass": [py, "-c", "pass"],
        BASELINE: [py, "-c", "import numpy"],
        "import psmat": [py, "-c", "import psmat"],
        "psmat --help" if script else "python -m psmat --help": helps,
    }


def _wall_s(argv: list[str]) -> float:
    t0 = time.perf_counter()
    subprocess.run(argv, check=True, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    return time.perf_counter() - t0


def measure(cmds: dict[str, list[str]], repeats: int) -> dict[str, list[float]]:
    """Wall time (s) of each command in ``repeats`` rounds, the commands taking turns in each.

    One uncounted round first (file cache, bytecode caches). Raises
    :class:`subprocess.CalledProcessError` if a command fails.
    """
    for argv in cmds.values():
        _wall_s(argv)
    times: dict[str, list[float]] = {name: [] for name in cmds}
    for _ in range(repeats):
        for name, argv in cmds.items():
            times[name].append(_wall_s(argv))
    return times


def report(times: dict[str, list[float]]) -> list[dict]:
    """One row per command: median, fastest and slowest (ms) and the median over the baseline's."""
    base = statistics.median(times[BASELINE])
    return [{"command": name, "median_ms": 1e3 * statistics.median(t), "min_ms": 1e3 * min(t),
             "max_ms": 1e3 * max(t), "vs_numpy": statistics.median(t) / base} for name, t in times.items()]


def build_parser(prog: str = "python -m psmat.bench import") -> argparse.ArgumentParser:
    """The benchmark's options (its help: this module's docstring, every default)."""
    from .._help import HelpFormatter, plain

    ap = argparse.ArgumentParser(prog=prog, description=plain(__doc__), formatter_class=HelpFormatter)
    ap.add_argument("--repeats", type=int, default=15, help="rounds counted, each running every command once")
    ap.add_argument("--json", metavar="PATH", help="also write the figures to this JSON file")
    ap.add_argument("--overwrite", action="store_true", help="replace an existing --json file")
    return ap


def main(argv: list[str] | None = None, prog: str = "python -m psmat.bench import") -> int:
    ap = build_parser(prog)
    args = ap.parse_args(argv)
    if args.repeats < 1:
        ap.error(f"--repeats must be >= 1, got {args.repeats}")
    from .._atomic import OutputRefused, check_outputs, open_atomic
    from .machine import machine_info

    try:  # before any work: an existing file only with --overwrite
        check_outputs([args.json], overwrite=args.overwrite)
    except OutputRefused as exc:
        print(f"{prog}: {exc}", file=sys.stderr)
        return 1
    info = machine_info()
    print(f"machine: {info['cpu']}, {info['usable_cpus']} usable CPUs; Python {info['python']}, psmat "
          f"{info['psmat']}; {os.path.basename(sys.executable)} in fresh processes, median of {args.repeats}")
    cmds = commands()
    try:
        rows = report(measure(cmds, args.repeats))
    except subprocess.CalledProcessError as exc:
        err = (exc.stderr or b"").decode(errors="replace").strip().splitlines()
        print(f"{prog}: {' '.join(exc.cmd)} failed (exit status {exc.returncode}): {err[-1] if err else ''}",
              file=sys.stderr)
        return 1
    width = max(len(r["command"]) for r in rows)
    print(f"{'command':<{width}}  median ms   min ms   max ms   x import numpy")
    for r in rows:
        print(f"{r['command']:<{width}}  {r['median_ms']:9.1f} {r['min_ms']:8.1f} {r['max_ms']:8.1f}"
              f"   {r['vs_numpy']:6.2f}")
    worst = max(r["vs_numpy"] for r in rows if r["command"] not in ("python -c pass", BASELINE))
    print(f"goal: import psmat and psmat --help at most {GOAL:g}x import numpy: "
          f"{'met' if worst <= GOAL else 'NOT met'} (worst {worst:.2f}x)")
    if args.json:
        with open_atomic(args.json, "w") as f:
            json.dump({"machine": info, "repeats": args.repeats, "goal_x_numpy": GOAL, "rows": rows,
                       "argv": {k: v for k, v in cmds.items()}}, f, indent=1)
    return 0

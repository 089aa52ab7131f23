"""``psmat bench BENCHMARK [options]``: the benchmarks, as ``python -m psmat.bench``.

``psmat bench --help`` lists them; ``psmat bench BENCHMARK --help`` gives one's options.
"""

from __future__ import annotations

import argparse

from ..bench.__main__ import BENCHMARKS, DESCRIPTION, add_arguments

NAME = "bench"
HELP = f"run a benchmark ({', '.join(BENCHMARKS)}) beside its baseline; psmat bench --help lists them"
__all__ = ["NAME", "HELP", "DESCRIPTION", "add_arguments", "run"]


def run(args: argparse.Namespace) -> int:
    import sys

    from ..bench.__main__ import run as run_benchmark

    if args.benchmark is None:
        print(f"psmat bench: name a benchmark: {', '.join(BENCHMARKS)} (see psmat bench --help)", file=sys.stderr)
        return 1
    return run_benchmark(args.benchmark, args.options, prog="psmat bench")

"""``psmat bench``: the benchmarks (same as ``python -m psmat.bench``)."""

from __future__ import annotations

import argparse

NAME = "bench"
HELP = "benchmarks (python -m psmat.bench --help)"
ADD_HELP = False  # the benchmark module parses its own options


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("rest", nargs=argparse.REMAINDER)


def run(args: argparse.Namespace) -> int:
    from ..bench.__main__ import main as bench_main

    return int(bench_main(args.rest))

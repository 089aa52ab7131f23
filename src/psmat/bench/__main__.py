"""``python -m psmat.bench BENCHMARK [options]`` (also ``psmat bench``): psmat's benchmarks
(docs/spec.md §10), each beside a baseline run in the same process.

``--help`` lists the benchmarks; ``BENCHMARK --help`` gives one's options, with their defaults
and units. Each benchmark is the module ``psmat.bench.<name>`` (or the one :data:`MODULES`
names), with ``build_parser(prog)`` (its options) and ``main(argv, prog)``; this module imports
it only when it is asked for.
"""

from __future__ import annotations

import argparse
import importlib
import sys
from types import ModuleType

from .._help import HelpFormatter

__all__ = ["BENCHMARKS", "DESCRIPTION", "PROG", "add_arguments", "benchmark_parser", "run", "main"]

PROG = "python -m psmat.bench"
#: Each benchmark (the module psmat.bench.<name>) and what it measures, in one line.
BENCHMARKS = {
    "iecm": "IECM (Inverse of Equivalent Conductance Method) crosstalk removal: frames/s and accuracy beside "
            "the thesis' NumPy/SciPy approach",
    "sensor": "sensor model (hysteresis and creep): direct and inverse throughput, and its identification, beside "
              "NumPy and scipy's dual_annealing",
    "acquire": "acquisition through the simulated mat on a pseudo-terminal: 165 Hz for 10 min, and a corrupted "
               "link beside a thesis-style reader",
    "study": "a thesis-size simulated balance study end to end, beside a plain multiprocessing pool over the "
             "sessions",
    "import": "the time of import psmat and of psmat --help in fresh processes, beside import numpy",
}
#: the module of a benchmark whose name is not a module name (``import`` is a Python keyword)
MODULES = {"import": "import_cost"}
DESCRIPTION = ("psmat's benchmarks (docs/spec.md §10), each beside a baseline run in the same process:\n\n"
               + "\n".join(f"* {name}: {line}" for name, line in BENCHMARKS.items())
               + "\n\nBENCHMARK --help gives a benchmark's options.")


def add_arguments(p: argparse.ArgumentParser) -> None:
    """BENCHMARK and the options passed on to it (for ``python -m psmat.bench`` and ``psmat bench``)."""
    p.add_argument("benchmark", nargs="?", choices=tuple(BENCHMARKS), metavar="BENCHMARK",
                   help=f"the benchmark to run: {', '.join(BENCHMARKS)}")
    p.add_argument("options", nargs=argparse.REMAINDER, metavar="...",
                   help="the benchmark's options (BENCHMARK --help lists them)")


def _module(name: str) -> ModuleType:
    if name not in BENCHMARKS:
        raise ValueError(f"unknown benchmark {name!r}; choose from {', '.join(BENCHMARKS)}")
    return importlib.import_module(f"{__package__}.{MODULES.get(name, name)}")


def benchmark_parser(name: str, prog: str = PROG) -> argparse.ArgumentParser:
    """The option parser of benchmark ``name``, its usage line starting ``prog name``."""
    return _module(name).build_parser(f"{prog} {name}")


def run(name: str, options: list[str], prog: str = PROG) -> int:
    """Run benchmark ``name`` with its command-line ``options``; its exit status."""
    return int(_module(name).main(options, prog=f"{prog} {name}") or 0)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog=PROG, description=DESCRIPTION, formatter_class=HelpFormatter)
    add_arguments(p)
    args = p.parse_args(sys.argv[1:] if argv is None else argv)
    if args.benchmark is None:
        p.error(f"name a benchmark: {', '.join(BENCHMARKS)}")
    return run(args.benchmark, args.options)


if __name__ == "__main__":
    sys.exit(main())

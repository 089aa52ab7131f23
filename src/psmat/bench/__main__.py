"""``python -m psmat.bench BENCHMARK [options]`` (also ``psmat bench``): psmat's benchmarks
(docs/spec.md §10), each beside a baseline run in the same process.

``--help`` lists the benchmarks; ``BENCHMARK --help`` gives one's options, with their defaults
and units. Each benchmark is the module ``psmat.bench.<name>`` (or the one :data:`MODULES`
names), with ``build_parser(prog)`` (its options) and ``main(argv, prog)``; this module imports
it only when it is asked for.
"""

from __future__ import annotations

import sys

from .._runners import Runners

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
    "firmware": "the PSM image in the emulator: instructions per frame, in the CRC and in busy-waits, scan time, "
                "beside the image with the earlier bitwise CRC",
    "lab": "the lab page in headless Chromium (frames drawn/s, latency from a frame's device time to the page, "
           "server CPU while recording) beside the matplotlib view, at 100 and 165 Hz",
}
#: the module of a benchmark whose name is not a module name (``import`` is a Python keyword)
MODULES = {"import": "import_cost"}
DESCRIPTION = ("psmat's benchmarks (docs/spec.md §10), each beside a baseline run in the same process:\n\n"
               + "\n".join(f"* {name}: {line}" for name, line in BENCHMARKS.items())
               + "\n\nBENCHMARK --help gives a benchmark's options.")


RUNNERS = Runners(__package__, PROG, "benchmark", BENCHMARKS, DESCRIPTION, modules=MODULES)
#: NAME and the options passed on to it (for ``python -m psmat.bench`` and ``psmat bench``).
add_arguments = RUNNERS.add_arguments
#: The option parser of a benchmark, its usage line starting ``prog name``.
benchmark_parser = RUNNERS.parser
#: Run a benchmark with its command-line options; its exit status.
run = RUNNERS.run
main = RUNNERS.main


if __name__ == "__main__":
    sys.exit(main())

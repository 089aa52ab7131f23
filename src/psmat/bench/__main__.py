"""``python -m psmat.bench <benchmark> [options]`` — see ``--help``."""

from __future__ import annotations

import argparse
import sys


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    benches = {
        "iecm": "IECM crosstalk removal: frames/s and accuracy vs the thesis' NumPy/SciPy approach",
        "sensor": "sensor model: direct/inverse throughput and identification vs NumPy and scipy dual_annealing",
        "acquire": "acquisition through the pty twin: 165 Hz for 10 min, and a corrupted link vs a thesis-style reader",
        "study": "a thesis-size simulated balance study end to end vs a plain multiprocessing pool over sessions",
    }
    if not argv or argv[0] in ("-h", "--help"):
        p = argparse.ArgumentParser(prog="python -m psmat.bench", description="psmat benchmarks (docs/spec.md §10).")
        p.add_argument("benchmark", choices=sorted(benches), help="; ".join(f"{k}: {v}" for k, v in benches.items()))
        p.print_help()
        return 0 if argv else 2
    name, rest = argv[0], argv[1:]
    if name == "iecm":
        from .iecm import main as iecm_main

        return iecm_main(rest)
    if name == "sensor":
        from .sensor import main as sensor_main

        return sensor_main(rest)
    if name == "acquire":
        from .acquire import main as acquire_main

        return acquire_main(rest)
    if name == "study":
        from .study import main as study_main

        return study_main(rest)
    print(f"python -m psmat.bench: unknown benchmark {name!r}; choose from {sorted(benches)}", file=sys.stderr)
    return 2


if __name__ == "__main__":
    sys.exit(main())

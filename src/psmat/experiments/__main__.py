"""``python -m psmat.experiments EXPERIMENT [options]``: the measurements beyond the thesis, in
simulation, each printing its table.

``--help`` lists them; ``EXPERIMENT --help`` gives one's options, with their defaults and units.
Each is the module ``psmat.experiments.<name>``, with ``build_parser(prog)`` and
``main(argv, prog)``; this module imports it only when it is asked for. (The thesis' own
studies are functions, ``psmat.experiments.table_2_4`` and the others, run by the notebooks.)
"""

from __future__ import annotations

import argparse
import importlib
import sys
from types import ModuleType

from .._help import HelpFormatter

__all__ = ["EXPERIMENTS", "PROG", "experiment_parser", "run", "main"]

PROG = "python -m psmat.experiments"
#: Each experiment (the module psmat.experiments.<name>) and what it measures, in one line.
EXPERIMENTS = {
    "equilibration": "SCHC-EQ (a per-cell equilibration learned from the trial) against SCHC, on simulated "
                     "balance trials through mats with unknown cell gains",
    "dynamic_correction": "SCHC-DYN (a linear correction fitted on other volunteers) against SCHC, on a "
                          "simulated balance study",
}
DESCRIPTION = ("psmat's measurements beyond the thesis, in simulation, each printing its table:\n\n"
               + "\n".join(f"* {name}: {line}" for name, line in EXPERIMENTS.items())
               + "\n\nEXPERIMENT --help gives an experiment's options.")


def _module(name: str) -> ModuleType:
    if name not in EXPERIMENTS:
        raise ValueError(f"unknown experiment {name!r}; choose from {', '.join(EXPERIMENTS)}")
    return importlib.import_module(f"{__package__}.{name}")


def experiment_parser(name: str, prog: str = PROG) -> argparse.ArgumentParser:
    """The option parser of experiment ``name``, its usage line starting ``prog name``."""
    return _module(name).build_parser(f"{prog} {name}")


def run(name: str, options: list[str], prog: str = PROG) -> int:
    """Run experiment ``name`` with its command-line ``options``; its exit status."""
    return int(_module(name).main(options, prog=f"{prog} {name}") or 0)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog=PROG, description=DESCRIPTION, formatter_class=HelpFormatter)
    p.add_argument("experiment", nargs="?", choices=tuple(EXPERIMENTS), metavar="EXPERIMENT",
                   help=f"the experiment to run: {', '.join(EXPERIMENTS)}")
    p.add_argument("options", nargs=argparse.REMAINDER, metavar="...",
                   help="the experiment's options (EXPERIMENT --help lists them)")
    args = p.parse_args(sys.argv[1:] if argv is None else argv)
    if args.experiment is None:
        p.error(f"name an experiment: {', '.join(EXPERIMENTS)}")
    return run(args.experiment, args.options)


if __name__ == "__main__":
    sys.exit(main())

"""``python -m psmat.experiments EXPERIMENT [options]``: the measurements beyond the thesis, in
simulation, each printing its table.

``--help`` lists them; ``EXPERIMENT --help`` gives one's options, with their defaults and units.
Each is the module ``psmat.experiments.<name>``, with ``build_parser(prog)`` and
``main(argv, prog)``; this module imports it only when it is asked for. (The thesis' own
studies are functions, ``psmat.experiments.table_2_4`` and the others, run by the notebooks.)
"""

from __future__ import annotations

import sys

from .._runners import Runners

__all__ = ["EXPERIMENTS", "PROG", "experiment_parser", "run", "main"]

PROG = "python -m psmat.experiments"
#: Each experiment (the module psmat.experiments.<name>) and what it measures, in one line.
EXPERIMENTS = {
    "equilibration": "SCHC-EQ (a per-cell equilibration learned from the trial) against SCHC, on simulated "
                     "balance trials through mats with unknown cell gains",
    "dynamic_correction": "SCHC-DYN (a linear correction fitted on other volunteers) against SCHC, on a "
                          "simulated balance study",
    "pressure_calibration": "the kPa of twin mats the processing does not know, before and after the psmat "
                            "calibrate pressure steps (equilibrate, known-load), against the truth",
}
DESCRIPTION = ("psmat's measurements beyond the thesis, in simulation, each printing its table:\n\n"
               + "\n".join(f"* {name}: {line}" for name, line in EXPERIMENTS.items())
               + "\n\nEXPERIMENT --help gives an experiment's options.")


RUNNERS = Runners(__package__, PROG, "experiment", EXPERIMENTS, DESCRIPTION)
#: NAME and the options passed on to it (for ``python -m psmat.experiments``).
add_arguments = RUNNERS.add_arguments
#: The option parser of an experiment, its usage line starting ``prog name``.
experiment_parser = RUNNERS.parser
#: Run an experiment with its command-line options; its exit status.
run = RUNNERS.run
main = RUNNERS.main


if __name__ == "__main__":
    sys.exit(main())

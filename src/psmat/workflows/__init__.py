"""The command-line workflows behind ``psmat demo`` and ``psmat calibrate`` (the commands
themselves, argument parsing and printing, live in :mod:`psmat.commands`).

* :mod:`psmat.workflows.sway_demo` — record a person swaying from the twin (or a mat), process, compare, plot.
* :mod:`psmat.workflows.crosstalk_demo` — crosstalk removal on one simulated frame, with a figure.
* :mod:`psmat.workflows.calibrate_steps` — the open- and short-circuit calibration steps (docs/spec.md §2).
* :mod:`psmat.workflows.calibrate_pressure` — the pressure steps (equilibrate, known load, pneumatic;
  docs/spec.md §4) from recorded session files.
"""

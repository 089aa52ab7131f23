"""Sensor model of the Velostat cells: hysteresis and creep (thesis §2.4-2.5, docs/spec.md §4).

* :class:`MPICreep` - the direct model and its exact inverse (eq. 2.15-2.25);
* :func:`fit` - identification from pneumatic experiments (eq. 2.26);
* :mod:`psmat.sensor.protocols` - the four pneumatic protocols (§2.4.2);
* :mod:`psmat.sensor.pneumatic` - simulated runs, the material DAQ's log and session loaders;
* :func:`fit_cells` - shared, shared + per-cell gain, or per-cell models (cell variability);
* :func:`frame_periods`, :func:`steps_over_gaps`, :func:`inverse_over_gaps` - the model on a stream
  with missing frames (the creep steps over gaps);
* :mod:`psmat.sensor.plots` - fitted vs measured output, recovered vs applied pressure (Fig. 2.37-2.39),
  the radar chart (Fig. 2.34) and hysteresis loops (Fig. 2.33);
* :mod:`psmat.sensor.metrics` - variability, drift, creep, hysteresis (eq. 2.1-2.4) and their tables.
"""

from . import metrics, plots, pneumatic, protocols
from ._cells import CellModels, fit_cells
from ._fit import FitResult, ReducedProblem, annealing_space, fit
from ._invertible_lsq import constrained_coefficients, slope_constraints
from ._mpi_creep import P_BEYOND, THESIS_TABLE_2_11, MPICreep, SensorState
from ._stepping import frame_periods, inverse_over_gaps, steps_over_gaps
from .pneumatic import PneumaticRun, load_daq_log, load_daq_session, simulate_run
from .protocols import Protocol, ascending_hysteresis, descending_hysteresis, fast_cyclic, long_staircase

__all__ = [
    "MPICreep", "SensorState", "THESIS_TABLE_2_11", "P_BEYOND", "fit", "FitResult", "ReducedProblem", "annealing_space",
    "protocols", "pneumatic", "metrics", "plots",
    "Protocol", "fast_cyclic", "long_staircase", "descending_hysteresis", "ascending_hysteresis",
    "PneumaticRun", "simulate_run", "load_daq_log", "load_daq_session", "CellModels", "fit_cells",
    "frame_periods", "steps_over_gaps", "inverse_over_gaps", "constrained_coefficients", "slope_constraints",
]

"""Sensor model of the Velostat cells: hysteresis and creep (thesis §2.4-2.5, SPEC §4)."""

from .fit import FitResult, fit
from .mpi_creep import THESIS_TABLE_2_11, MPICreep, SensorState

__all__ = ["MPICreep", "SensorState", "THESIS_TABLE_2_11", "fit", "FitResult"]

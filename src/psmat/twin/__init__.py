"""Digital twin of the mat (SPEC §5).

* :mod:`psmat.twin.pressure` — feet and seats as smooth pressure fields (psi), integrated
  over each cell, and seeded scene generators (quiet standing, single-leg sway, a recorded
  force-platform trajectory, sitting) returning :class:`PressureScene`.
* :mod:`psmat.twin.mat` — :class:`MatPhysics`: pressure → sensor model with cell-to-cell
  variability → crosstalk F(g) → measurement chain → ADC counts.
* :mod:`psmat.twin.sources` — what each simulated device measures, tick by tick.
* :mod:`psmat.twin.serial_twin` — :class:`SerialTwin`: the firmware core on the host,
  served on a real pseudo-terminal, with fault injection.
"""

from .pressure import (
    PSI_PA,
    Lobes,
    PressureScene,
    cell_centres_cm,
    cell_cop_cm,
    cell_force_n,
    cell_pressure_psi,
    foot,
    quiet_standing,
    single_leg_sway,
    sitting,
    trajectory_sway,
    two_feet,
)

from .mat import MatPhysics, MatTruth
from .serial_twin import Faults, SerialTwin, TwinStats
from .sources import SCENES, CalibrationFixture, DaqSource, ImuSource, PsmSource, make_scene

__all__ = [
    "MatPhysics",
    "MatTruth",
    "Faults",
    "SerialTwin",
    "TwinStats",
    "SCENES",
    "CalibrationFixture",
    "DaqSource",
    "ImuSource",
    "PsmSource",
    "make_scene",
    "PSI_PA",
    "Lobes",
    "PressureScene",
    "cell_centres_cm",
    "cell_cop_cm",
    "cell_force_n",
    "cell_pressure_psi",
    "foot",
    "quiet_standing",
    "single_leg_sway",
    "sitting",
    "trajectory_sway",
    "two_feet",
]

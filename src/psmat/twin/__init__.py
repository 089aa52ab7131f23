"""Digital twin of the mat (SPEC §5): simulated pressure fields on the mat.

:mod:`psmat.twin.pressure` — feet and seats as smooth pressure fields (psi), integrated
over each cell, and seeded scene generators (quiet standing, single-leg sway, a recorded
force-platform trajectory, sitting) returning :class:`PressureScene`.
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
)

__all__ = [
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
]

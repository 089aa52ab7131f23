"""Digital twin of the mat (docs/spec.md §5): one synthetic world for the whole package.

One coordinate convention (cell ``(i, p)`` centred at ``(p·pitch, i·pitch)`` cm, as
:func:`psmat.balance.cop`), pressure in psi inside (the sensor model's unit), forces in N;
pressure becomes conductance only through the sensor model (:class:`MatPhysics`).

* :mod:`psmat.twin.field` — the continuous pressure field (:class:`Lobes`) and its cell image.
* :mod:`psmat.twin.anatomy` — feet and a seat as lobes.
* :mod:`psmat.twin.steering` — the group forces that put the field's CoP on a target.
* :mod:`psmat.twin.scenes` — seeded scenes (quiet standing, single-leg sway, a recorded
  force-platform trajectory, sitting) returning :class:`PressureScene`.
* :mod:`psmat.twin.seated` — the seated twin (docs/spec.md §8), a subpackage: a person of thesis
  Table 4.2 following the posture protocol, one trajectory driving the cushion's pressure and the
  five spine IMUs, whose bytes come from the IMU firmware core (:func:`~psmat.twin.seated.imu_packets`).
* :mod:`psmat.twin.mat` — :class:`MatPhysics`: pressure → sensor model with cell-to-cell
  variability → crosstalk F(g) → measurement chain → ADC counts.
* :mod:`psmat.twin.conductance` — :func:`swaying_feet`: cell conductances of a person in quiet
  standing (benchmarks, tests, the crosstalk demo).
* :mod:`psmat.twin.arrays` — :func:`random_array`: the random array of thesis Fig. 2.13.
* :mod:`psmat.twin.sources` — what each simulated device measures, tick by tick.
* :mod:`psmat.twin.serial_twin` — :class:`SerialTwin`: the firmware core on the host,
  served on a real pseudo-terminal or on TCP (``socket://127.0.0.1:PORT``, where the system
  has no pty), with fault injection (:mod:`~psmat.twin.pty_link`, :mod:`~psmat.twin.tcp_link`);
  with ``protocol="csv"`` a do-it-yourself mat printing text lines (the ``arduino16`` profile).
* :mod:`psmat.twin.emulated` — :class:`EmulatedTwin`: the STM32 PSM firmware image itself, run
  in :mod:`psmat.emulator`, served on the same link (:mod:`~psmat.twin.serving`: the link, its
  queue, faults and counters, shared with :class:`SerialTwin`).
"""

from .anatomy import foot, two_feet
from .arrays import random_array
from .conductance import swaying_feet
from .emulated import EmulatedTwin
from .field import MAT_SIZE_CM, PSI_PA, Lobes, cell_force_n, cell_pressure_psi, mat_pitch_cm
from .mat import MatPhysics, MatTruth
from .scenes import PressureScene, quiet_standing, single_leg_sway, trajectory_sway, uniform_load
from .seated import (SeatedDay, SeatedSession, SeatedSubject, draw_seated_day, draw_seated_subject, seated_session,
                     sitting)
from .serial_twin import Faults, SerialTwin, TwinStats
from .sources import SCENES, CalibrationFixture, DaqSource, ImuSource, PsmSource, make_scene

__all__ = [
    "MatPhysics",
    "MatTruth",
    "Faults",
    "SerialTwin",
    "EmulatedTwin",
    "TwinStats",
    "SCENES",
    "CalibrationFixture",
    "DaqSource",
    "ImuSource",
    "PsmSource",
    "make_scene",
    "PSI_PA",
    "MAT_SIZE_CM",
    "Lobes",
    "PressureScene",
    "cell_force_n",
    "cell_pressure_psi",
    "mat_pitch_cm",
    "foot",
    "quiet_standing",
    "single_leg_sway",
    "uniform_load",
    "sitting",
    "trajectory_sway",
    "two_feet",
    "swaying_feet",
    "random_array",
    "SeatedSession",
    "SeatedSubject",
    "SeatedDay",
    "seated_session",
    "draw_seated_subject",
    "draw_seated_day",
]

"""psmat - software for low-cost pressure-sensitive mats (Velostat resistive sensor arrays).

Submodules: :mod:`psmat.iecm` (crosstalk removal), :class:`psmat.Circuit` (measurement
chain counts <-> conductance), :class:`psmat.Calibration` (a box's R_adc and R_mux, as data)
and :mod:`psmat.calibration_estimate` (their estimates from open/short-circuit recordings),
:mod:`psmat.noise` (Table 2.4 noise model), :mod:`psmat.sensor` (Velostat hysteresis +
creep), :mod:`psmat.protocol` (wire formats), :mod:`psmat.io` (session files, force
platforms), :mod:`psmat.twin` (the simulated mat: the one synthetic world of tests,
benchmarks and demos), :mod:`psmat.acquire` (reading devices over serial),
:mod:`psmat.process` (counts → pressure → CoP), :mod:`psmat.qzpm` (IECM for the QZPM readout, App. C),
:mod:`psmat.experiments` (the thesis' crosstalk studies), :mod:`psmat.balance` (sway, alignment,
the chapter 3 variants) and :mod:`psmat.study` (a balance study folder run in batch).
"""

from . import acquire, balance, calibration_estimate, experiments, iecm, io, noise, posture, protocol, qzpm, sensor, study, twin
from .calibration import Calibration
from .circuit import Circuit


from ._version import __version__  # the one place the version is written
__all__ = ["acquire", "balance", "calibration_estimate", "experiments", "iecm", "io", "noise", "posture", "protocol", "qzpm", "sensor", "study", "twin", "Circuit", "Calibration", "__version__"]

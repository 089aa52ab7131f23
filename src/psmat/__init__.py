"""psmat - software for low-cost pressure-sensitive mats (Velostat resistive sensor arrays).

Submodules: :mod:`psmat.iecm` (crosstalk removal), :class:`psmat.Circuit` (measurement
chain counts <-> conductance), :mod:`psmat.noise` (Table 2.4 noise model),
:mod:`psmat.scenes` (synthetic pressure images).
"""

from . import iecm, noise, scenes, sensor
from .calibration import Calibration
from .circuit import Circuit


__version__ = "0.1.0"
__all__ = ["iecm", "noise", "scenes", "sensor", "Circuit", "Calibration", "__version__"]

"""The baselines that psmat's benchmarks time beside psmat, in the same process.

Each is an independent re-implementation of what psmat does, the way the thesis did it or
in plain NumPy: nothing here imports the psmat code it is compared with, so a benchmark
compares two implementations and a test can check one against the other.

* :mod:`.iecm_numpy` — IECM (eq. 2.5-2.13): the forward model, its Jacobian, scipy
  ``least_squares`` with a numerical Jacobian, the fixed point of eq. 2.10;
* :mod:`.sensor_numpy` — the sensor model (eq. 2.15-2.24), direct and inverse;
* :mod:`.thesis_reader` — the thesis-style reader of v1 frames on a serial port.

They live in the package, not in ``tests/``, because ``python -m psmat.bench`` runs them for
a pip user. The tests check each against what does not come from the code under test:
reference vectors, closed forms, finite differences and hand-made byte streams, or, for the
sensor model, psmat's C++ model (two implementations written apart that must agree).
"""

from .iecm_numpy import forward_numpy, jacobian_numpy, solve_fixed_point_numpy, solve_least_squares_scipy
from .sensor_numpy import direct_numpy, inverse_numpy
from .thesis_reader import thesis_read, thesis_read_port

__all__ = ["forward_numpy", "jacobian_numpy", "solve_fixed_point_numpy", "solve_least_squares_scipy",
           "direct_numpy", "inverse_numpy", "thesis_read", "thesis_read_port"]

"""Type stub for the compiled core psmat._core (private; use the psmat package API).

This folder holds stubs only (no __init__.py): the compiled extension module
``_core.*.so`` takes precedence at import time.
"""

import enum

from . import iecm as iecm
from . import qzpm as qzpm
from . import firmware as firmware
from . import sensor as sensor

class Status(enum.Enum):
    """How an iterative solve ended (src/cpp/psmat/solve_report.hpp); a pybind11 enum."""

    converged = 0
    max_iterations = 1
    stalled = 2
    singular = 3
    least_squares = 4
    bounded = 5

class SolveReport:
    """Diagnostics of one solved IECM frame or QZPM problem (read-only)."""

    @property
    def iterations(self) -> int: ...
    @property
    def factorizations(self) -> int: ...
    @property
    def krylov_iterations(self) -> int: ...
    @property
    def evaluations(self) -> int: ...
    @property
    def residual(self) -> float: ...
    @property
    def cost(self) -> float: ...
    @property
    def status(self) -> Status: ...
    @property
    def used_fallback(self) -> bool: ...
    @property
    def at_bound(self) -> int: ...
    @property
    def converged(self) -> bool: ...

"""Type stub for psmat._core.iecm (bindings/python/register_iecm.cpp)."""

import enum
from typing import Any

import numpy as np
import numpy.typing as npt

class Method(enum.Enum):
    newton = 0
    bounded_newton = 1
    lm = 2
    bounded_lsq = 3
    fixed_point = 4
    active_set = 5

class Status(enum.Enum):
    converged = 0
    max_iterations = 1
    stalled = 2
    singular = 3
    least_squares = 4
    bounded = 5

class SolveOptions:
    method: Method
    max_iter: int
    rtol: float
    ftol: float
    beta: float
    g_floor: float
    max_log_step: float
    reuse_factorization: bool
    krylov_max_iter: int
    forcing: float
    fallback: bool
    def __init__(self) -> None: ...

def forward(g: npt.ArrayLike) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.bool_]]: ...
def jacobian(g: npt.ArrayLike) -> npt.NDArray[np.float64]: ...
def hadamard_product(g: npt.ArrayLike, v: npt.ArrayLike) -> npt.NDArray[np.float64]: ...
def inverse_jacobian(g: npt.ArrayLike) -> npt.NDArray[np.float64]: ...
def propagate_uncertainty(g: npt.ArrayLike, sigma_G: npt.ArrayLike) -> npt.NDArray[np.float64]: ...
def solve_frame(
    G: npt.ArrayLike, options: SolveOptions, g0: npt.ArrayLike | None = None
) -> tuple[npt.NDArray[np.float64], dict[str, Any]]: ...
def hardware_threads() -> int: ...

class BatchJob:
    def __init__(
        self,
        G: npt.ArrayLike,
        options: SolveOptions,
        streaming: bool,
        threads: int,
        initial: npt.ArrayLike | None = None,
    ) -> None: ...
    def start(self) -> None: ...
    def wait(self, seconds: float) -> bool: ...
    def cancel(self) -> None: ...
    @property
    def completed(self) -> int: ...
    @property
    def frames(self) -> int: ...
    def g(self) -> npt.NDArray[np.float64]: ...
    def reports(self) -> dict[str, npt.NDArray[Any]]: ...

class StreamSolver:
    def __init__(
        self, rows: int, cols: int, options: SolveOptions, threads: int, max_pending: int
    ) -> None: ...
    def push(self, G: npt.ArrayLike, timeout: float = -1.0) -> int | None: ...
    def pop(self, timeout: float) -> tuple[int, npt.NDArray[np.float64], dict[str, Any]] | None: ...
    @property
    def pending(self) -> int: ...
    def close(self) -> None: ...

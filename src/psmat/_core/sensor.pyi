"""Type stub for psmat._core.sensor (bindings/python/register_sensor.cpp)."""

import numpy as np
import numpy.typing as npt

class MPICreepParams:
    rho: float
    tau: float
    a1: float
    a2: float
    a3: float
    l: list[float]
    w: list[float]
    n_ops: int
    p_max: float
    def __init__(self) -> None: ...

class MPICreepState:
    y: npt.NDArray[np.float64]
    yc: npt.NDArray[np.float64]
    p_prev: npt.NDArray[np.float64]
    def copy(self) -> MPICreepState: ...

class MPICreep:
    def __init__(self, params: MPICreepParams) -> None: ...
    @property
    def thresholds(self) -> npt.NDArray[np.float64]: ...
    @property
    def weights(self) -> npt.NDArray[np.float64]: ...
    def rest_state(self, cells: int) -> MPICreepState: ...
    def check_invertible(self) -> str: ...
    def direct(self, p: npt.ArrayLike, dt: npt.ArrayLike, state: MPICreepState) -> npt.NDArray[np.float64]: ...
    def inverse(
        self, g: npt.ArrayLike, dt: npt.ArrayLike, state: MPICreepState
    ) -> tuple[npt.NDArray[np.float64], int]: ...

class Counter:
    def __init__(self) -> None: ...
    @property
    def value(self) -> int: ...

def theta_from_x(
    x: npt.ArrayLike, scale: npt.ArrayLike, log10: list[bool]
) -> npt.NDArray[np.float64]: ...
def anneal_fit(*args: object, **kwargs: object) -> dict[str, object]: ...
def sse_n_each(
    theta: npt.ArrayLike, p: list[npt.ArrayLike], g: list[npt.ArrayLike], dt: list[float], n_ops: int, p_max: float
) -> npt.NDArray[np.float64]: ...
def play_basis(p: npt.ArrayLike, r: npt.ArrayLike) -> npt.NDArray[np.float64]: ...
def creep_basis(p: npt.ArrayLike, l: npt.ArrayLike, dt: float) -> npt.NDArray[np.float64]: ...

def play_inverse(
    a1: float, b: npt.ArrayLike, r: npt.ArrayLike
) -> tuple[float, npt.NDArray[np.float64], npt.NDArray[np.float64]]: ...
def apply_play(
    a1: float, b: npt.ArrayLike, r: npt.ArrayLike, u: npt.ArrayLike
) -> npt.NDArray[np.float64]: ...

class SeparableProblem:
    """Variable projection of the MPI + creep fit (docs/spec.md §4): z = (tau, log10 l_j) searched,
    c = (a1, a2, a3, rho, w_j) an exact linear solve."""

    def __init__(
        self,
        p: list[npt.ArrayLike],
        g: list[npt.ArrayLike],
        dt: list[float],
        n_ops: int,
        p_max: float,
        n_creep: int,
    ) -> None: ...
    @property
    def n_nonlinear(self) -> int: ...
    @property
    def n_linear(self) -> int: ...
    def design(self, z: npt.ArrayLike) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]: ...
    def solve(self, z: npt.ArrayLike) -> tuple[float, npt.NDArray[np.float64], str]: ...
    def theta(self, z: npt.ArrayLike, c: npt.ArrayLike) -> npt.NDArray[np.float64]: ...

def anneal_separable(
    problem: SeparableProblem,
    z0: npt.ArrayLike,
    lo: npt.ArrayLike,
    hi: npt.ArrayLike,
    max_evals: int,
    t0: float,
    t_end: float,
    seed: int,
    progress: Counter | None = None,
) -> dict[str, object]: ...

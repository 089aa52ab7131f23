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
    def direct(self, p: npt.ArrayLike, dt: float, state: MPICreepState) -> npt.NDArray[np.float64]: ...
    def inverse(
        self, g: npt.ArrayLike, dt: float, state: MPICreepState
    ) -> tuple[npt.NDArray[np.float64], int]: ...

def play_inverse(
    a1: float, b: npt.ArrayLike, r: npt.ArrayLike
) -> tuple[float, npt.NDArray[np.float64], npt.NDArray[np.float64]]: ...
def apply_play(
    a1: float, b: npt.ArrayLike, r: npt.ArrayLike, u: npt.ArrayLike
) -> npt.NDArray[np.float64]: ...

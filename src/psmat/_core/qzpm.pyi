"""Type stub for psmat._core.qzpm (bindings/python/register_qzpm.cpp)."""

import numpy as np
import numpy.typing as npt

from . import SolveReport

_F = npt.NDArray[np.float64]

def forward(g: npt.ArrayLike, g_row: npt.ArrayLike, g_col: npt.ArrayLike) -> tuple[_F, _F, _F]: ...
def jacobian(g: npt.ArrayLike, g_row: npt.ArrayLike, g_col: npt.ArrayLike) -> _F: ...
def closed_form(pairs: npt.ArrayLike, rows: npt.ArrayLike, cols: npt.ArrayLike, r_switch: float) -> _F: ...
def solve(
    pairs: npt.ArrayLike,
    rows: npt.ArrayLike,
    cols: npt.ArrayLike,
    switches: int,
    max_iter: int,
    rtol: float,
    ftol: float,
    max_log_step: float,
    r_switch0: float,
    g0: npt.ArrayLike | None = None,
    sw0: npt.ArrayLike | None = None,
) -> tuple[_F, _F, _F, SolveReport]: ...
def solve_batch(
    pairs: npt.ArrayLike,
    rows: npt.ArrayLike,
    cols: npt.ArrayLike,
    switches: int,
    max_iter: int,
    rtol: float,
    ftol: float,
    max_log_step: float,
    r_switch0: float,
    threads: int = 0,
) -> tuple[_F, _F, _F, list[SolveReport]]: ...

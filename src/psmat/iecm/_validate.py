"""The IECM's conductance frames: clear errors instead of garbage (generic checks: psmat._checks)."""

from __future__ import annotations

import math
import os

import numpy as np

from .._checks import finite_values, nonnegative

__all__ = ["as_frames", "check_dense_size", "DENSE_LIMIT_BYTES", "dense_bytes_per_cell2"]

#: Dense memory one thread may allocate for one frame (bytes). IECM's Newton-type solvers and the
#: uncertainty work on dense (R*C) x (R*C) matrices (docs/spec.md §3), so their memory grows as
#: the square of the number of cells: 4 GiB holds every method for a 64 x 64 mat (the largest in
#: docs/spec.md §10) many times over, and refuses a frame whose matrices would not fit a machine.
DENSE_LIMIT_BYTES = 4 * 2**30

# bytes per (R*C)**2 allocated per thread, the worst case of each method with the solvers it
# hands over to (src/cpp/psmat/iecm): newton's float32 preconditioner (4), active_set's float32
# factor of the free block (4), bounded_newton's double S, its system and its Cholesky factor
# (8 + 8 + 8), least squares' Jacobian, normal matrix, S and factor (4 x 8); fixed_point is
# matrix-free (0)
_BOUNDED_NEWTON = 24
_ACTIVE_SET = 4 + _BOUNDED_NEWTON
_PER_CELL2 = {
    "newton": 4, "active_set": _ACTIVE_SET, "bounded_newton": _BOUNDED_NEWTON, "lm": 32, "bounded_lsq": 32,
    "fixed_point": 0,
    "jacobian": 8,  # the (R*C, R*C) result
    "inverse_jacobian": 32,  # S, its factor, the inverse and the result
    "propagate_uncertainty": 24,  # S, its factor and the inverse
}


def dense_bytes_per_cell2(what: str, *, fallback: bool = True) -> int:
    """Bytes per (R*C)**2 that ``what`` (an IECM method or an uncertainty function) allocates per
    thread; ``newton`` with ``fallback`` includes the active-set solver it hands noisy frames to."""
    n = _PER_CELL2[what]
    return n + _ACTIVE_SET if what == "newton" and fallback else n


def _physical_memory() -> int | None:
    try:
        return int(os.sysconf("SC_PAGE_SIZE")) * int(os.sysconf("SC_PHYS_PAGES"))
    except (AttributeError, ValueError, OSError):  # not every system says (Windows)
        return None


def check_dense_size(shape: tuple[int, int], what: str, *, threads: int = 1, fallback: bool = True) -> None:
    """ValueError, before anything is allocated, when the dense matrices of ``what`` for an
    ``(R, C)`` frame exceed :data:`DENSE_LIMIT_BYTES` per thread, or ``threads`` of them the
    machine's memory (worst cases: the fallbacks included); the message says the size, the need
    and the limit."""
    per = dense_bytes_per_cell2(what, fallback=fallback)
    if per == 0:
        return
    R, C = int(shape[0]), int(shape[1])
    n = R * C
    need = per * n * n
    if need > DENSE_LIMIT_BYTES:
        most = math.isqrt(DENSE_LIMIT_BYTES // per)
        side = math.isqrt(most)
        raise ValueError(f"a {R}x{C} frame has {n} cells: IECM ({what}) works on dense {n}x{n} matrices, about "
                         f"{need / 1e9:.3g} GB per thread, over the limit of {DENSE_LIMIT_BYTES / 1e9:.3g} GB; "
                         f"{what} takes at most {most} cells (e.g. {side}x{side})")
    total, phys = need * threads, _physical_memory()
    if threads > 1 and phys is not None and total > phys:
        raise ValueError(f"a {R}x{C} frame on {threads} threads needs up to {total / 1e9:.3g} GB of dense matrices "
                         f"for IECM ({what}), more than this machine's {phys / 1e9:.3g} GB of memory; use fewer threads")


def as_frames(x, name: str, *, allow_zero: bool, max_ndim: int = 3,
              measured: bool = False) -> tuple[np.ndarray, bool]:
    """Validate a conductance array of shape (R, C) or (T, R, C).

    Returns the array as C-contiguous float64 of shape (T, R, C) and whether the input was a
    single frame. Raises TypeError for non-real dtypes (and, with ``measured``, for integer
    dtypes: measured G comes from ``Circuit.conductance`` as floats, integers are raw ADC
    counts), ValueError for wrong shapes, non-finite, negative or (unless ``allow_zero``)
    zero values.
    """
    a = np.asarray(x)
    if a.dtype == object or not (np.issubdtype(a.dtype, np.floating) or np.issubdtype(a.dtype, np.integer)):
        raise TypeError(f"{name} must be a real numeric array (conductances in S), got dtype {a.dtype}")
    if measured and np.issubdtype(a.dtype, np.integer):
        raise TypeError(
            f"{name} has integer dtype {a.dtype}: raw ADC counts? IECM takes equivalent conductances in S; "
            "convert counts with psmat.Circuit().conductance(counts) (or pass floats if these are conductances)"
        )
    if a.ndim not in (2, 3) or a.ndim > max_ndim:
        allowed = "(R, C)" if max_ndim == 2 else "(R, C) or (T, R, C)"
        raise ValueError(f"{name} must have shape {allowed}, got {a.shape}")
    if a.shape[-1] < 2 or a.shape[-2] < 2:
        raise ValueError(f"{name}: arrays need at least 2 rows and 2 columns, got {a.shape[-2:]}")
    single = a.ndim == 2
    a = np.ascontiguousarray(a, dtype=np.float64)
    if single:
        a = a[None]
    if a.shape[0] == 0:
        raise ValueError(f"{name} has no frames")
    at = (lambda idx: f"cell {idx[1:]}") if single else (lambda idx: f"frame {idx[0]}, cell {idx[1:]}")
    finite_values(a, name, where=at)
    nonnegative(a, name, allow_zero=allow_zero, noun="conductance(s)", where=at,
                hint="; conductances are in S and must be > 0"
                + ("" if allow_zero else " (an open or saturated reading must be masked before IECM)"))
    return a, single


"""IECM inverse g = F^-1(G) (thesis eq. 2.8-2.10, docs/spec.md §3) for frames, batches and streams.

The solvers run in the C++ core (``src/cpp/psmat/iecm/solve_*.cpp``) with the GIL released;
batches are spread over all cores. The recommended methods:

``"newton"`` (default)
    Damped Newton-Krylov on log g: each step solves the SPD system D_G (T∘T) D_G y = b by
    preconditioned conjugate gradients with the exact O((R+C)^3) matrix-free product and a
    float32 Cholesky preconditioner that is reused across iterations and across the frames
    of a stream (rebuilt only when PCG slows down); backtracking line search. When noise makes
    G unreachable by positive g (``fallback``) it restarts the frame from its starting point
    with ``"active_set"``, and a frame that starts from a solution with cells at the bound (the
    previous frame of a stream) goes to ``"active_set"`` directly (``info.used_fallback``).
``"active_set"``
    The bounded (complementarity) problem of noisy frames: F(g) = G on the free cells, g at
    g_floor (~0) on cells where even an empty cell over-predicts the measured G (noise on
    quiet background cells); unique solution (dG/dg is a P-matrix). Solved by sequential
    bound-constrained QPs: at each iterate the linearised complementarity problem is the convex
    QP min 0.5 y'S y + c'y over y >= lo (S = T∘T scaled, the cells' step dg = F(g) y), solved
    exactly by a primal-dual active-set method (free cells: a PCG solve with the matrix-free
    product and a float32 Cholesky factor of the free block, rebuilt or updated when the free
    set changes); then one step on g. Warm-started from the previous frame's solution; 4-5
    steps per noisy frame.

The reference methods, :mod:`psmat.iecm.reference` (``solve`` dispatches to them by name):
``"bounded_newton"`` (the complementarity problem by Fischer-Burmeister Newton; it also finishes
an active-set frame whose line search fails), ``"lm"`` and ``"bounded_lsq"`` (least squares,
eq. 2.9, on log g or on g >= g_floor) and ``"fixed_point"`` (the thesis' eq. 2.10).

Whatever the method, a frame that g_floor decides is not a solution: every cell at g_floor
(status ``all_at_floor``), or g_floor at or above a measured G (``floor_above_data``: since
g <= G cell by cell, that cell is forced to the bound by the floor, not by the data).
"""

from __future__ import annotations

import numpy as np

from . import reference
from ._info import SolveInfo
from ._run import METHODS, RECOMMENDED, make_options, run

__all__ = ["solve", "METHODS", "RECOMMENDED"]


def solve(
    G,
    method: str = "newton",
    *,
    g0=None,
    warm_start: bool = True,
    threads: int | None = None,
    rtol: float = 1e-10,
    max_iter: int | None = None,
    beta: float = 0.05,
    g_floor: float = 1e-12,
    reuse_factorization: bool = True,
    fallback: bool = True,
    progress: bool | None = None,
    return_info: bool = False,
) -> np.ndarray | tuple[np.ndarray, SolveInfo]:
    """Remove crosstalk: cell conductances g from measured equivalent conductances G.

    Parameters
    ----------
    G : array_like, shape (R, C) or (T, R, C)
        Equivalent conductances in S (> 0, finite, a float dtype), e.g.
        ``Circuit.conductance(counts)``; integer arrays (raw ADC counts) are refused.
    method : {"newton", "active_set", "bounded_newton", "lm", "bounded_lsq", "fixed_point"}
        Recommended: ``"newton"`` (any frame; noisy ones are handed to the active-set method)
        or ``"active_set"`` (noisy frames). The others are the reference methods of
        :mod:`psmat.iecm.reference`, to which this call dispatches. See the module docstring.
    g0 : array_like, optional
        Starting point, shape of G (S). Default: a cold start from g0 = G, or for a batch
        with ``warm_start`` the previous frame's solution.
    warm_start : bool
        For (T, R, C): True treats the frames as a recording (each frame starts from the
        previous solution; the frames are split into one contiguous chunk per thread);
        False solves every frame independently from g0 = G.
    threads : int, optional
        Worker threads for a batch; default all cores.
    rtol : float
        Stop when max |F(g) - G| / G <= rtol (dimensionless).
    max_iter : int, optional
        Per-frame iteration limit (default 1000 Newton, active set and bounded Newton,
        200 least squares, 20000 fixed point).
    beta : float
        Fixed-point damping (eq. 2.10; ``"fixed_point"`` only).
    g_floor : float
        Lower bound on g in S (positivity).
    reuse_factorization, fallback : bool
        Newton only: keep the preconditioner across iterations and frames; hand a frame to the
        active-set method when G is not reachable by positive g.
    progress : bool, optional
        Progress bar for batches (default: on for >= 2000 frames when writing to a terminal).
    return_info : bool
        Also return a :class:`SolveInfo`.

    Returns
    -------
    g : numpy.ndarray
        Cell conductances in S, shape of G.
    info : SolveInfo
        Only with ``return_info=True``.

    Warns
    -----
    RuntimeWarning
        When some frame did not converge, including frames that g_floor decided (look at
        ``info.status``).

    Raises
    ------
    TypeError
        For an integer (or non-numeric) G.
    ValueError
        For an unknown method or an invalid option.
    """
    # every option checked as before, whichever method: one message for a bad value
    make_options(method, rtol=rtol, max_iter=max_iter, beta=beta, g_floor=g_floor,
                 reuse_factorization=reuse_factorization, fallback=fallback)
    common = dict(g0=g0, warm_start=warm_start, threads=threads, rtol=rtol, max_iter=max_iter, g_floor=g_floor,
                  progress=progress, return_info=return_info)
    if method in RECOMMENDED:
        return run(G, method, beta=beta, reuse_factorization=reuse_factorization, fallback=fallback, **common)
    if method == "fixed_point":
        return reference.fixed_point(G, beta=beta, **common)
    return getattr(reference, method)(G, **common)  # a reference method: make_options refused any other name

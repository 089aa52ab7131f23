"""IECM inverse g = F^-1(G) (thesis eq. 2.8-2.10, docs/spec.md §3) for frames, batches and streams.

The solvers run in the C++ core (``src/cpp/psmat/iecm/solve_*.cpp``) with the GIL released;
batches are spread over all cores. Methods:

``"newton"`` (default)
    Damped Newton-Krylov on log g: each step solves the SPD system D_G (T∘T) D_G y = b by
    preconditioned conjugate gradients with the exact O((R+C)^3) matrix-free product and a
    float32 Cholesky preconditioner that is reused across iterations and across the frames
    of a stream (rebuilt only when PCG slows down); backtracking line search. When noise makes G unreachable by positive g it
    restarts with ``"active_set"``, and a stream whose previous frame has cells at the bound
    goes to ``"active_set"`` directly.
``"active_set"``
    The bounded (complementarity) problem below by sequential bound-constrained QPs: at each
    iterate the linearised complementarity problem is the convex QP min 0.5 y'S y + c'y over
    y >= lo (S = T∘T scaled, the cells' step dg = F(g) y), solved exactly by a primal-dual
    active-set method (free cells: a PCG solve with the matrix-free product and a float32
    Cholesky factor of the free block, rebuilt when the free set changes); then one step on
    g. Warm-started from the previous frame's solution; 4-5 steps per noisy frame. Same
    solution as ``"bounded_newton"`` (the solution is unique), which finishes a frame whose
    line search fails.
``"bounded_newton"``
    The bounded problem as a complementarity problem: F(g) = G on the free cells, g at
    g_floor (~0) on cells where even an empty cell over-predicts the measured G (noise on
    quiet background cells). Unique solution (dG/dg is a P-matrix); semismooth Newton on the
    Fischer-Burmeister reformulation (SPD systems S + diag(>= 0), Cholesky), non-monotone
    line search. Kept as the reference of ``"active_set"``; it converges linearly.
``"lm"``
    Levenberg-Marquardt least squares (eq. 2.9) on log g, analytic Jacobian (the thesis'
    GSL formulation). On noisy G it can stall: a cell driven towards 0 sits on a plateau of
    the cost in log g. Prefer ``"bounded_newton"`` or ``"bounded_lsq"`` there.
``"bounded_lsq"``
    Least squares (eq. 2.9) on g with the bound g >= g_floor (projected LM, active set).
``"fixed_point"``
    The thesis' iteration g <- g + beta (G - F(g)) (eq. 2.10).

Whatever the method, a frame that g_floor decides is not a solution: every cell at g_floor
(status ``all_at_floor``), or g_floor at or above a measured G (``floor_above_data``: since
g <= G cell by cell, that cell is forced to the bound by the floor, not by the data).
"""

from __future__ import annotations

import time
import warnings
from dataclasses import dataclass, field

import numpy as np

from .. import _core
from .._checks import int_at_most
from ._validate import as_frames, check_dense_size

__all__ = ["solve", "SolveInfo", "METHODS", "make_options"]

METHODS = ("newton", "active_set", "bounded_newton", "lm", "bounded_lsq", "fixed_point")
# newton hands noisy frames to active_set (4-5 iterations per frame on noisy 16 / 32 / 64 twin
# recordings, at most ~12 in a simulated study session); bounded_newton's Fischer-Burmeister
# iteration converges only linearly: about 1 frame in 200 needs a few hundred iterations (most
# need 15-40), so all three allow 1000 before reporting max_iterations
#: the most iterations per frame: the C++ core counts them in an ``int``
_MAX_ITER = 2**31 - 1
_DEFAULT_MAX_ITER = {"newton": 1000, "active_set": 1000, "bounded_newton": 1000, "lm": 200, "bounded_lsq": 200,
                     "fixed_point": 20000}
_STATUS_NAMES = np.array(["converged", "max_iterations", "stalled", "singular", "least_squares", "bounded"])
# statuses set here rather than by the core: the answer is g_floor's, not the data's (docs/spec.md §3)
_FLOOR_REASONS = {
    "floor_above_data": "g_floor = {g_floor:g} S is not below the measured G; it is a positivity bound and must be "
                        "far below the data",
    "all_at_floor": "every cell ended at g_floor = {g_floor:g} S: no signal above the floor",
}


@dataclass
class SolveInfo:
    """Per-frame diagnostics of :func:`solve` (arrays of length T, or scalars for one frame).

    Attributes
    ----------
    iterations, factorizations, krylov_iterations, evaluations : int arrays
        Newton (or method) iterations, matrix factorisations, PCG iterations and
        forward-model evaluations per frame.
    residual : float array
        Final max_a |F(g)_a - G_a| / G_a (relative, dimensionless); for the bounded Newton
        the complementarity residual, i.e. the same over the cells not at the bound.
    cost : float array
        Final 0.5 * sum(((F(g) - G) / G)^2).
    status : str array
        ``converged``, ``bounded`` (noisy G: complementarity solution with ``at_bound``
        cells at g_floor), ``least_squares`` (noisy G: least-squares point),
        ``max_iterations``, ``stalled``, ``singular``, ``all_at_floor`` (every cell at
        g_floor) or ``floor_above_data`` (g_floor >= some measured G).
    converged : bool array
        True for ``converged``, ``bounded`` and ``least_squares`` (never for a frame that
        g_floor decided).
    at_bound : int array
        Cells held at g_floor (bounded methods).
    used_fallback : bool array
        Newton handed over to least squares.
    method : str
    wall_time : float
        Seconds for the whole call.
    threads : int
    """

    iterations: np.ndarray
    factorizations: np.ndarray
    krylov_iterations: np.ndarray
    evaluations: np.ndarray
    residual: np.ndarray
    cost: np.ndarray
    status: np.ndarray
    converged: np.ndarray
    used_fallback: np.ndarray
    at_bound: np.ndarray
    method: str = "newton"
    wall_time: float = 0.0
    threads: int = 1
    extra: dict = field(default_factory=dict)

    _FIELDS = ("iterations", "factorizations", "krylov_iterations", "evaluations", "residual", "cost",
               "converged", "used_fallback", "at_bound")

    @classmethod
    def from_report(cls, rep: dict, method: str, **kw) -> "SolveInfo":
        """From the C++ core's report: a dict of scalars (one frame) or arrays (a batch)."""
        status = rep["status"]
        if isinstance(status, np.ndarray) and status.dtype.kind == "i":
            status = _STATUS_NAMES[status]  # batch reports carry status codes
        return cls(**{k: np.asarray(rep[k]) for k in cls._FIELDS}, status=np.asarray(status), method=method, **kw)

    def flag_floor(self, G_min: np.ndarray, g: np.ndarray, g_floor: float) -> None:
        """Mark the frames that g_floor decided (module docstring) as not converged.

        Parameters
        ----------
        G_min : numpy.ndarray, shape (T,)
            Smallest measured equivalent conductance of each frame, S.
        g : numpy.ndarray, shape (T, R, C)
            The solution, S.
        g_floor : float
            The lower bound the solver used, S.
        """
        shape = np.shape(self.converged)
        above = (np.asarray(G_min) <= g_floor).reshape(shape)
        # the core's own test for a cell at the bound (at_bound)
        floor = np.all(g <= g_floor * (1.0 + 1e-9), axis=(1, 2)).reshape(shape)
        self.status = np.where(above, "floor_above_data", np.where(floor, "all_at_floor", self.status))
        self.converged = self.converged & ~above & ~floor

    def warn_unconverged(self, g_floor: float, stacklevel: int = 3) -> None:
        """One RuntimeWarning naming the statuses of the frames that did not converge, if any."""
        conv = np.atleast_1d(self.converged)
        if conv.all():
            return
        names, counts = np.unique(np.atleast_1d(self.status)[~conv], return_counts=True)
        reasons = [_FLOOR_REASONS[n].format(g_floor=g_floor) for n in names if n in _FLOOR_REASONS]
        warnings.warn(
            f"IECM ({self.method}): {int((~conv).sum())} of {conv.size} frame(s) did not converge "
            f"(status: {', '.join(f'{n} {c}' for n, c in zip(names.tolist(), counts.tolist()))})"
            + "".join(f"; {r}" for r in reasons) + "; pass return_info=True to inspect them",
            RuntimeWarning,
            stacklevel=stacklevel,
        )

    @property
    def all_converged(self) -> bool:
        return bool(np.all(self.converged))

    def summary(self) -> str:
        n = np.size(self.converged)
        return (
            f"{self.method}: {int(np.sum(self.converged))}/{n} frames converged, "
            f"iterations mean {np.mean(self.iterations):.1f} max {np.max(self.iterations)}, "
            f"max residual {np.max(self.residual):.2e}, {self.wall_time:.3f} s on {self.threads} thread(s)"
        )


def make_options(
    method: str = "newton",
    *,
    rtol: float = 1e-10,
    max_iter: int | None = None,
    beta: float = 0.05,
    g_floor: float = 1e-12,
    reuse_factorization: bool = True,
    fallback: bool = True,
) -> "_core.iecm.SolveOptions":
    """Build the C++ solver options, validating every value."""
    if method not in METHODS:
        raise ValueError(f"unknown method {method!r}; choose one of {METHODS}")
    if not (np.isfinite(rtol) and rtol > 0):
        raise ValueError(f"rtol must be a positive number, got {rtol!r}")
    if max_iter is None:
        max_iter = _DEFAULT_MAX_ITER[method]
    if isinstance(max_iter, (float, np.floating)) and float(max_iter).is_integer():
        max_iter = int(max_iter)  # 1000.0 as 1000, as before
    max_iter = int_at_most("max_iter", max_iter, _MAX_ITER, why="the solver counts iterations in a 32-bit integer")
    if not (np.isfinite(beta) and beta > 0):
        raise ValueError(f"beta must be a positive number, got {beta!r}")
    if not (np.isfinite(g_floor) and g_floor > 0):
        raise ValueError(f"g_floor must be a positive conductance in S, got {g_floor!r}")
    o = _core.iecm.SolveOptions()
    o.method = getattr(_core.iecm.Method, method)
    o.rtol = float(rtol)
    o.max_iter = int(max_iter)
    o.beta = float(beta)
    o.g_floor = float(g_floor)
    o.reuse_factorization = bool(reuse_factorization)
    o.fallback = bool(fallback)
    return o


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
):
    """Remove crosstalk: cell conductances g from measured equivalent conductances G.

    Parameters
    ----------
    G : array_like, shape (R, C) or (T, R, C)
        Equivalent conductances in S (> 0, finite, a float dtype), e.g.
        ``Circuit.conductance(counts)``; integer arrays (raw ADC counts) are refused.
    method : {"newton", "active_set", "bounded_newton", "lm", "bounded_lsq", "fixed_point"}
        See the module docstring.
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
        Stop when max |F(g) - G| / G <= rtol.
    max_iter : int, optional
        Per-frame iteration limit (default 1000 Newton, 200 least squares, 20000 fixed point).
    beta : float
        Fixed-point damping (eq. 2.10).
    g_floor : float
        Lower bound on g in S (positivity).
    reuse_factorization, fallback : bool
        Newton: keep the preconditioner across iterations and frames; restart with the
        bounded Newton when G is not reachable by positive g.
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
    """
    frames, single = as_frames(G, "G", allow_zero=False, measured=True)
    opts = make_options(method, rtol=rtol, max_iter=max_iter, beta=beta, g_floor=g_floor,
                        reuse_factorization=reuse_factorization, fallback=fallback)
    init = None
    if g0 is not None:
        init, _ = as_frames(g0, "g0", allow_zero=False)
        if init.shape != frames.shape:
            raise ValueError(f"g0 must have the shape of G {np.shape(G)}, got {np.shape(g0)}")
    T = frames.shape[0]
    nthreads = _core.iecm.hardware_threads() if threads is None else int(threads)
    if nthreads < 1:
        raise ValueError(f"threads must be >= 1, got {threads!r}")
    nthreads = min(nthreads, T)
    check_dense_size(frames.shape[1:], method, threads=nthreads, fallback=fallback)  # before the core allocates

    t0 = time.perf_counter()
    if single:
        out, rep = _core.iecm.solve_frame(frames[0], opts, None if init is None else init[0])
        info = SolveInfo.from_report(rep, method, threads=1)
    else:
        job = _core.iecm.BatchJob(frames, opts, bool(warm_start), nthreads, init)
        job.start()
        _wait(job, T, progress)
        out = job.g().reshape(frames.shape)
        info = SolveInfo.from_report(job.reports(), method, threads=nthreads)
    info.wall_time = time.perf_counter() - t0
    info.flag_floor(frames.min(axis=(1, 2)), out.reshape(frames.shape), g_floor)
    info.warn_unconverged(g_floor)
    return (out, info) if return_info else out


def _wait(job, total: int, progress: bool | None) -> None:
    """Wait for a BatchJob, driving a progress bar and honouring Ctrl-C."""
    from psmat._progress import tqdm

    show = progress if progress is not None else (total >= 2000)
    bar = tqdm(total=total, unit="frame", desc="IECM", disable=None if show else True, leave=False)
    try:
        done = 0
        while not job.wait(0.1):
            c = job.completed
            bar.update(c - done)
            done = c
        bar.update(job.completed - done)
    except KeyboardInterrupt:
        job.cancel()
        job.wait(-1.0)
        raise
    finally:
        bar.close()

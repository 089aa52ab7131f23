"""What every IECM method shares: the names, the options of the C++ core, and one run over frames.

:func:`run` validates G, builds the options, solves a frame (``psmat._core.iecm.solve_frame``)
or a batch on worker threads (``psmat._core.iecm.BatchJob``, the GIL released, a progress bar
and Ctrl-C honoured) and gathers the core's reports into a :class:`~psmat.iecm.SolveInfo`.
The public entry points are :func:`psmat.iecm.solve` (the recommended methods) and the
functions of :mod:`psmat.iecm.reference`.
"""

from __future__ import annotations

import time

import numpy as np

from .. import _core
from .._checks import int_at_most
from ._info import SolveInfo
from ._validate import as_frames, check_dense_size

__all__ = ["RECOMMENDED", "REFERENCE", "METHODS", "make_options", "run"]

#: the methods to use: Newton (noisy frames handed to the active-set method) and the active-set method
RECOMMENDED = ("newton", "active_set")
#: the reference methods (psmat.iecm.reference): the thesis' iterations and the slower bounded Newton
REFERENCE = ("bounded_newton", "lm", "bounded_lsq", "fixed_point")
METHODS = RECOMMENDED + REFERENCE

# newton hands noisy frames to active_set (4-5 iterations per frame on noisy 16 / 32 / 64 twin
# recordings, at most ~12 in a simulated study session); bounded_newton's Fischer-Burmeister
# iteration converges only linearly: about 1 frame in 200 needs a few hundred iterations (most
# need 15-40), so all three allow 1000 before reporting max_iterations
#: the most iterations per frame: the C++ core counts them in an ``int``
_MAX_ITER = 2**31 - 1
_DEFAULT_MAX_ITER = {"newton": 1000, "active_set": 1000, "bounded_newton": 1000, "lm": 200, "bounded_lsq": 200,
                     "fixed_point": 20000}


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
    """Build the C++ solver options, validating every value (see :func:`psmat.iecm.solve`)."""
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


def run(
    G,
    method: str,
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
    """Solve the frames of G with ``method``; the parameters and the result are those of
    :func:`psmat.iecm.solve`."""
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
        info = SolveInfo.from_reports([rep], method, single=True, threads=1)
    else:
        job = _core.iecm.BatchJob(frames, opts, bool(warm_start), nthreads, init)
        job.start()
        _wait(job, T, progress)
        out = job.g().reshape(frames.shape)
        info = SolveInfo.from_reports(job.reports(), method, threads=nthreads)
    info.wall_time_s = time.perf_counter() - t0
    info.flag_floor(frames.min(axis=(1, 2)), out.reshape(frames.shape), g_floor)
    info.warn_unconverged(g_floor)
    return (out, info) if return_info else out


def _wait(job, total: int, progress: bool | None) -> None:
    """Wait for a BatchJob, driving a progress bar and honouring Ctrl-C (the core waits on the
    futures of its workers; 0.1 s is the refresh of the bar and of Ctrl-C)."""
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

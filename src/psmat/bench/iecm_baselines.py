"""The thesis-style baselines of ``python -m psmat.bench iecm``, timed in the same process as psmat:
the NumPy fixed point (eq. 2.10) for a fixed number of iterations and to the accuracy target,
the thesis' quick fixed point (25 iterations, β 0.05) on noisy frames, and scipy ``least_squares``
with a numerical Jacobian (:mod:`psmat.bench.baselines.iecm_numpy`)."""

from __future__ import annotations

import os
import time

import numpy as np

from .baselines.iecm_numpy import jacobian_numpy, solve_fixed_point_numpy, solve_least_squares_scipy
from .iecm_setup import ACCURACY_TARGET, ERROR_THRESHOLD_S, complementarity_residual, errors, row, scene

__all__ = ["measure_fixed_point_numpy", "measure_quick_fixed_point_numpy", "measure_fixed_point_to_target",
           "measure_least_squares"]


def measure_fixed_point_numpy(size: int, frames: int, seed: int, max_iter: int = 2000,
                              beta: float = 0.05) -> dict:
    """NumPy fixed point (eq. 2.10), cold from g0 = G, a fixed number of iterations, batched over frames."""
    g, G = scene(size, frames + 1, seed)
    g, G = g[1:], G[1:]
    t0 = time.perf_counter()
    g_hat, info = solve_fixed_point_numpy(G, beta=beta, rtol=0.0, max_iter=max_iter)
    secs = time.perf_counter() - t0
    e_loaded, e_all = errors(g_hat, g)
    return row(size=size, mode="cold", solver=f"numpy fixed point β={beta:g}, {max_iter} it",
                threads=1, frames=frames, calls=1, seconds=secs, fps=frames / secs,
                fps_per_core=frames / secs, err_loaded=e_loaded, err_all=e_all,
                iterations=float(np.mean(info["iterations"])),
                note="vectorised over the frames (NumPy batched Cholesky)")


def measure_quick_fixed_point_numpy(size: int, frames: int, scene_frames: int, seed: int, min_time: float,
                                    max_time: float, cores: int, noise_v: float = 1e-3, beta: float = 0.05,
                                    iterations: int = 25) -> dict:
    """The thesis' quick fixed point (eq. 2.10) in NumPy on the noisy frames psmat's noisy rows solve.

    Every frame runs cold from ``g0 = G`` for exactly ``iterations`` updates ``g <- g + beta (G - F(g))``
    (``rtol = 0``), as the thesis' Python module runs each frame independently; the frames are
    iterated together in one batched call of :func:`solve_fixed_point_numpy`, which also evaluates
    ``F`` once after the last update for its residual (``iterations`` + 1 forward solves a frame).

    Parameters
    ----------
    size : int
        Array size N (N x N cells).
    frames : int
        Frames solved, the first of the recording psmat's noisy streaming row solves.
    scene_frames : int
        Frames of that recording (``frames <= scene_frames``): the scene is drawn exactly as for
        psmat's row (``scene(size, scene_frames + 1, seed, noise_v)``, less its priming frame 0), so
        the noise on these frames is the same.
    seed : int
        Seed of the scene.
    min_time, max_time : float
        The batched call is repeated until ``min_time`` s are spent, never starting one that would
        pass ``max_time`` s (s).
    cores : int
        Usable CPUs of the machine; ``fps_per_core = fps / cores`` (NumPy's BLAS may use them all).
    noise_v : float
        Voltage noise at the ADC node (V), 12-bit quantisation (:func:`psmat.bench.iecm_setup.scene`).
    beta : float
        Damping factor (thesis: 0.05).
    iterations : int
        Updates per frame (the quick method: 25).

    Returns
    -------
    dict
        One row (:func:`psmat.bench.iecm_setup.row`), ``mode="cold"``; ``max_residual`` is the
        complementarity residual of the returned g, computed as for every solver.
    """
    if not 1 <= frames <= scene_frames:
        raise ValueError(f"frames must be in 1..scene_frames={scene_frames}, got {frames}")
    g, G = scene(size, scene_frames + 1, seed, noise_v)
    g, G = g[1:frames + 1], G[1:frames + 1]

    solve_fixed_point_numpy(G[:2], beta=beta, rtol=0.0, max_iter=1)  # untimed warm-up (NumPy, BLAS)
    wall = cpu = 0.0
    calls = 0
    while True:
        c0, t0 = time.process_time(), time.perf_counter()
        g_hat, info = solve_fixed_point_numpy(G, beta=beta, rtol=0.0, max_iter=iterations)
        dt = time.perf_counter() - t0
        wall += dt
        cpu += time.process_time() - c0
        calls += 1
        if wall >= min_time or wall + dt > max_time:
            break
    fps = frames * calls / wall
    e_loaded, e_all = errors(g_hat, g)
    blas = os.environ.get("OPENBLAS_NUM_THREADS") or os.environ.get("OMP_NUM_THREADS")
    note = (f"cold from g0 = G every frame, {iterations} updates (+1 forward solve for the residual), "
            f"the {frames} frames batched in one NumPy call (one process, no pool); BLAS threads "
            f"{'limited to ' + blas if blas else 'left at their default'} on {cores} usable core(s): "
            f"{cpu / wall:.2f} cores busy (CPU/wall); fps/core = fps / {cores}")
    return row(size=size, mode="cold", solver=f"numpy fixed point β={beta:g}, {iterations} it (thesis quick), noisy G",
                threads=cores, frames=frames, calls=calls, seconds=wall, fps=fps, fps_per_core=fps / cores,
                err_loaded=e_loaded, err_all=e_all,
                iterations=float(np.mean(info["iterations"])), max_iterations=float(np.max(info["iterations"])),
                max_residual=complementarity_residual(g_hat, G), noise_v=noise_v, note=note)


def measure_fixed_point_to_target(size: int, seed: int, time_limit: float, beta: float = 0.05,
                                  max_iter: int = 10_000_000) -> dict:
    """Iterations the NumPy fixed point needs to reach the 1e-6 target on frame 1 (oracle stop)."""
    g, G = scene(size, 2, seed)
    g, G = g[1], G[1]
    g_hat, info = solve_fixed_point_numpy(G, beta=beta, rtol=0.0, max_iter=max_iter, g_true=g,
                                          target_error=ACCURACY_TARGET,
                                          error_threshold=ERROR_THRESHOLD_S, time_limit=time_limit)
    secs = info["wall_time"]
    e_loaded, e_all = errors(g_hat, g)
    it = int(info["iterations"])
    lo, hi = _jacobian_spread(g)
    if info["converged"]:
        note = f"{it} iterations to reach {ACCURACY_TARGET:g} on cells >= {ERROR_THRESHOLD_S:g} S (oracle stop)"
    else:
        note = f"not at {ACCURACY_TARGET:g} after {it} iterations ({time_limit:.0f} s cap)"
        est = _extrapolate_iterations(info["error_history"], ACCURACY_TARGET)
        if est is not None and not beta * hi > 2:
            note += (f"; the error's decay over the last half extrapolates to ~{est:.2g} iterations "
                     f"(~{est * secs / max(it, 1):.2g} s per frame at this speed)")
    if np.isfinite(hi):
        spread = f"eigenvalues {lo:.2g} ... {hi:.3g}" if np.isfinite(lo) else f"largest eigenvalue {hi:.3g}"
        note += f"; dG/dg at the solution has {spread}, so β·λmax = {beta * hi:.2g}"
        if beta * hi > 2:
            note += " > 2: the iteration is unstable at this size"
        elif np.isfinite(lo):
            note += f" and the slowest mode contracts by 1 - β·λmin = {1 - beta * lo:.6f} per iteration"
    return row(size=size, mode="cold", solver=f"numpy fixed point β={beta:g}, to {ACCURACY_TARGET:g}",
                threads=1, frames=1, calls=1, seconds=secs, fps=1.0 / secs, fps_per_core=1.0 / secs,
                err_loaded=e_loaded, err_all=e_all, iterations=float(it), note=note)


def _jacobian_spread(g: np.ndarray) -> tuple[float, float]:
    """Smallest and largest eigenvalue of dG/dg at g (NaN where too costly).

    ``J = D² (T∘T)`` with ``D = diag(G)`` is similar to the symmetric ``D (T∘T) D``, so its
    eigenvalues are real and non-negative; above 32×32 only the largest (ARPACK).
    """
    try:
        J = jacobian_numpy(g)
        if J.shape[0] <= 1024:
            ev = np.linalg.eigvals(J).real
            return float(ev.min()), float(ev.max())
        from scipy.sparse.linalg import eigs

        hi = float(np.abs(eigs(J, k=1, which="LM", return_eigenvectors=False)[0]))
        return float("nan"), hi
    except Exception:  # informative only
        return float("nan"), float("nan")


def _extrapolate_iterations(history: np.ndarray, target: float) -> float | None:
    """Iterations to reach ``target`` at the geometric decay rate seen over the second half."""
    h = np.asarray(history, dtype=float)
    k = len(h) - 1
    if k < 20 or not np.all(np.isfinite(h[[k // 2, k]])) or h[k] <= 0:
        return None
    rate = (h[k] / h[k // 2]) ** (1.0 / (k - k // 2))
    if not 0 < rate < 1:
        return None
    return k + np.log(target / h[k]) / np.log(rate)


def measure_least_squares(size: int, frames: int, seed: int, param: str = "bounds") -> dict:
    """scipy.optimize.least_squares, numerical Jacobian, cold from g0 = G, frame by frame."""
    g, G = scene(size, frames + 1, seed)
    g, G = g[1:], G[1:]
    out = np.empty_like(g)
    nfev, njev = [], []
    t0 = time.perf_counter()
    for t in range(frames):
        out[t], res = solve_least_squares_scipy(G[t], param=param)
        nfev.append(res.nfev)
        njev.append(res.njev if res.njev is not None else np.nan)
    secs = time.perf_counter() - t0
    e_loaded, e_all = errors(out, g)
    what = "g in (0, inf), trf" if param == "bounds" else "log g, trf"
    return row(size=size, mode="cold", solver=f"scipy least_squares 2-point, {what}", threads=1,
                frames=frames, calls=1, seconds=secs, fps=frames / secs, fps_per_core=frames / secs,
                err_loaded=e_loaded, err_all=e_all, iterations=float(np.mean(njev)),
                note=f"{np.mean(nfev):.0f} residual evaluations + {np.mean(njev):.0f} numerical "
                     f"Jacobians ({size * size} forward solves each) per frame; iterations = Jacobians")


"""The sensor model (MPI hysteresis + creep, thesis eq. 2.15-2.24) in plain NumPy: the sensor
benchmark's throughput baseline.

Independent of psmat's C++ model: it reads only a model's parameters (``params``,
``thresholds``, ``weights`` of a :class:`psmat.sensor.MPICreep`) and runs the play operators,
the creep filters and, for the inverse, a bisection of the algebraic loop itself, vectorised
over cells with a Python loop over samples. ``tests/integration/test_bench_baseline.py`` checks that it
agrees with the C++ model, so that the benchmark compares like with like.

Pressures in psi, conductances in S, the sample interval ``dt`` in s.
"""

from __future__ import annotations

from typing import Any

import numpy as np

__all__ = ["direct_numpy", "inverse_numpy"]


def _setup(model: Any, dt: float, cells: int) -> tuple:
    """Parameters and rest state: (params, r, b, w, e^{-l dt}, y, y_c, p_prev)."""
    prm = model.params
    l, w = np.asarray(prm["l"]), np.asarray(prm["w"])
    zeros = np.zeros
    return (prm, model.thresholds, model.weights, w, np.exp(-l * dt), zeros((len(model.thresholds), cells)),
            zeros((len(l), cells)), zeros(cells))


def direct_numpy(model: Any, p: np.ndarray, dt: float) -> np.ndarray:
    """Direct model g(p) (eq. 2.15-2.24) from rest.

    Parameters
    ----------
    model : psmat.sensor.MPICreep
        The model whose parameters are used.
    p : numpy.ndarray, shape (T, cells)
        Pressure in psi.
    dt : float
        Sample interval in s.

    Returns
    -------
    numpy.ndarray
        Conductance in S, shape of ``p``.
    """
    prm, r, b, w, decay, y, yc, p_prev = _setup(model, dt, p.shape[1])
    out = np.empty_like(p)
    for t in range(p.shape[0]):
        x = p[t]
        y = np.maximum(x - r[:, None], np.minimum(x, y))
        yc = decay[:, None] * yc + (1 - decay[:, None]) * p_prev
        out[t] = prm["a1"] * x + prm["a2"] * x**2 + prm["a3"] * x**3 + b @ y + w @ yc
        p_prev = x
    return out


def inverse_numpy(model: Any, g: np.ndarray, dt: float, iters: int = 60) -> np.ndarray:
    """Inverse model p(g) from rest: per sample, ``iters`` bisection steps on [0, 64] psi for all cells at once.

    Parameters
    ----------
    model : psmat.sensor.MPICreep
        The model whose parameters are used.
    g : numpy.ndarray, shape (T, cells)
        Conductance in S.
    dt : float
        Sample interval in s.
    iters : int
        Bisection steps per sample.

    Returns
    -------
    numpy.ndarray
        Pressure in psi, shape of ``g``.
    """
    prm, r, b, w, decay, y, yc, p_prev = _setup(model, dt, g.shape[1])
    out = np.empty_like(g)
    for t in range(g.shape[0]):
        yc = decay[:, None] * yc + (1 - decay[:, None]) * p_prev
        target = g[t] - w @ yc
        lo, hi = np.zeros(g.shape[1]), np.full(g.shape[1], 64.0)
        for _ in range(iters):
            mid = 0.5 * (lo + hi)
            h = prm["a1"] * mid + prm["a2"] * mid**2 + prm["a3"] * mid**3 + b @ np.maximum(mid - r[:, None], np.minimum(mid, y))
            below = h < target
            lo = np.where(below, mid, lo)
            hi = np.where(below, hi, mid)
        x = 0.5 * (lo + hi)
        y = np.maximum(x - r[:, None], np.minimum(x, y))
        out[t] = p_prev = x
    return out

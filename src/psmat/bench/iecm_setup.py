"""What every row of the IECM benchmark (:mod:`psmat.bench.iecm`) shares: its frames, its
accuracy measure, the row record and the work per array size.

psmat's rows (:mod:`psmat.bench.iecm`), the baselines' rows (:mod:`psmat.bench.iecm_baselines`)
and the two-build comparison (:mod:`psmat.bench.iecm_native`) all import from here, and this
module imports none of them.
"""

from __future__ import annotations

import numpy as np

from .. import twin
from .baselines.iecm_numpy import forward_numpy

__all__ = ["ERROR_THRESHOLD_S", "ACCURACY_TARGET", "HEAVY_CELLS", "NOISY_LABEL", "scene", "errors",
           "complementarity_residual", "row", "settings"]

ERROR_THRESHOLD_S = 1e-4   # cells with g >= this (S) carry the accuracy target
ACCURACY_TARGET = 1e-6     # relative error reached by "Newton accuracy"
HEAVY_CELLS = 32 * 32      # above this, psmat entries run isolated in a child process
NOISY_LABEL = "psmat newton, noisy G (1 mV, 12 bit)"


def scene(size: int, frames: int, seed: int, noise_v: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """True g and G (independent NumPy forward), both (T, size, size), in S.

    Parameters
    ----------
    size : int
        Array size N (N x N cells).
    frames : int
        Frames T of the swaying-feet recording (:func:`psmat.twin.swaying_feet`).
    seed : int
        Seed of the scene.
    noise_v : float
        With ``noise_v`` > 0 (V) the G is what the mat would measure: the measurement chain of
        docs/spec.md §2 (psmat.Circuit, improved prototype) with that voltage noise and 12-bit
        quantisation, inverted back to G.
    """
    g = twin.swaying_feet(frames, (size, size), seed=seed)
    G = forward_numpy(g)
    if noise_v > 0:
        from ..circuit import Circuit

        c = Circuit()
        G = c.conductance(c.counts(G, noise_v=noise_v, rng=seed + 1))
    return g, G


def errors(g_hat: np.ndarray, g: np.ndarray) -> tuple[float, float]:
    """Largest relative error ``|ĝ - g| / g`` over cells with ``g >= ERROR_THRESHOLD_S`` and over all cells."""
    rel = np.abs(g_hat - g) / g
    mask = g >= ERROR_THRESHOLD_S
    return float(rel[mask].max()) if mask.any() else float("nan"), float(rel.max())


def complementarity_residual(g: np.ndarray, G: np.ndarray, g_floor: float = 1e-12) -> float:
    """Largest Fischer-Burmeister residual ``max |phi|`` of the bounded problem (docs/spec.md §3) over
    cells and frames.

    ``phi = sqrt(a^2 + b^2) - a - b`` with ``a = (g - g_floor)/G`` and ``b = (F(g) - G)/G``
    (dimensionless); zero exactly when g >= g_floor, F(g) >= G and one of them is tight. phi is
    negative where both are slack (g above the floor and F(g) > G), hence the absolute value.
    """
    import psmat.iecm as iecm

    a = (g - g_floor) / G
    b = (iecm.forward(g) - G) / G
    return float(np.max(np.abs(np.hypot(a, b) - a - b)))


def row(**kw) -> dict:
    """One row of the benchmark's table: every field, NaN / empty where not measured, then ``kw``."""
    base = dict(size=None, mode="", solver="", threads=1, frames=0, calls=0, seconds=float("nan"),
                fps=float("nan"), fps_per_core=float("nan"), err_loaded=float("nan"),
                err_all=float("nan"), iterations=float("nan"), factorizations=float("nan"),
                max_iterations=float("nan"), max_residual=float("nan"), noise_v=0.0,
                note="", target="", target_met=None)
    base.update(kw)
    return base


def settings(size: int, quick: bool, smoke: bool) -> dict:
    """Default frames and budgets (s) per array size, for a full, ``--quick`` or ``--smoke`` run."""
    if size <= 16:
        s = dict(frames=2000, fp_frames=20, lsq_frames=2, fp_target_s=60.0)
    elif size <= 32:
        s = dict(frames=200, fp_frames=2, lsq_frames=0, fp_target_s=30.0)
    else:
        s = dict(frames=20, fp_frames=1, lsq_frames=0, fp_target_s=30.0)
    s["lsq_params"] = ("bounds", "log")
    if quick:
        s.update(frames=max(4, s["frames"] // 4), fp_frames=max(1, s["fp_frames"] // 4),
                 lsq_frames=min(1, s["lsq_frames"]), fp_target_s=10.0 if size <= 32 else 0.0,
                 lsq_params=("log",))
    if smoke:
        s.update(fp_frames=1, lsq_frames=0, fp_target_s=0.0)
    return s

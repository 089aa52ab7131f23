"""Figures of an identified sensor model (thesis Fig. 2.37-2.39), matplotlib's object API (Agg)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .mpi_creep import MPICreep

__all__ = ["plot_fit", "plot_pressure_recovery"]


def _figure(nrows: int = 1, ncols: int = 1, size=(10, 4)):
    from matplotlib.figure import Figure

    fig = Figure(figsize=size, constrained_layout=True)
    return fig, fig.subplots(nrows, ncols, squeeze=False)


def plot_fit(model: MPICreep, p, g, dt: float, path: str | Path, title: str = "") -> Path:
    """Measured vs modelled conductance over time and against pressure (Fig. 2.37-2.38).

    Parameters
    ----------
    model : MPICreep
    p, g : array_like, shape (T,)
        Applied pressure (psi) and measured conductance (S) of one experiment.
    dt : float
        Sampling period (s).
    path : str or Path
        PNG to write.
    """
    p, g = np.asarray(p, float), np.asarray(g, float)
    gm = model.direct(p, dt)
    t = np.arange(len(p)) * dt / 60.0
    sse = float(np.mean((g - gm) ** 2))
    fig, ax = _figure(1, 2, (12, 4))
    ax[0, 0].plot(t, g * 1e3, lw=0.8, label="measured")
    ax[0, 0].plot(t, gm * 1e3, lw=0.8, label="model")
    ax[0, 0].set_xlabel("time (min)")
    ax[0, 0].set_ylabel("conductance (mS)")
    ax[0, 0].legend()
    ax[0, 1].plot(p, g * 1e3, ".", ms=2, label="measured")
    ax[0, 1].plot(p, gm * 1e3, lw=0.8, label="model")
    ax[0, 1].set_xlabel("applied pressure (psi)")
    ax[0, 1].set_ylabel("conductance (mS)")
    ax[0, 1].legend()
    fig.suptitle(f"{title} SSE_N = {sse:.3g} S² (eq. 2.26)".strip())
    path = Path(path)
    fig.savefig(path, dpi=100)
    return path


def plot_pressure_recovery(model: MPICreep, p, g, dt: float, path: str | Path, title: str = "") -> Path:
    """Pressure recovered by the inverse model against the applied one (Fig. 2.39)."""
    p, g = np.asarray(p, float), np.asarray(g, float)
    p_hat = model.inverse(g, dt)
    t = np.arange(len(p)) * dt / 60.0
    rms = float(np.sqrt(np.mean((p_hat - p) ** 2)))
    fig, ax = _figure(1, 2, (12, 4))
    ax[0, 0].plot(t, p, lw=0.8, label="applied")
    ax[0, 0].plot(t, p_hat, lw=0.8, label="recovered (inverse model)")
    ax[0, 0].set_xlabel("time (min)")
    ax[0, 0].set_ylabel("pressure (psi)")
    ax[0, 0].legend()
    ax[0, 1].plot(p, p_hat - p, ".", ms=2)
    ax[0, 1].axhline(0, color="k", lw=0.6)
    ax[0, 1].set_xlabel("applied pressure (psi)")
    ax[0, 1].set_ylabel("recovered - applied (psi)")
    fig.suptitle(f"{title} RMS error {rms:.3g} psi".strip())
    path = Path(path)
    fig.savefig(path, dpi=100)
    return path

"""Figures of the sensor: an identified model (thesis Fig. 2.37-2.39) and the material metrics
(radar chart, Fig. 2.34; hysteresis loops, Fig. 2.33); matplotlib's object API (Agg)."""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from .metrics import CREEP_RADAR_TIME_S, RADAR_AXES, as_run, hysteresis_loops, table_summary
from ._mpi_creep import MPICreep

__all__ = ["plot_fit", "plot_pressure_recovery", "radar_chart", "plot_hysteresis_loops"]


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


# --------------------------------------------------------------------------- material metrics (eq. 2.1-2.4)
def _new_figure(figsize: tuple[float, float]) -> Any:
    # Object-oriented matplotlib: no pyplot state, rendered by Agg when saved to PNG.
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=figsize, layout="constrained")
    FigureCanvasAgg(fig)
    return fig


def radar_chart(table: Sequence[Mapping[str, Any]] | Mapping[str, Mapping[str, float]],
                path: str | os.PathLike[str], creep_time_s: float = CREEP_RADAR_TIME_S,
                title: str = "Non-linear effects of the materials") -> Path:
    """Radar chart of the non-linear effects of each material (thesis Fig. 2.34).

    Axes: variability (CV²), drift, creep × ``creep_time_s`` (25 min, the load period of the
    long test, so every axis is a relative measure) and hysteresis; one polygon per material.

    Parameters
    ----------
    table : list of dict or mapping
        :func:`material_table` output, or its :func:`table_summary`.
    path : path-like
        Output image (the format follows the extension; PNG by Agg).
    creep_time_s : float
        Multiplier of the creep axis (s).
    title : str
        Figure title.

    Returns
    -------
    pathlib.Path
        ``path``.
    """
    summary = table if isinstance(table, Mapping) else table_summary(table)
    if not summary:
        raise ValueError("no material to draw (the table has no 'mean' rows)")
    fig = _new_figure((6.0, 6.0))
    ax = fig.add_subplot(projection="polar")
    n = len(RADAR_AXES)
    ang = np.linspace(0.0, 2 * np.pi, n, endpoint=False)
    for material, vals in summary.items():
        v = np.array([vals.get(m, np.nan) * (creep_time_s if m == "creep" else 1.0) for m, _ in RADAR_AXES])
        ax.plot(np.append(ang, ang[0]), np.append(v, v[0]), marker="o", label=str(material))
        ax.fill(np.append(ang, ang[0]), np.nan_to_num(np.append(v, v[0])), alpha=0.15)
    ax.set_xticks(ang)
    ax.set_xticklabels([lab for _, lab in RADAR_AXES])
    ax.set_ylim(bottom=0.0)
    ax.set_title(title, pad=24)
    ax.legend(loc="upper right", bbox_to_anchor=(1.25, 1.1))
    out = Path(path)
    fig.savefig(out, dpi=100)
    return out


def plot_hysteresis_loops(run: Any, path: str | os.PathLike[str], settle_fraction: float = 0.5) -> Path:
    """Conductance vs. pressure loops of a hysteresis run (cell- and repetition-averaged, thesis Fig. 2.33).

    The cell-averaged samples are drawn faintly behind the plateau values of each loop
    (rising branch solid, falling branch dashed); the legend gives eq. 2.4 for each loop.

    Parameters
    ----------
    run : run-like
        Descending and/or ascending hysteresis run.
    path : path-like
        Output image.
    settle_fraction : float
        As in :func:`hysteresis_loops`.

    Returns
    -------
    pathlib.Path
        ``path``.
    """
    r = as_run(run)
    loops = hysteresis_loops(r, settle_fraction)
    fig = _new_figure((7.0, 5.0))
    ax = fig.add_subplot()
    known = ~np.isnan(r.g)
    with np.errstate(invalid="ignore", divide="ignore"):  # a sample with no cell known: NaN, a gap in the line
        g_mean = np.where(known, r.g, 0.0).sum(axis=1) / known.sum(axis=1)
    ax.plot(r.p, g_mean * 1e3, color="0.8", lw=0.5, zorder=0)
    for h in loops:
        line, = ax.plot(h.p_psi, h.g_up * 1e3, marker=".", label=f"{h.kind} {h.level:g} psi: {h.value:.3f}")
        ax.plot(h.p_psi, h.g_down * 1e3, marker=".", ls="--", color=line.get_color())
    ax.set_xlabel("pressure (psi)")
    ax.set_ylabel("conductance, mean over cells (mS)")
    ax.set_title(f"{r.name}: hysteresis loops (eq. 2.4)")
    ax.legend(fontsize="small", ncol=2)
    out = Path(path)
    fig.savefig(out, dpi=100)
    return out

"""Figure of the spine over time (thesis Fig. 4.8/§4.2: the model drawn on screen while
recording); matplotlib's object API, imported when a figure is drawn."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike

from .._checks import positive_int, real_array

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = ["plot_spine"]


def plot_spine(points: ArrayLike, t: ArrayLike | None = None, *, every: int | None = None,
               path: str | Path | None = None, title: str = "") -> Figure:
    """Spine shapes at several times, coloured by time (as thesis Fig. 4.8).

    Sensor 1 (the upper one) is drawn at the top: the vertical axis is u, increasing down the
    back, the horizontal axis v (both in mm, equal aspect; see :func:`spine_points`).

    Parameters
    ----------
    points : array_like, (T, 5, 2) or (5, 2)
        (u, v) of the sensors in mm, from :func:`psmat.posture.spine_points`.
    t : array_like, (T,), optional
        Time of each frame (s); frame indices when omitted.
    every : int, optional
        Draw every ``every``-th frame (the last one always); by default about 20 shapes.
    path : str or Path, optional
        PNG to write.
    title : str
        Figure title.

    Returns
    -------
    matplotlib.figure.Figure
    """
    from matplotlib import colormaps
    from matplotlib.cm import ScalarMappable
    from matplotlib.colors import Normalize
    from matplotlib.figure import Figure

    p = real_array(points, "points", unit="mm")
    if p.ndim == 2:
        p = p[None]
    if p.ndim != 3 or p.shape[0] < 1 or p.shape[1] < 2 or p.shape[2] != 2:
        raise ValueError(f"points must have shape (T, 5, 2) or (5, 2) in mm with T >= 1, got {np.shape(points)}")
    n = p.shape[0]
    if t is None:
        tt, t_label = np.arange(n, dtype=float), "frame"
    else:
        tt, t_label = real_array(t, "t", unit="s"), "time (s)"
        if tt.shape != (n,):
            raise ValueError(f"t must have shape ({n},) to match points, got {tt.shape}")
    if every is None:
        every = max(1, n // 20)
    else:
        every = positive_int("every", every)
    idx = np.unique(np.r_[np.arange(0, n, every), n - 1])

    lo, hi = float(tt[idx].min()), float(tt[idx].max())
    norm = Normalize(lo, hi if hi > lo else lo + 1.0)
    cmap = colormaps["viridis"]
    fig = Figure(figsize=(5, 6), constrained_layout=True)
    ax = fig.subplots()
    for k in idx:
        ax.plot(p[k, :, 1], p[k, :, 0], "-o", color=cmap(norm(tt[k])), lw=1.2, ms=3)
    ax.set_xlabel("v (mm)")
    ax.set_ylabel("u, down the back from sensor 1 (mm)")
    ax.set_aspect("equal", adjustable="datalim")
    ax.invert_yaxis()
    fig.colorbar(ScalarMappable(norm=norm, cmap=cmap), ax=ax, label=t_label)
    ax.set_title(title or "spine shape (eq. 4.4)")
    if path is not None:
        fig.savefig(Path(path), dpi=100)
    return fig

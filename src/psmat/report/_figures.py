"""A report's figures as PNG bytes in base64 (matplotlib's Agg canvas, no window, no pyplot state).

Few and small (at most three per session, 80 dpi), so a report takes seconds: the pressure images
(mean and peak, kPa), the CoP (stabilogram and time series, cm) and, with a platform, the overlay
of both traces after the same preprocessing.
"""

from __future__ import annotations

import base64
import io
from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..profile import Geometry

__all__ = ["pressure_images_png", "cop_png", "overlay_png", "DPI"]

#: resolution of every figure, dots per inch
DPI = 80


def _figure(width_in: float, height_in: float) -> Any:
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(width_in, height_in), dpi=DPI, layout="constrained")
    FigureCanvasAgg(fig)
    return fig


def _png(fig: Any) -> str:
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=DPI)
    return base64.b64encode(buf.getvalue()).decode("ascii")


def _on_grid(img: NDArray[np.float64], geo: Geometry) -> tuple[NDArray[np.float64], tuple[float, ...]]:
    """The (R, C) image as rows of growing A-P (y) and columns of growing M-L (x), and its extent (cm)."""
    ax_x, px = geo.axis_positions_cm("x")
    _, py = geo.axis_positions_cm("y")
    a = img if ax_x == -1 else img.T  # now a[y line, x line]
    a = a[np.ix_(np.argsort(py), np.argsort(px))]
    h = 0.5 * geo.pitch_cm
    return a, (px.min() - h, px.max() + h, py.min() - h, py.max() + h)


def pressure_images_png(mean_kpa: NDArray[np.float64], peak_kpa: NDArray[np.float64], geo: Geometry) -> str:
    """Mean and peak pressure over the usable frames, side by side, each with its colour bar (kPa)."""
    fig = _figure(7.0, 3.4)
    for ax, img, title in zip(fig.subplots(1, 2), (mean_kpa, peak_kpa), ("mean pressure", "peak pressure")):
        a, extent = _on_grid(np.nan_to_num(img), geo)
        im = ax.imshow(a, origin="lower", extent=extent, cmap="viridis", interpolation="nearest")
        ax.set(title=title, xlabel="M-L x (cm)", ylabel="A-P y (cm)", aspect="equal")
        fig.colorbar(im, ax=ax, label="kPa", shrink=0.85)
    return _png(fig)


def cop_png(t_s: NDArray[np.float64], cop_cm: NDArray[np.float64], starts_s: Sequence[float] = ()) -> str:
    """The CoP: stabilogram (A-P against M-L) and both coordinates against time, cm; condition starts
    dashed, ``starts_s`` in s from the first frame on the clock of ``t_s`` (the frame clock)."""
    fig = _figure(7.6, 3.2)
    left, right = fig.subplots(1, 2, width_ratios=(1, 1.6))
    left.plot(cop_cm[:, 0], cop_cm[:, 1], lw=0.6)
    left.set(title="stabilogram", xlabel="M-L (cm)", ylabel="A-P (cm)", aspect="equal")
    t = t_s - t_s[0]
    right.plot(t, cop_cm[:, 0] - np.nanmean(cop_cm[:, 0]), lw=0.6, label="M-L")
    right.plot(t, cop_cm[:, 1] - np.nanmean(cop_cm[:, 1]), lw=0.6, label="A-P")
    for s in starts_s:
        right.axvline(s, color="0.4", ls="--", lw=0.8)
    right.set(title="CoP, mean removed", xlabel="time (s)", ylabel="CoP (cm)")
    right.legend(loc="upper right", fontsize="small")
    return _png(fig)


def overlay_png(t_s: NDArray[np.float64], mat_cm: NDArray[np.float64], fp_cm: NDArray[np.float64]) -> str:
    """The mat's and the platform's CoP after alignment and the same preprocessing, M-L and A-P (cm)."""
    fig = _figure(7.6, 3.6)
    for ax, k, name in zip(fig.subplots(2, 1, sharex=True), (0, 1), ("M-L", "A-P")):
        ax.plot(t_s, fp_cm[:, k], lw=0.7, label="platform")
        ax.plot(t_s, mat_cm[:, k], lw=0.7, label="mat")
        ax.set(ylabel=f"{name} (cm)")
        ax.legend(loc="upper right", fontsize="small")
    ax.set(xlabel="time from the overlap's start (s)")
    return _png(fig)

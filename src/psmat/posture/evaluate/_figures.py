"""Predicted against measured angles over the samples of a set (thesis Figs. 4.13-4.16):
one panel per output; matplotlib's object API (Agg), PNG."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from ._metrics import OUTPUTS, r2_per_output

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = ["plot_predictions"]


def plot_predictions(measured: NDArray[np.float64], predicted: NDArray[np.float64], path: str | Path, *,
                     title: str) -> Path:
    """Measured and predicted window-mean outputs (rad) against window number, 6 panels.

    Parameters
    ----------
    measured, predicted : ndarray, (N, 6)
        Window means of the five angles and their sum (rad), windows in recording and time order.
    path : str or Path
        PNG to write.
    title : str
        Figure title (e.g. ``"KSI (Keep Subjects In: ...), test set (simulation)"``: abbreviations spelled out).
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(11, 8), layout="constrained")
    FigureCanvasAgg(fig)
    axes = fig.subplots(3, 2, sharex=True).ravel()
    n = np.arange(len(measured))
    r2 = r2_per_output(measured, predicted)
    for j, (ax, name) in enumerate(zip(axes, OUTPUTS)):
        ax.plot(n, measured[:, j], lw=0.8, color="k", label="measured by the spine IMUs (inertial measurement units)")
        ax.plot(n, predicted[:, j], lw=0.8, color="tab:red", alpha=0.8, label="predicted from the mat")
        ax.set_title(f"{name}  R² (coefficient of determination) = {r2[j]:.3f}", fontsize=10)
        ax.set_ylabel("angle (rad)")
    for ax in axes[-2:]:
        ax.set_xlabel("sample (window)")
    axes[0].legend(fontsize=8, loc="best")
    fig.suptitle(title)
    return save_png(fig, path)


def save_png(fig: Figure, path: str | Path) -> Path:
    """Write ``fig`` to ``path`` as PNG (100 dpi), its folder made; the file whole or not at all."""
    from ..._atomic import replacing

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with replacing(path) as tmp:
        fig.savefig(tmp, dpi=100)
    return path

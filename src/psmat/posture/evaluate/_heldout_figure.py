"""R² per output of each held-out-subject model, as grouped bars (beyond the thesis); Agg, PNG."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ._figures import save_png
from ._metrics import OUTPUTS

__all__ = ["plot_r2_bars"]

#: The axis' floor: R² runs to -inf (the thesis' LSO Sensor4: -2.4); lower bars are cut and labelled.
R2_FLOOR = -1.0
#: The abbreviations of the models' names, spelled out under the legend when a name uses them.
TERMS = {"CNN": "the thesis' convolutional neural network (§4.3)",
         "PCA": "principal component analysis of the window-mean image",
         "ridge": "ridge regression"}


def plot_r2_bars(rows: Sequence[dict[str, Any]], path: str | Path, *, title: str) -> Path:
    """One group of bars per output (Sensor0..4, Sum), one bar per model.

    Parameters
    ----------
    rows : sequence of dict
        Table 4.4 rows (:func:`~psmat.posture.evaluate.table44_row`) of one subset, one per model,
        in the order to draw.
    path : str or Path
        PNG to write.
    title : str
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(14, 5.5), layout="constrained")
    FigureCanvasAgg(fig)
    ax = fig.subplots()
    n = len(rows)
    width = 0.85 / max(n, 1)
    x = np.arange(len(OUTPUTS))
    for i, row in enumerate(rows):
        r2 = np.array([row[f"R2_{o}"] for o in OUTPUTS], dtype=float)
        pos = x - 0.425 + (i + 0.5) * width
        ax.bar(pos, np.maximum(r2, R2_FLOOR), width, color=f"C{i % 10}", label=row["model"])
        for p, v in zip(pos, r2):
            if v < R2_FLOOR:
                ax.text(p, R2_FLOOR, f"{v:.1f}", rotation=90, ha="center", va="bottom", fontsize=7)
    ax.axhline(0.0, color="k", lw=0.8)
    ax.set_xticks(x, OUTPUTS)
    ax.set_ylim(R2_FLOOR, 1.0)
    ax.set_ylabel("R²")
    from matplotlib.patches import Patch

    handles, labels = ax.get_legend_handles_labels()
    names = " ".join(str(row["model"]) for row in rows)
    for term, meaning in TERMS.items():
        if term in names:
            handles.append(Patch(visible=False))
            labels.append(f"{term}: {meaning}")
    handles.append(Patch(visible=False))
    labels.append("R²: coefficient of determination")
    fig.legend(handles, labels, fontsize=8, loc="outside lower center", ncols=3)
    fig.suptitle(title)
    return save_png(fig, path)

"""Helpers shared by the thesis experiments: figure folder, text tables, timing."""

from __future__ import annotations

import os
import time
from contextlib import contextmanager
from pathlib import Path
from typing import Iterator, Sequence

import numpy as np

__all__ = ["figures_dir", "format_table", "fmt", "timed", "plt", "save_figure"]

FIGURES_ENV = "PSMAT_FIGURES"


def figures_dir(path: str | os.PathLike | None = None) -> Path:
    """Folder for figures (created): ``path``, else ``$PSMAT_FIGURES``, else ``./psmat_figures``
    in the current directory."""
    if path is None:
        path = os.environ.get(FIGURES_ENV) or Path.cwd() / "psmat_figures"
    p = Path(path)
    p.mkdir(parents=True, exist_ok=True)
    return p


def plt():
    """matplotlib.pyplot, imported on first use (matplotlib picks Agg when there is no display)."""
    import matplotlib.pyplot as pyplot

    return pyplot


def save_figure(fig, name: str, folder: str | os.PathLike | None = None) -> Path:
    """Save ``fig`` as ``<folder>/<name>.png`` (folder: :func:`figures_dir`); returns the path."""
    out = figures_dir(folder) / f"{name}.png"
    fig.savefig(out, dpi=120, bbox_inches="tight")
    return out


def fmt(x: float, digits: int = 2) -> str:
    """Compact number: ``1.3e-06``, ``0.28``, ``nan`` → ``-``."""
    if x is None or (isinstance(x, float) and np.isnan(x)):
        return "-"
    x = float(x)
    if x == 0:
        return "0"
    if 1e-2 <= abs(x) < 1e3:
        return f"{x:.{digits}g}"
    return f"{x:.{max(digits - 1, 0)}e}"


def format_table(header: Sequence[str], rows: Sequence[Sequence[object]], markdown: bool = True) -> str:
    """A plain-text (Markdown pipe) table; floats through :func:`fmt`."""
    cells = [[fmt(c) if isinstance(c, (float, np.floating)) else str(c) for c in row] for row in rows]
    widths = [max(len(str(h)), *(len(r[k]) for r in cells)) if cells else len(str(h)) for k, h in enumerate(header)]
    line = lambda items: "| " + " | ".join(str(s).rjust(w) for s, w in zip(items, widths)) + " |"  # noqa: E731
    out = [line(header)]
    if markdown:
        out.append("|" + "|".join("-" * (w + 2) for w in widths) + "|")
    out += [line(r) for r in cells]
    return "\n".join(out)


@contextmanager
def timed() -> Iterator[list]:
    """``with timed() as t: ...`` then ``t[0]`` holds the wall time in s."""
    box: list = [0.0]
    t0 = time.perf_counter()
    try:
        yield box
    finally:
        box[0] = time.perf_counter() - t0


def as_rng(seed) -> np.random.Generator:
    return seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)


class UncertaintyComparison:
    """Per-cell views shared by the uncertainty studies: needs ``g``, ``sigma_prop`` (eq. 2.11)
    and ``sigma_mc`` (Monte Carlo) attributes, all in S."""

    g: np.ndarray
    sigma_prop: np.ndarray
    sigma_mc: np.ndarray

    @property
    def rel_prop(self) -> np.ndarray:
        """σ_g/g from eq. 2.11."""
        return self.sigma_prop / self.g

    @property
    def rel_mc(self) -> np.ndarray:
        """σ'_g/g from the simulation."""
        return self.sigma_mc / self.g

    @property
    def ratio(self) -> np.ndarray:
        """eq. 2.11 / Monte Carlo per cell."""
        return self.sigma_prop / self.sigma_mc

"""Thesis Fig. 2.11/2.13: propagated (eq. 2.11) vs Monte-Carlo uncertainty for a random array.

The thesis drew a 16×16 array of cell conductances "randomly selected between 1e-5 and
1e-2 S", computed ``G = F(g)``, added Gaussian noise with the relative SD of Fig. 2.12
(Table 2.4 interpolated in log R: :mod:`psmat.noise`), solved IECM 1000 times and compared
the SD of each cell with the law of propagation of uncertainty (eq. 2.11, with
``∂g/∂G = (∂G/∂g)⁻¹``, eq. 2.14). Findings to reproduce: agreement for high
conductances, overestimation by eq. 2.11 for low ones, relative uncertainty growing as
``g`` falls.

Draw: log-uniform in ``g_range`` (every decade equally likely, the reading that spreads the
cells over the figure's logarithmic axis; ``log=False`` gives uniform in g, which puts 90 %
of the cells above 1e-3 S).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field

import numpy as np

from .. import iecm
from ..noise import table_sigma_G
from ..twin import random_array
from ._common import UncertaintyComparison, fmt, format_table, plt, timed

__all__ = ["RandomArrayUncertainty", "uncertainty_random", "compare_uncertainty"]


@dataclass
class RandomArrayUncertainty(UncertaintyComparison):
    """Per-cell results (all ``shape``): true g, eq. 2.11 and Monte-Carlo SDs (S)."""

    g: np.ndarray
    G: np.ndarray
    sigma_G: np.ndarray
    sigma_prop: np.ndarray
    sigma_mc: np.ndarray
    draws: int
    seed: int | None
    seconds: float
    params: dict = field(default_factory=dict)

    def summary(self, edges=(1e-5, 1e-4, 1e-3, 1e-2)) -> list[dict]:
        """Per conductance decade: cells, median relative σ (both), median and range of the ratio."""
        out = []
        g = self.g.ravel()
        for lo, hi in zip(edges[:-1], edges[1:]):
            m = (g >= lo) & (g < hi) if hi != edges[-1] else (g >= lo) & (g <= hi)
            if not m.any():
                continue
            r = self.ratio.ravel()[m]
            out.append({
                "g_low": lo, "g_high": hi, "cells": int(m.sum()),
                "rel_prop_median": float(np.median(self.rel_prop.ravel()[m])),
                "rel_mc_median": float(np.median(self.rel_mc.ravel()[m])),
                "ratio_median": float(np.median(r)), "ratio_min": float(r.min()), "ratio_max": float(r.max()),
            })
        return out

    def threshold_10pct(self) -> float:
        """Smallest g above which every cell's Monte-Carlo relative σ is < 10 % (S)."""
        g, rel = self.g.ravel(), self.rel_mc.ravel()
        order = np.argsort(g)[::-1]
        bad = np.flatnonzero(rel[order] >= 0.1)
        return float(g[order][bad[0] - 1]) if bad.size and bad[0] > 0 else (float(g.min()) if not bad.size else np.nan)

    def table(self) -> str:
        rows = [
            [f"{fmt(s['g_low'])}–{fmt(s['g_high'])}", s["cells"], fmt(s["rel_prop_median"]), fmt(s["rel_mc_median"]),
             fmt(s["ratio_median"], 3), f"{s['ratio_min']:.2f}–{s['ratio_max']:.2f}"]
            for s in self.summary()
        ]
        return format_table(
            ["g decade (S)", "cells", "median σ/g eq. 2.11", f"median σ/g MC ({self.draws})", "median ratio", "ratio range"],
            rows,
        )

    def plot(self, ax=None, title: str = "Fig. 2.13: random array"):
        """Relative uncertainty vs g: squares eq. 2.11, circles simulation (as the thesis)."""
        pyplot = plt()
        if ax is None:
            fig, ax = pyplot.subplots(figsize=(5.5, 3.8))
        else:
            fig = ax.figure
        plot_relative(ax, self.g, self.rel_prop, self.rel_mc, self.draws)
        ax.set_title(title)
        return fig


def plot_relative(ax, g, rel_prop, rel_mc, draws) -> None:
    ax.loglog(g.ravel(), rel_prop.ravel(), "s", ms=4, mfc="none", label="eq. 2.11")
    ax.loglog(g.ravel(), rel_mc.ravel(), "o", ms=3, alpha=0.7, label=f"simulation ({draws} draws)")
    ax.axhline(0.1, color="0.5", lw=0.8, ls="--")
    ax.set_xlabel("g (S)")
    ax.set_ylabel("relative uncertainty σ_g/g")
    ax.legend(fontsize=8)


def compare_uncertainty(g: np.ndarray, *, draws: int, seed, sigma_G=None) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(G, σ_G, eq. 2.11 σ_g, Monte-Carlo σ_g) for true cells g with the Table 2.4 noise model."""
    G = iecm.forward(g)
    sG = table_sigma_G(G) if sigma_G is None else np.broadcast_to(np.asarray(sigma_G, float), G.shape)
    prop = iecm.propagate_uncertainty(g, sG)
    with warnings.catch_warnings():  # a few noisy draws may end as least-squares points: still valid samples
        warnings.simplefilter("ignore", RuntimeWarning)
        mc = iecm.monte_carlo_uncertainty(g, sG, draws=int(draws), rng=seed)
    return G, np.asarray(sG), prop, mc


def uncertainty_random(
    shape: tuple[int, int] = (16, 16),
    g_range: tuple[float, float] = (1e-5, 1e-2),
    draws: int = 1000,
    seed: int | None = 0,
    *,
    log: bool = True,
) -> RandomArrayUncertainty:
    """Fig. 2.13: eq. 2.11 vs Monte Carlo for a random array (Table 2.4 noise model).

    Parameters
    ----------
    shape : (R, C)
        Array size (thesis 16×16).
    g_range : (low, high)
        Range of the cell conductances in S (thesis 1e-5…1e-2).
    draws : int
        Monte-Carlo draws (thesis 1000).
    seed : int or None
        The array is drawn with ``seed``, the noise with ``seed + 1``.
    log : bool
        Log-uniform draw (default) or uniform in g.
    """
    with timed() as t:
        g = random_array(shape, g_range, log=log, seed=seed)
        G, sG, prop, mc = compare_uncertainty(g, draws=draws, seed=None if seed is None else seed + 1)
    return RandomArrayUncertainty(
        g=g, G=G, sigma_G=sG, sigma_prop=prop, sigma_mc=mc, draws=int(draws), seed=seed, seconds=t[0],
        params={"shape": tuple(shape), "g_range": tuple(g_range), "log": log},
    )

"""Thesis Fig. 2.15/2.16: uncertainty maps of a person standing / in semi-tandem on the mat.

The thesis took ``g`` from IECM-processed images of its first prototype with a person on it
(Fig. 2.15 standing, Fig. 2.16 semi-tandem) and compared eq. 2.11 with the Monte-Carlo SD
(Table 2.4 noise model, 1000 draws). We have no recordings of those images, so the stances
are simulated:

* pressure: two feet from :func:`psmat.twin.two_feet` (smooth plantar lobes, 24 cm ×
  9 cm, 60 % of each foot's load on the rearfoot), 700 N shared equally, averaged over the
  2 cm cells of the 16×16, 32 cm mat. *Standing*: feet side by side, 15 cm between their
  axes, toes out 7°. *Semi-tandem*: feet parallel and touching along their medial borders
  (axes one foot-width apart), the right foot half a foot length ahead of the left; the
  pair is centred on the mat, so heel and toe tips (2 cm at each end) fall off it.
* sensor: the thesis' Velostat model :meth:`psmat.sensor.MPICreep.thesis` (Table 2.11)
  loaded by a 1 s ramp to the cell pressure (20 samples), ``g`` read at the end.
* unloaded cells: background conductance log-uniform in 1e-6…1e-5 S (100 kΩ–1 MΩ), since
  the model gives exactly 0 S at 0 psi and IECM needs ``g > 0``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..sensor import MPICreep
from ..twin.anatomy import two_feet
from ..twin.field import cell_pressure_psi
from ._common import UncertaintyComparison, as_rng, fmt, format_table, plt, timed
from .random_array import compare_uncertainty, plot_relative

__all__ = ["StanceUncertainty", "uncertainty_maps", "stance_pressure", "stance_conductance", "STANCES"]

STANCES = ("standing", "semi_tandem")


def stance_pressure(
    stance: str = "standing",
    shape: tuple[int, int] = (16, 16),
    pitch_cm: float = 2.0,
    *,
    weight_n: float = 700.0,
    foot_length_cm: float = 24.0,
    foot_width_cm: float = 9.0,
    stance_cm: float = 15.0,
    toe_out_deg: float = 7.0,
) -> np.ndarray:
    """Cell pressure (psi), shape ``shape``, for ``"standing"`` or ``"semi_tandem"``."""
    if stance not in STANCES:
        raise ValueError(f"stance must be one of {STANCES}, got {stance!r}")
    R, C = shape
    cx, cy = (C - 1) / 2 * pitch_cm, (R - 1) / 2 * pitch_cm
    kw = dict(length_cm=foot_length_cm, width_cm=foot_width_cm)
    if stance == "standing":
        feet = two_feet(cx, cy, weight_n, stance_cm=stance_cm, toe_out_deg=toe_out_deg, **kw)
    else:  # medial borders touching, the right foot half a foot length ahead
        feet = two_feet(cx, cy, weight_n, stance_cm=foot_width_cm, stagger_cm=foot_length_cm / 2.0, **kw)
    return cell_pressure_psi(feet, (R, C), pitch_cm)


def stance_conductance(
    pressure_psi: np.ndarray,
    seed=0,
    *,
    model: MPICreep | None = None,
    background_s: tuple[float, float] = (1e-6, 1e-5),
    ramp_s: float = 1.0,
    samples: int = 20,
) -> np.ndarray:
    """Cell conductances (S): background + the sensor model's response after a ramp to ``pressure_psi``."""
    m = MPICreep.thesis() if model is None else model
    p = np.asarray(pressure_psi, dtype=np.float64)
    ramp = np.linspace(0.0, 1.0, int(samples))[(...,) + (None,) * p.ndim] * p
    g_load = m.direct(ramp, ramp_s / (samples - 1))[-1]
    lo, hi = background_s
    bg = np.exp(as_rng(seed).uniform(np.log(lo), np.log(hi), size=p.shape))
    return bg + np.clip(g_load, 0.0, None)


@dataclass
class StanceUncertainty(UncertaintyComparison):
    """Conductance map and per-cell uncertainties (S) of a simulated stance."""

    stance: str
    pressure_psi: np.ndarray
    g: np.ndarray
    G: np.ndarray
    sigma_prop: np.ndarray
    sigma_mc: np.ndarray
    draws: int
    seed: int | None
    seconds: float
    params: dict = field(default_factory=dict)


    def threshold_10pct(self, which: str = "mc") -> float:
        """Smallest g (S) such that every cell at or above it has relative σ < 10 %."""
        rel = (self.rel_mc if which == "mc" else self.rel_prop).ravel()
        g = self.g.ravel()
        order = np.argsort(g)[::-1]
        bad = np.flatnonzero(rel[order] >= 0.1)
        if not bad.size:
            return float(g.min())
        return float(g[order][bad[0] - 1]) if bad[0] > 0 else np.nan

    def summary(self, edges=(1e-6, 1e-5, 1e-4, 1e-3, 1e-2)) -> list[dict]:
        g = self.g.ravel()
        out = []
        for lo, hi in zip(edges[:-1], edges[1:]):
            m = (g >= lo) & (g < hi)
            if m.any():
                r = self.ratio.ravel()[m]
                out.append({"g_low": lo, "g_high": hi, "cells": int(m.sum()),
                            "rel_prop_median": float(np.median(self.rel_prop.ravel()[m])),
                            "rel_mc_median": float(np.median(self.rel_mc.ravel()[m])),
                            "ratio_median": float(np.median(r)), "ratio_min": float(r.min()),
                            "ratio_max": float(r.max())})
        return out

    def table(self) -> str:
        rows = [[f"{fmt(s['g_low'])}–{fmt(s['g_high'])}", s["cells"], fmt(s["rel_prop_median"]),
                 fmt(s["rel_mc_median"]), fmt(s["ratio_median"], 3), f"{s['ratio_min']:.2f}–{s['ratio_max']:.2f}"]
                for s in self.summary()]
        head = format_table(["g decade (S)", "cells", "median σ/g eq. 2.11", f"median σ/g MC ({self.draws})",
                             "median ratio", "ratio range"], rows)
        return (f"{self.stance}: loaded cells {int((self.pressure_psi > 0).sum())}, g max {fmt(self.g.max())} S, "
                f"σ/g < 10 % (MC) for g ≥ {fmt(self.threshold_10pct())} S\n" + head)

    def plot(self, fig=None):
        """Top: log10 conductance map; bottom: relative uncertainty vs g (squares eq. 2.11, circles MC)."""
        pyplot = plt()
        if fig is None:
            fig = pyplot.figure(figsize=(5.5, 7))
        ax1, ax2 = fig.subplots(2, 1, gridspec_kw={"height_ratios": [1.1, 1]})
        im = ax1.imshow(np.log10(self.g), origin="lower", cmap="viridis")
        fig.colorbar(im, ax=ax1, label="log10 g (S)")
        ax1.set_title(f"{self.stance.replace('_', '-')}: conductance map")
        ax1.set_xlabel("column")
        ax1.set_ylabel("row")
        plot_relative(ax2, self.g, self.rel_prop, self.rel_mc, self.draws)
        fig.tight_layout()
        return fig


def uncertainty_maps(
    stance: str = "standing",
    shape: tuple[int, int] = (16, 16),
    draws: int = 1000,
    seed: int | None = 0,
    *,
    pitch_cm: float | None = None,
    weight_n: float = 700.0,
    **geometry,
) -> StanceUncertainty:
    """Fig. 2.15 (``"standing"``) / Fig. 2.16 (``"semi_tandem"``): eq. 2.11 vs Monte Carlo.

    Parameters
    ----------
    stance : {"standing", "semi_tandem"}
    shape : (R, C)
        Mat size; the mat stays 32 cm wide unless ``pitch_cm`` is given (16×16 → 2 cm).
    draws : int
        Monte-Carlo draws (thesis 1000).
    seed : int or None
        Background conductances from ``seed``, noise from ``seed + 1``.
    weight_n, **geometry
        Passed to :func:`stance_pressure` (``foot_length_cm``, ``stance_cm`` ...).
    """
    pitch = 32.0 / max(shape) if pitch_cm is None else float(pitch_cm)
    with timed() as t:
        p = stance_pressure(stance, tuple(shape), pitch, weight_n=weight_n, **geometry)
        g = stance_conductance(p, seed)
        G, _, prop, mc = compare_uncertainty(g, draws=draws, seed=None if seed is None else seed + 1)
    return StanceUncertainty(stance=stance, pressure_psi=p, g=g, G=G, sigma_prop=prop, sigma_mc=mc,
                             draws=int(draws), seed=seed, seconds=t[0],
                             params={"shape": tuple(shape), "pitch_cm": pitch, "weight_n": weight_n, **geometry})

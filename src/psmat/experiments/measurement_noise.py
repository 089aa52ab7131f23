"""Thesis Table 2.4 / Fig. 2.12: voltage noise σ_v → conductance uncertainty σ_g through the DAQ.

The thesis plugged one test resistor into a cell (all other lines open, so ``G = g``), read
about 300 samples and reported the SD of the node voltage (σ_v ≈ 1 mV) and of the
conductance deduced from the voltage divider (σ_g). Here the same chain is
:class:`psmat.Circuit` (docs/spec.md §2): σ_g to first order is ``σ_v / |dV_x/dG|``
(:func:`psmat.noise.voltage_sigma_G`), and a simulation reads ``n_frames`` noisy, 12-bit
quantised frames and takes the SD of the inverted conductance, as the thesis did.

Default circuit: the first prototype's DAQ box (``R_adc = 123 kΩ``, ``R_mux = 145 Ω``,
``R_o = 2.2 kΩ``, 3.3 V, 12 bits) — the box Table 2.4 was measured with (300 samples in
30 s is that box's 10 Hz; see tests/unit/test_circuit.py).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Sequence

import numpy as np

from ..circuit import OK, Circuit
from ..noise import TABLE_2_4_R_OHM, TABLE_2_4_SIGMA_G_S, TABLE_2_4_SIGMA_V_MV, voltage_sigma_G
from ._common import as_rng, fmt, format_table, plt

__all__ = ["Table24Result", "table_2_4", "THESIS_TABLE_2_4"]

#: Thesis Table 2.4 as (R Ω, σ_v V, σ_g S) rows.
THESIS_TABLE_2_4 = tuple(
    (float(r), float(v) * 1e-3, float(s)) for r, v, s in zip(TABLE_2_4_R_OHM, TABLE_2_4_SIGMA_V_MV, TABLE_2_4_SIGMA_G_S)
)


@dataclass
class Table24Result:
    """σ_g per test resistor: ours (first order and simulated) beside the thesis'.

    Arrays have one entry per resistance; ``thesis_*`` are NaN where the thesis has no row.
    """

    resistance: np.ndarray          #: test resistor (Ω)
    sigma_v: np.ndarray             #: voltage noise used (V)
    sigma_g: np.ndarray             #: first-order σ_g = σ_v/|dV/dG| (S)
    sigma_g_sim: np.ndarray         #: SD of G over n_frames quantised noisy frames (S)
    sigma_v_sim: np.ndarray         #: SD of the quantised voltage over the frames (V)
    thesis_sigma_v: np.ndarray      #: Table 2.4 σ_v (V)
    thesis_sigma_g: np.ndarray      #: Table 2.4 σ_g (S)
    circuit: Circuit
    n_frames: int
    seed: int | None
    params: dict = field(default_factory=dict)

    @property
    def relative(self) -> np.ndarray:
        """σ_g/g = σ_g·R (Fig. 2.12)."""
        return self.sigma_g * self.resistance

    @property
    def ratio(self) -> np.ndarray:
        """Ours (first order) / thesis."""
        return self.sigma_g / self.thesis_sigma_g

    def table(self) -> str:
        rows = [
            [f"{r:g}", fmt(sv * 1e3), fmt(tsv * 1e3), fmt(s), fmt(ss), fmt(ts), fmt(s / ts, 3), fmt(s * r)]
            for r, sv, tsv, s, ss, ts in zip(
                self.resistance, self.sigma_v, self.thesis_sigma_v, self.sigma_g, self.sigma_g_sim, self.thesis_sigma_g
            )
        ]
        return format_table(
            ["R (Ω)", "σ_v ours (mV)", "σ_v thesis (mV)", "σ_g ours (S)", f"σ_g sim, {self.n_frames} fr (S)",
             "σ_g thesis (S)", "ours/thesis", "σ_g/g ours"],
            rows,
        )

    def plot(self, ax=None):
        """σ_g vs R (log-log): ours (line, simulation) and the thesis' points; returns the figure."""
        pyplot = plt()
        if ax is None:
            fig, ax = pyplot.subplots(figsize=(5, 3.5))
        else:
            fig = ax.figure
        order = np.argsort(self.resistance)
        ax.loglog(self.resistance[order], self.sigma_g[order], "-", label="Circuit, first order")
        ax.loglog(self.resistance, self.sigma_g_sim, "o", mfc="none", label=f"simulated, {self.n_frames} frames")
        ok = np.isfinite(self.thesis_sigma_g)
        ax.loglog(self.resistance[ok], self.thesis_sigma_g[ok], "s", label="thesis Table 2.4")
        ax.set_xlabel("test resistance (Ω)")
        ax.set_ylabel("σ_g (S)")
        ax.set_title("Table 2.4: conductance uncertainty")
        ax.legend(fontsize=8)
        return fig


def table_2_4(
    sigma_v: float | str | Sequence[float] = 1e-3,
    resistances: Sequence[float] = tuple(TABLE_2_4_R_OHM),
    *,
    circuit: Circuit | None = None,
    n_frames: int = 300,
    seed: int | None = 0,
) -> Table24Result:
    """σ_v → σ_g through the measurement chain, beside Table 2.4.

    Parameters
    ----------
    sigma_v : float, sequence or ``"thesis"``
        Voltage noise SD (V): one value for all rows, one per resistance, or ``"thesis"``
        for each row's measured σ_v (1.0, 0.9, 1.1, 1.1, 1.1 mV; needs the thesis'
        resistances).
    resistances : sequence of float
        Test resistors (Ω); default the thesis' 100 Ω … 220 kΩ.
    circuit : Circuit, optional
        Default :meth:`psmat.Circuit.first_prototype` (R_adc 123 kΩ, R_mux 145 Ω).
    n_frames : int
        Frames of the simulated recording per resistor (thesis: ~300).
    seed : int or None
        Seed of the simulated noise.
    """
    R = np.asarray(resistances, dtype=np.float64).ravel()
    if R.size == 0 or np.any(~np.isfinite(R)) or np.any(R <= 0):
        raise ValueError("resistances must be finite and > 0 (Ω)")
    thesis = {r: (v, s) for r, v, s in THESIS_TABLE_2_4}
    t_sv = np.array([thesis.get(float(r), (np.nan, np.nan))[0] for r in R])
    t_sg = np.array([thesis.get(float(r), (np.nan, np.nan))[1] for r in R])
    if isinstance(sigma_v, str):
        if sigma_v != "thesis":
            raise ValueError(f"sigma_v must be a number, a sequence or 'thesis', got {sigma_v!r}")
        if np.isnan(t_sv).any():
            raise ValueError("sigma_v='thesis' needs the thesis' resistances (100, 1e3, 1e4, 1e5, 2.2e5 Ω)")
        sv = t_sv.copy()
    else:
        sv = np.broadcast_to(np.asarray(sigma_v, dtype=np.float64), R.shape).copy()
    if np.any(~np.isfinite(sv)) or np.any(sv < 0):
        raise ValueError("sigma_v must be finite and >= 0 (V)")
    if int(n_frames) != n_frames or n_frames < 2:
        raise ValueError(f"n_frames must be an integer >= 2, got {n_frames!r}")
    cir = Circuit.first_prototype() if circuit is None else circuit
    G = 1.0 / R
    s_lin = voltage_sigma_G(G, sv, cir)
    rng = as_rng(seed)
    counts = cir.counts(np.broadcast_to(G, (int(n_frames), R.size)), noise_v=np.broadcast_to(sv, (int(n_frames), R.size)), rng=rng)
    g, flags = cir.conductance(counts, return_flags=True)
    g = np.where(flags == OK, g, np.nan)
    s_sim = np.nanstd(g, axis=0, ddof=1)
    v_sim = (counts.astype(np.float64) / cir.full_scale * cir.v_ref).std(axis=0, ddof=1)
    return Table24Result(
        resistance=R, sigma_v=sv, sigma_g=s_lin, sigma_g_sim=s_sim, sigma_v_sim=v_sim,
        thesis_sigma_v=t_sv, thesis_sigma_g=t_sg, circuit=cir, n_frames=int(n_frames), seed=seed,
        params={"sigma_v": sigma_v, "circuit": cir.as_dict()},
    )

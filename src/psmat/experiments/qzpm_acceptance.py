"""Thesis Appendix C (Tables C.1, C.2, Fig. C.4): IECM adapted to the QZPM readout.

The thesis' experiment, repeated for every array size and switch-resistance range:

1. cells ``r`` "randomly selected in the range 100 Ω–10 kΩ" — drawn here uniformly in
   resistance (the literal reading; ``cell_draw="log"`` draws log-uniformly instead);
2. switch resistances "randomly distributed in the ranges 10 ± 5 Ω or 10 ± 1 Ω" — uniform in
   resistance; one value for every switch (``switches="shared"``, Table C.1) or one per
   row and column switch (``"separate"``, R + C values, Table C.2);
3. the equivalent conductances of every row–column pair, single row and single column
   (Fig. C.3, :func:`psmat.qzpm.forward`) turned into the op-amp output voltage and back
   (eq. C.1–C.3, ideal OA, ``r_d = 100 Ω``, ``r_f = 400 Ω``, ``V_ref = 1 V``): noise-free
   "experimental" readings;
4. IECM-QZPM (:func:`psmat.qzpm.solve`, least squares eq. C.8 with g ≥ 0, switches
   unknown: one shared or R + C separate conductances) against the closed-form QZPM with
   the switches assumed to be 10 Ω (:func:`psmat.qzpm.closed_form`: derived from the
   circuit under QZPM's assumptions, it stands in for the equations of Hidalgo et al.,
   thesis ref. [138]; with exact 10 Ω switches it keeps a ~2 % quasi-zero-potential error);
5. absolute relative error per cell, eq. C.10, and its 95th percentile over all cells of
   ``n_sims`` simulations (thesis: 10).

:mod:`psmat.qzpm` is imported when a function runs, not at import time.
"""

from __future__ import annotations

import dataclasses
import time
import warnings
from dataclasses import dataclass, field
from typing import Sequence

import numpy as np

from ._common import fmt, format_table, plt

__all__ = ["QzpmTables", "QzpmCase", "qzpm_tables", "qzpm_case", "figure_c4", "THESIS_TABLE_C1", "THESIS_TABLE_C2"]

R_SWITCH_NOMINAL = 10.0
R_D, R_F, V_REF = 100.0, 400.0, 1.0
CELL_RANGE_OHM = (100.0, 10e3)

#: Thesis Table C.1 (shared switch): size -> {range Ω: (IECM p95, QZPM p95)}.
THESIS_TABLE_C1 = {
    4: {5.0: (1.9e-10, 0.28), 1.0: (2.0e-10, 4.5e-2)},
    6: {5.0: (5.3e-10, 0.35), 1.0: (1.8e-12, 7.7e-2)},
    8: {5.0: (2.6e-10, 0.53), 1.0: (1.0e-12, 0.10)},
    10: {5.0: (6.9e-11, 0.89), 1.0: (2.6e-12, 0.12)},
    12: {5.0: (1.7e-11, 1.4), 1.0: (2.0e-11, 0.13)},
}
#: Thesis Table C.2 (R + C separate switches).
THESIS_TABLE_C2 = {
    4: {5.0: (4.7e-5, 0.19), 1.0: (5.9e-10, 4.2e-2)},
    6: {5.0: (3.4e-11, 0.24), 1.0: (1.4e-11, 4.6e-2)},
    8: {5.0: (1.7e-4, 0.37), 1.0: (5.0e-10, 6.5e-2)},
    10: {5.0: (8.7e-5, 0.40), 1.0: (6.5e-11, 7.9e-2)},
    12: {5.0: (8.0e-6, 0.75), 1.0: (8.7e-4, 0.11)},
}


def _qzpm():
    from .. import qzpm  # lazy: written alongside (psmat.qzpm)

    return qzpm


def _with_arrays(readings, **arrays):
    """A copy of a Readings object with new arrays (dataclass, namedtuple or plain class)."""
    if dataclasses.is_dataclass(readings):
        return dataclasses.replace(readings, **arrays)
    if hasattr(readings, "_replace"):
        return readings._replace(**arrays)
    return type(readings)(**arrays)


def through_output_voltage(readings, r_d: float = R_D, r_f: float = R_F, v_ref: float = V_REF):
    """Readings (S) → op-amp output voltages → readings (S), eq. C.1–C.3 with an ideal OA.

    Returns ``(readings_back, voltages)`` where ``voltages`` is a dict of the three arrays (V).
    """
    q = _qzpm()
    kw = dict(r_d=r_d, r_f=r_f, v_ref=v_ref)
    volts, back = {}, {}
    for name in ("pairs", "rows", "cols"):
        v = np.asarray(q.output_voltage(np.asarray(getattr(readings, name)), **kw))
        volts[name] = v
        back[name] = np.asarray(q.from_output_voltage(v, **kw))
    return _with_arrays(readings, **back), volts


def draw_circuit(rng: np.random.Generator, size: int | tuple[int, int], range_ohm: float, switches: str,
                 cell_draw: str = "uniform_r"):
    """(g (R,C), g_row (R,), g_col (C,)) in S for one simulation."""
    R, C = (size, size) if np.ndim(size) == 0 else tuple(size)
    lo, hi = CELL_RANGE_OHM
    if cell_draw == "uniform_r":
        r = rng.uniform(lo, hi, (R, C))
    elif cell_draw == "log":
        r = np.exp(rng.uniform(np.log(lo), np.log(hi), (R, C)))
    else:
        raise ValueError(f"cell_draw must be 'uniform_r' or 'log', got {cell_draw!r}")
    a, b = R_SWITCH_NOMINAL - range_ohm, R_SWITCH_NOMINAL + range_ohm
    if not a > 0:
        raise ValueError(f"range_ohm must be < {R_SWITCH_NOMINAL} (switch resistances > 0), got {range_ohm!r}")
    if switches == "shared":
        rs = rng.uniform(a, b)
        r_row, r_col = np.full(R, rs), np.full(C, rs)
    elif switches == "separate":
        r_row, r_col = rng.uniform(a, b, R), rng.uniform(a, b, C)
    else:
        raise ValueError(f"switches must be 'shared' or 'separate', got {switches!r}")
    return 1.0 / r, 1.0 / r_row, 1.0 / r_col


@dataclass
class QzpmCase:
    """All simulations of one (size, range, switches) condition; ARE arrays are (n_sims, R, C)."""

    size: int
    range_ohm: float
    switches: str
    g: np.ndarray
    are_iecm: np.ndarray
    are_qzpm: np.ndarray
    switch_are: np.ndarray     #: ARE of the recovered switch conductances, (n_sims, R + C)
    seconds: float
    solve_seconds: np.ndarray  #: per simulation
    status: list = field(default_factory=list)  #: solver status per simulation ("converged", ...)

    @property
    def p95_iecm(self) -> float:
        return float(np.percentile(self.are_iecm, 95))

    @property
    def p95_qzpm(self) -> float:
        return float(np.percentile(self.are_qzpm, 95))

    def plot(self, ax=None):
        """Fig. C.4: ARE per cell vs its conductance, IECM (blue) and QZPM (orange)."""
        pyplot = plt()
        if ax is None:
            fig, ax = pyplot.subplots(figsize=(5.5, 3.8))
        else:
            fig = ax.figure
        floor = 1e-17  # exact recoveries (ARE 0) drawn at the floor of the log axis
        ax.loglog(self.g.ravel(), np.maximum(self.are_iecm.ravel(), floor), "o", ms=3, color="C0", label="IECM-QZPM")
        ax.loglog(self.g.ravel(), np.maximum(self.are_qzpm.ravel(), floor), "o", ms=3, color="C1",
                  label="QZPM, r_s = 10 Ω assumed")
        ax.set_xlabel("cell conductance g (S)")
        ax.set_ylabel("absolute relative error (eq. C.10)")
        ax.set_title(f"{self.size}x{self.size}, {self.switches} switches, 10 ± {self.range_ohm:g} Ω")
        ax.legend(fontsize=8)
        return fig


def qzpm_case(size: int, range_ohm: float, switches: str = "shared", n_sims: int = 10, seed: int = 0, *,
              cell_draw: str = "uniform_r", r_d: float = R_D, r_f: float = R_F, v_ref: float = V_REF,
              solve_kwargs: dict | None = None) -> QzpmCase:
    """One condition of Tables C.1/C.2 (see the module docstring)."""
    q = _qzpm()
    t0 = time.perf_counter()
    gs, ai, aq, asw, ts, status = [], [], [], [], [], []
    for k in range(int(n_sims)):
        rng = np.random.default_rng([int(seed), int(size), int(round(range_ohm * 1000)), k,
                                     0 if switches == "shared" else 1])
        g, g_row, g_col = draw_circuit(rng, size, range_ohm, switches, cell_draw)
        readings, _ = through_output_voltage(q.forward(g, g_row, g_col), r_d, r_f, v_ref)
        t1 = time.perf_counter()
        with warnings.catch_warnings():  # a non-converged solve is recorded in ``status``, not raised
            warnings.simplefilter("ignore", RuntimeWarning)
            sol = q.solve(readings, switches=switches, return_info=True, **(solve_kwargs or {}))
        ts.append(time.perf_counter() - t1)
        status.append(str((sol.info or {}).get("status", "unknown")))
        g_q = np.asarray(q.closed_form(readings, r_switch=R_SWITCH_NOMINAL))
        gs.append(g)
        ai.append(np.abs(np.asarray(sol.g) - g) / g)
        aq.append(np.abs(g_q - g) / g)
        sw_true = np.concatenate([g_row, g_col])
        sw = np.concatenate([np.broadcast_to(np.asarray(sol.g_row, float), g_row.shape),
                             np.broadcast_to(np.asarray(sol.g_col, float), g_col.shape)])
        asw.append(np.abs(sw - sw_true) / sw_true)
    return QzpmCase(size=int(size), range_ohm=float(range_ohm), switches=switches, g=np.array(gs),
                    are_iecm=np.array(ai), are_qzpm=np.array(aq), switch_are=np.array(asw),
                    seconds=time.perf_counter() - t0, solve_seconds=np.array(ts), status=status)


@dataclass
class QzpmTables:
    """Table C.1 (shared) or C.2 (separate): one :class:`QzpmCase` per (size, range)."""

    switches: str
    sizes: tuple
    ranges: tuple
    cases: dict            #: (size, range) -> QzpmCase
    n_sims: int
    seed: int
    seconds: float
    params: dict = field(default_factory=dict)

    @property
    def thesis(self) -> dict:
        return THESIS_TABLE_C1 if self.switches == "shared" else THESIS_TABLE_C2

    def p95(self) -> dict:
        """(size, range) -> (IECM p95, QZPM p95)."""
        return {k: (c.p95_iecm, c.p95_qzpm) for k, c in self.cases.items()}

    def table(self) -> str:
        name = "C.1 (shared switch)" if self.switches == "shared" else "C.2 (R + C separate switches)"
        header = ["size"]
        for rg in self.ranges:
            header += [f"IECM ±{rg:g} Ω", "thesis", f"QZPM ±{rg:g} Ω", "thesis"]
        rows = []
        for s in self.sizes:
            row = [f"{s}x{s}"]
            for rg in self.ranges:
                c = self.cases[(s, rg)]
                th = self.thesis.get(s, {}).get(rg, (np.nan, np.nan))
                row += [fmt(c.p95_iecm), fmt(th[0]), fmt(c.p95_qzpm), fmt(th[1])]
            rows.append(row)
        return (f"Table {name}: 95th percentile of the ARE (eq. C.10), {self.n_sims} simulations per cell of the "
                f"table\n" + format_table(header, rows))

    def plot(self, ax=None):
        """p95 ARE vs size: IECM and QZPM per range (ours lines, thesis markers)."""
        pyplot = plt()
        if ax is None:
            fig, ax = pyplot.subplots(figsize=(5.5, 3.8))
        else:
            fig = ax.figure
        for j, rg in enumerate(self.ranges):
            ours = np.array([self.cases[(s, rg)].p95_iecm for s in self.sizes])
            qz = np.array([self.cases[(s, rg)].p95_qzpm for s in self.sizes])
            th = np.array([self.thesis.get(s, {}).get(rg, (np.nan, np.nan)) for s in self.sizes])
            ax.semilogy(self.sizes, np.maximum(ours, 1e-17), "-o", color=f"C{2 * j}", label=f"IECM ±{rg:g} Ω")
            ax.semilogy(self.sizes, qz, "-o", color=f"C{2 * j + 1}", label=f"QZPM ±{rg:g} Ω")
            ax.semilogy(self.sizes, th[:, 0], "s", mfc="none", color=f"C{2 * j}")
            ax.semilogy(self.sizes, th[:, 1], "s", mfc="none", color=f"C{2 * j + 1}")
        ax.set_xlabel("array size N (N×N)")
        ax.set_ylabel("95th percentile ARE")
        ax.set_title(f"Table C.{1 if self.switches == 'shared' else 2} (squares: thesis)")
        ax.legend(fontsize=7, ncol=2)
        return fig


def qzpm_tables(
    sizes: Sequence[int] = (4, 6, 8, 10, 12),
    ranges: Sequence[float] = (5.0, 1.0),
    n_sims: int = 10,
    switches: str = "shared",
    seed: int = 0,
    **kwargs,
) -> QzpmTables:
    """Table C.1 (``switches="shared"``) or C.2 (``"separate"``); see the module docstring.

    ``kwargs`` go to :func:`qzpm_case` (``cell_draw``, ``r_d``, ``r_f``, ``v_ref``, ``solve_kwargs``).
    """
    t0 = time.perf_counter()
    cases = {(int(s), float(rg)): qzpm_case(int(s), float(rg), switches, n_sims, seed, **kwargs)
             for s in sizes for rg in ranges}
    return QzpmTables(switches=switches, sizes=tuple(int(s) for s in sizes), ranges=tuple(float(r) for r in ranges),
                      cases=cases, n_sims=int(n_sims), seed=int(seed), seconds=time.perf_counter() - t0,
                      params=dict(kwargs))


def figure_c4(size: int = 10, range_ohm: float = 5.0, switches: str = "separate", n_sims: int = 10,
              seed: int = 0, **kwargs) -> QzpmCase:
    """Fig. C.4: ARE per cell vs conductance (thesis: 10×10, separate switches, 10 ± 5 Ω).

    The same draws as the corresponding entry of :func:`qzpm_tables` with the same seed;
    ``.plot()`` draws the figure.
    """
    return qzpm_case(size, range_ohm, switches, n_sims, seed, **kwargs)

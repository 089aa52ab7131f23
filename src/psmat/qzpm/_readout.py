"""QZPM readout: forward model, Jacobian, inverse and closed form (thesis App. C).

Model (eq. C.4-C.7; derivation in docs/qzpm.md and src/cpp/psmat/qzpm/forward.hpp): with
``A = L_cells + diag(g_row, g_col)`` (SPD for positive switches) and the coupling vector
``s = sum_{k in S} g_k e_k`` of the selected lines S, each reading is
``G_S = sum_{k in S} g_k - s^T A^-1 s``.
"""

from __future__ import annotations

import os
import warnings
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .. import _core
from .._checks import nonnegative, real_array

__all__ = ["Readings", "QzpmSolution", "SWITCH_MODES", "forward", "jacobian", "solve", "closed_form"]

SWITCH_MODES = ("shared", "separate")
_IN_S = "; conductances are in S"


def _cells(g) -> np.ndarray:
    a = real_array(g, "g", unit="S")
    if a.ndim != 2 or a.shape[0] < 1 or a.shape[1] < 1:
        raise ValueError(f"g must have shape (R, C), got {a.shape}")
    nonnegative(a, "g", hint=_IN_S)
    return a


def _switches(x, n: int, name: str) -> np.ndarray:
    a = real_array(x, name, unit="S")
    if a.ndim == 0:
        a = np.full(n, float(a))
    if a.shape != (n,):
        raise ValueError(f"{name} must be a scalar or have shape ({n},), got {a.shape}")
    nonnegative(a, name, allow_zero=False, hint=_IN_S)
    return a


@dataclass(frozen=True)
class Readings:
    """Equivalent conductances (S) of a QZPM readout, eq. C.7.

    Attributes
    ----------
    pairs : numpy.ndarray, (R, C)
        Row i and column p connected to the connecting node.
    rows : numpy.ndarray, (R,)
        Only row i connected.
    cols : numpy.ndarray, (C,)
        Only column p connected.

    A stack of independent readouts has shapes (T, R, C), (T, R), (T, C) (for :func:`solve`).
    """

    pairs: np.ndarray
    rows: np.ndarray
    cols: np.ndarray

    @property
    def shape(self) -> tuple[int, int]:
        """(R, C) of the array."""
        return (int(np.shape(self.pairs)[-2]), int(np.shape(self.pairs)[-1]))

    def validated(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, bool]:
        """Checked float64 copies with a leading batch axis, and whether the input was single."""
        p = real_array(self.pairs, "readings.pairs", unit="S")
        r = real_array(self.rows, "readings.rows", unit="S")
        c = real_array(self.cols, "readings.cols", unit="S")
        if p.ndim not in (2, 3):
            raise ValueError(f"readings.pairs must have shape (R, C) or (T, R, C), got {p.shape}")
        single = p.ndim == 2
        if single:
            p, r, c = p[None], r[None] if r.ndim == 1 else r, c[None] if c.ndim == 1 else c
        T, R, C = p.shape
        if r.shape != (T, R) or c.shape != (T, C):
            want = f"({R},) and ({C},)" if single else f"({T}, {R}) and ({T}, {C})"
            raise ValueError(f"readings.rows / readings.cols must have shapes {want}, got {np.shape(self.rows)} and {np.shape(self.cols)}")
        for a, name in ((p, "readings.pairs"), (r, "readings.rows"), (c, "readings.cols")):
            nonnegative(a, name, allow_zero=False, hint=_IN_S)
        return p, r, c, single


@dataclass
class QzpmSolution:
    """Result of :func:`solve`.

    Attributes
    ----------
    g : numpy.ndarray, (R, C) or (T, R, C)
        Cell conductances in S.
    g_row : numpy.ndarray, (R,) or (T, R)
        Row switch conductances in S (all equal with ``switches="shared"``).
    g_col : numpy.ndarray, (C,) or (T, C)
        Column switch conductances in S.
    info : dict or None
        With ``return_info=True``: ``iterations``, ``factorizations``, ``evaluations``, ``residual`` (max relative
        reading residual), ``cost``, ``status`` ("converged", "least_squares",
        "max_iterations", "stalled", "singular"), ``converged`` (residual <= rtol), ``switches``;
        arrays for a stack.
    """

    g: np.ndarray
    g_row: np.ndarray
    g_col: np.ndarray
    info: dict[str, Any] | None = field(default=None)

    @property
    def r_row(self) -> np.ndarray:
        """Row switch resistances in Ohm."""
        return 1.0 / self.g_row

    @property
    def r_col(self) -> np.ndarray:
        """Column switch resistances in Ohm."""
        return 1.0 / self.g_col


def forward(g, g_row, g_col) -> Readings:
    """Readings of the QZPM readout for known cells and switches (eq. C.4-C.7, Fig. C.3).

    Parameters
    ----------
    g : array_like, (R, C)
        Cell conductances in S (>= 0).
    g_row : float or array_like, (R,)
        Row switch conductances in S (> 0); a scalar for one shared value.
    g_col : float or array_like, (C,)
        Column switch conductances in S (> 0).

    Returns
    -------
    Readings
        ``pairs`` (R, C), ``rows`` (R,), ``cols`` (C,) in S, I_ref / V_in of each configuration.
    """
    a = _cells(g)
    R, C = a.shape
    gr = _switches(g_row, R, "g_row")
    gc = _switches(g_col, C, "g_col")
    pairs, rows, cols = _core.qzpm.forward(a, gr, gc)
    return Readings(pairs, rows, cols)


def jacobian(g, g_row, g_col) -> np.ndarray:
    """Derivatives of all readings with respect to all conductances.

    Parameters
    ----------
    g, g_row, g_col
        As in :func:`forward` (S).

    Returns
    -------
    numpy.ndarray, (R*C + R + C, R*C + R + C)
        Dimensionless dG/dtheta. Rows: readings in the order pairs (row-major, a = i*C + p),
        rows, cols. Columns: parameters in the order cells (row-major), g_row, g_col.
        With V_in = 1 and v the node potentials of a configuration, each entry is the squared
        voltage across that element: (v_j - v_{R+q})^2 for a cell, (1 - v_k)^2 for a selected
        switch and v_k^2 for a grounded one.
    """
    a = _cells(g)
    R, C = a.shape
    return _core.qzpm.jacobian(a, _switches(g_row, R, "g_row"), _switches(g_col, C, "g_col"))


def closed_form(readings: Readings, r_switch: float = 10.0) -> np.ndarray:
    """The "QZPM" closed-form method: cells from the readings with a known switch resistance.

    Assumes every switch has resistance ``r_switch`` and that the lines not selected sit at
    0 V (quasi zero potential). Derived from the circuit in docs/qzpm.md; it stands in for
    the analytical method of Hidalgo et al. (thesis ref. [138]), the "QZPM" column of thesis
    Tables C.1/C.2. Exact when the unselected lines are truly at 0 V and the selected switches
    are exactly ``r_switch``; in the real circuit its error vanishes as the switch resistance
    goes to 0, and grows when the true switches differ from ``r_switch``.

    Parameters
    ----------
    readings : Readings
        One readout (pairs (R, C), rows (R,), cols (C,)) in S, or a stack (T, ...).
    r_switch : float
        Assumed switch resistance in Ohm (>= 0; 0 gives the plain ZPM formula
        g = (S_i + S^p - G_ip) / 2).

    Returns
    -------
    numpy.ndarray, (R, C) or (T, R, C)
        Cell conductances in S. NaN where the readings are inconsistent with ``r_switch``
        (e.g. r_switch * G >= 1); values may be <= 0 where the assumption is badly off.
    """
    if not (np.isfinite(r_switch) and r_switch >= 0):
        raise ValueError(f"r_switch must be a finite resistance >= 0 in Ohm, got {r_switch!r}")
    p, r, c, single = readings.validated()
    out = np.stack([_core.qzpm.closed_form(p[t], r[t], c[t], float(r_switch)) for t in range(p.shape[0])])
    return out[0] if single else out


def solve(
    readings: Readings,
    switches: str = "shared",
    g0=None,
    return_info: bool = False,
    *,
    r_switch0: float = 10.0,
    max_iter: int = 300,
    rtol: float = 1e-13,
    ftol: float = 1e-16,
    max_log_step: float = 2.0,
    threads: int | None = None,
) -> QzpmSolution:
    """Recover cell AND switch conductances from QZPM readings (IECM adaptation, eq. C.8-C.9).

    Minimises sum(((F(theta) - G) / G)^2) over theta = (cells, switches) > 0 by
    Levenberg-Marquardt in log-parameters with the analytic Jacobian. ``switches="shared"``:
    one unknown switch conductance for all lines (R*C + 1 unknowns); ``"separate"``: R + C
    unknown switches (as many unknowns as readings). The separate problem is solved by variable
    projection (cells eliminated for given switches; LM with geodesic acceleration on the log
    switch conductances) from the closed-form cold start, then polished by the full LM; plain
    LM often ends in a spurious minimum. The former path (shared solution, homotopy in the
    readings, restarts; docs/qzpm.md) remains as a fallback when that does not converge.

    Parameters
    ----------
    readings : Readings
        pairs (R, C), rows (R,), cols (C,) in S; or a stack (T, R, C), (T, R), (T, C) of
        independent readouts (solved on ``threads`` threads).
    switches : {"shared", "separate"}
        Switch model.
    g0 : array_like, (R, C), optional
        Starting cells in S (single readout only); default: the closed form with ``r_switch0``.
    return_info : bool
        Fill :attr:`QzpmSolution.info` with the iteration report.
    r_switch0 : float
        Switch resistance (Ohm) of the cold start.
    max_iter, rtol, ftol, max_log_step
        LM iterations per stage, target max relative residual, relative cost decrease that
        stops it, and largest |step| of a log-parameter per iteration.
    threads : int, optional
        Threads for a stack (default: all cores).

    Returns
    -------
    QzpmSolution
        ``g`` (S), ``g_row`` (S), ``g_col`` (S), ``info``.

    Warns
    -----
    RuntimeWarning
        When a problem ends without a converged or least-squares status.
    """
    if switches not in SWITCH_MODES:
        raise ValueError(f"switches must be one of {SWITCH_MODES}, got {switches!r}")
    if not (np.isfinite(r_switch0) and r_switch0 > 0):
        raise ValueError(f"r_switch0 must be a positive resistance in Ohm, got {r_switch0!r}")
    if int(max_iter) < 1:
        raise ValueError("max_iter must be >= 1")
    p, r, c, single = readings.validated()
    mode = SWITCH_MODES.index(switches)
    T, R, C = p.shape
    args = (mode, int(max_iter), float(rtol), float(ftol), float(max_log_step), float(r_switch0))
    if g0 is not None:
        if not single:
            raise ValueError("g0 is supported for a single readout only")
        g0a = _cells(g0)
        if g0a.shape != (R, C):
            raise ValueError(f"g0 must have shape {(R, C)}, got {g0a.shape}")
    if single:
        g, gr, gc, rep = _core.qzpm.solve(p[0], r[0], c[0], *args, None if g0 is None else g0a, None)
        reports = [rep]
    else:
        n = int(threads) if threads else (os.cpu_count() or 1)
        g, gr, gc, reports = _core.qzpm.solve_batch(p, r, c, *args, n)
    info = _info(reports, single)
    bad = [s for s in np.atleast_1d(info["status"]).tolist() if s not in ("converged", "least_squares")]
    info["switches"] = switches
    if bad:
        warnings.warn(
            f"QZPM inverse ({switches} switches): {len(bad)} problem(s) did not converge "
            f"(status: {sorted(set(bad))}); pass return_info=True to inspect them",
            RuntimeWarning,
            stacklevel=2,
        )
    return QzpmSolution(g, gr, gc, info if return_info else None)


def _info(reports: list, single: bool) -> dict[str, Any]:
    """The info dict of :class:`QzpmSolution` from the core's ``psmat._core.SolveReport`` of each
    problem: scalars for one readout, arrays for a stack."""
    info: dict[str, Any] = {k: np.array([getattr(rep, k) for rep in reports])
                            for k in ("iterations", "factorizations", "evaluations", "residual", "cost")}
    info["status"] = np.array([rep.status.name for rep in reports])
    info["converged"] = info["status"] == "converged"  # residual <= rtol (a least-squares point is not)
    if single:
        info = {k: v[0].item() for k, v in info.items()}
    return info

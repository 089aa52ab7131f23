"""Per-cell gains from uniform loads (equilibration; docs/spec.md §4 "Pressure calibration").

The thesis could not equilibrate its large mat (§3.2.2: "It is typical to perform some
equilibration process or even to find individual models for each cell ... which is not possible
in our case") and scaled it by the body weight instead (eq. 3.3). With a uniform load of known
level — a pneumatic bladder, or masses on a rigid plate over the mat — every cell carries the
same pressure ``L``, so each cell's conductance gain relative to the sensor model is found on
its own. With ``M`` the inverse sensor model run over the recording (hysteresis and creep, per
cell) and ``g_ij(t)`` the cell's conductance after IECM, the gain ``k_ij`` solves

    mean over the settled frames of  M(k_ij · g_ij)(t)  =  L                    (per cell)

The left side grows with ``k`` (the inverse model preserves order), so each cell has one root,
found for all cells at once by the Illinois variant of false position on ``log k`` (the inverse
model acts per cell, so one run of it over the (T, R·C) recording evaluates every cell).

Several recordings (levels) give one gain per cell each; their geometric mean is the gain, and
``spread = max/min − 1`` over them is reported per cell: a cell whose response is not a pure
gain of the model's (another shape of curve) shows a spread where a gain would not.

Cells that never carry the load (below ``1/contrast`` of the 90th percentile of the cells'
settled conductance: off the plate, a broken line) or whose root is not within a factor
``reach`` of the model's nominal conductance at the level (a cell saturated or shorted) get no
gain from that recording. A cell with no gain from any recording is flagged and given the
median gain of the other cells — the mat's typical cell: gain 1 would leave it at the nominal
model's sensitivity, off by the mat's global factor; NaN would spoil every frame's total force
and CoP.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .. import _checks
from ..sensor import MPICreep
from ..units import PSI_KPA
from ._calibration import PressureCalibration, utc_now
from ._window import recording_cells, settled_frames

__all__ = ["EquilibrationResult", "equilibrate"]

_TOL = 1e-9  # relative error of a cell's mean pressure at which its root is taken


@dataclass(frozen=True)
class EquilibrationResult:
    """Per-cell gains from uniform loads.

    Attributes
    ----------
    gains : (R, C) array
        ``k_ij`` (dimensionless): the inverse sensor model run on ``k_ij · g_ij`` gives the level.
    flagged : (R, C) bool array
        Cells with no gain from any recording; their gain is the median of the others'.
    spread : (R, C) array
        ``max/min − 1`` of a cell's gains over the recordings that gave one (0 with one; NaN
        where flagged).
    per_recording : (N, R, C) array
        Each recording's gains; NaN where that recording gave none.
    levels_kpa : tuple of float
        Each recording's level (kPa).
    """

    gains: NDArray[np.float64]
    flagged: NDArray[np.bool_]
    spread: NDArray[np.float64]
    per_recording: NDArray[np.float64]
    levels_kpa: tuple[float, ...]

    def calibration(self, base: PressureCalibration | None = None) -> PressureCalibration:
        """``base`` (default none) with these gains, dated now; a scale ``base`` had is dropped:
        it was made relative to the old gains (run the known load again)."""
        b = base or PressureCalibration()
        return PressureCalibration(sensor=b.sensor, sensor_fitted_utc=b.sensor_fitted_utc,
                                   sensor_source=b.sensor_source, gains=self.gains, gains_utc=utc_now(),
                                   gain_levels_kpa=tuple(sorted(set(self.levels_kpa))),
                                   gains_flagged=self.flagged)


def _illinois(h: Callable[[NDArray[np.float64]], NDArray[np.float64]], lo: NDArray[np.float64],
              hi: NDArray[np.float64], max_iter: int = 60) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """Roots of the increasing functions ``h`` (one per element) in [lo, hi]; and where one exists."""
    a, b = lo.copy(), hi.copy()
    fa, fb = h(a), h(b)
    has = (fa <= 0) & (fb >= 0)
    fa, fb = np.where(has, fa, -1.0), np.where(has, fb, 1.0)  # keep the others harmless
    for _ in range(max_iter):
        denom = fb - fa
        c = np.where(denom > 0, b - fb * (b - a) / np.where(denom > 0, denom, 1.0), 0.5 * (a + b))
        c = np.clip(c, np.minimum(a, b), np.maximum(a, b))
        fc = np.where(has, h(c), 0.0)
        flip = fc * fb < 0
        a, fa = np.where(flip, b, a), np.where(flip, fb, fa / 2)
        b, fb = c, fc
        if np.all(np.abs(fc) <= _TOL):
            break
    return b, has & (np.abs(fb) <= 1e3 * _TOL)


def _one(x: NDArray[np.float64], dt_s: float | ArrayLike, level_kpa: float, sensor: MPICreep, settle_s: float,
         contrast: float, reach: float, name: str) -> NDArray[np.float64]:
    """Gains (R·C,) from one recording, NaN where none."""
    usable, steps, settled = settled_frames(x, dt_s, settle_s, name)
    cells = x[usable].reshape(int(usable.sum()), -1)
    level = level_kpa / PSI_KPA  # psi, the model's unit
    mean_g = cells[settled].mean(axis=0)
    loaded = (mean_g > 0) & (mean_g >= np.percentile(mean_g, 90) / contrast)
    out = np.full(cells.shape[1], np.nan)
    if not loaded.any():
        return out
    g_level = float(sensor.direct(np.full(cells.shape[0], level), steps)[settled].mean())  # the model's cell
    xl = cells[:, loaded]
    u0 = np.log(g_level / mean_g[loaded])

    def h(u: NDArray[np.float64]) -> NDArray[np.float64]:
        return sensor.inverse(xl * np.exp(u), steps)[settled].mean(axis=0) / level - 1.0

    u, ok = _illinois(h, u0 - np.log(reach), u0 + np.log(reach))
    k = np.full(u.size, np.nan)
    k[ok] = np.exp(u[ok])
    out[loaded] = k
    return out


def equilibrate(g_recordings: Sequence[ArrayLike], dt_s: float | Sequence[float | ArrayLike],
                levels_kpa: Sequence[float], sensor: MPICreep | None = None, *, settle_s: float = 3.0,
                contrast: float = 20.0, reach: float = 30.0) -> EquilibrationResult:
    """Per-cell gains of a mat from recordings under uniform loads of known level.

    Parameters
    ----------
    g_recordings : sequence of (T_k, R, C) arrays
        Cell conductances (S) after IECM (and the unloaded leakage removed, as the chain does),
        one array per recording; NaN frames are missing (the sensor model steps over them).
        Each recording starts with the mat at rest (unloaded, rested).
    dt_s : float, or one float or (T_k,) array per recording
        Frame period(s) (s).
    levels_kpa : sequence of float
        The uniform pressure of each recording (kPa), below the model's range ``p_max``.
    sensor : MPICreep, optional
        The sensor model the gains are relative to; default the thesis' (Table 2.11).
    settle_s : float
        Time after the load appears before frames enter the average (s).
    contrast : float
        A cell carries the load when its settled conductance is at least the 90th percentile of
        the cells' over ``contrast``.
    reach : float
        A gain is searched within this factor of the nominal model's (dimensionless, > 1).

    Returns
    -------
    EquilibrationResult

    Raises
    ------
    ValueError
        Recordings and levels of different numbers or shapes, a level beyond the model's
        range, a recording without a settled load, no cell with a gain.
    """
    recs = list(g_recordings)
    levels = [float(_checks.positive("level_kpa", v)) for v in levels_kpa]
    if not recs or len(recs) != len(levels):
        raise ValueError(f"give one level (kPa) per recording: {len(recs)} recording(s), {len(levels)} level(s)")
    periods = list(dt_s) if isinstance(dt_s, Sequence) and not isinstance(dt_s, (str, bytes)) else [dt_s] * len(recs)
    if len(periods) != len(recs):
        raise ValueError(f"give one frame period per recording: {len(recs)} recording(s), {len(periods)} period(s)")
    sensor = sensor or MPICreep.thesis()
    top = sensor.p_max * PSI_KPA
    for v in levels:
        if v >= top:
            raise ValueError(f"a uniform load of {v:g} kPa is beyond the sensor model's range ({top:.4g} kPa)")
    contrast = _checks.positive("contrast", contrast)
    if not (np.isfinite(reach) and reach > 1):
        raise ValueError(f"reach must be a factor > 1, got {reach!r}")
    arrays = [recording_cells(g, f"recording {k + 1}") for k, g in enumerate(recs)]
    shape = arrays[0].shape[1:]
    for k, a in enumerate(arrays):
        if a.shape[1:] != shape:
            raise ValueError(f"recording {k + 1} is {a.shape[1]}x{a.shape[2]}, recording 1 {shape[0]}x{shape[1]}")
    per = np.stack([_one(a, p, v, sensor, settle_s, contrast, reach, f"recording {k + 1}")
                    for k, (a, p, v) in enumerate(zip(arrays, periods, levels))])
    logk = np.log(per)
    good = np.isfinite(logk)
    flagged = ~good.any(axis=0)
    if flagged.all():
        raise ValueError("no cell gave a gain: is the load on the mat, and its level right?")
    mean = np.full(flagged.shape, np.nan)
    spread = np.full(flagged.shape, np.nan)
    some = logk[:, ~flagged]
    mean[~flagged] = np.nanmean(some, axis=0)
    spread[~flagged] = np.exp(np.nanmax(some, axis=0) - np.nanmin(some, axis=0)) - 1.0
    gains = np.where(flagged, np.exp(np.median(mean[~flagged])), np.exp(mean))
    R, C = shape
    return EquilibrationResult(gains.reshape(R, C), flagged.reshape(R, C), spread.reshape(R, C),
                               per.reshape(len(arrays), R, C), tuple(levels))

"""The scaling factor of the SCHC variant (thesis eq. 3.3, docs/spec.md §7).

The large mat is more conductive than the pneumatic-platform samples its sensor model was
fitted on (the thesis found it ~1.3–4× more), so the pressures the nominal inverse model
gives do not add up to the body weight. SCHC scales the conductances by one factor ``f``
per trial, chosen so that the mean force over the trial equals the weight:

    mean over t of  Σ_ij M(f · g_ij)(t) · A  =  W                      (eq. 3.3)

with ``M`` the inverse sensor model run over the whole trial (its hysteresis and creep
state carried from frame to frame), ``A`` the cell area and ``W`` the body weight. The
thesis brute-forces ``f`` on [0.25, 0.75]; the left side grows with ``f`` (the inverse
model is order preserving), so ``f`` is found as a root: by the secant method on
``log(mean force / W)`` against ``log f``, nearly a straight line (the inverse model is close to
a power law), in 5-7 runs of the sensor model over the trial; Brent's method on the bracket
(10-12 runs) where the secant leaves the bracket or meets a zero force. The ``f`` returned is
the last one the search ran the model at (within ``rtol`` of the root), so the variant's
pressures are that run's (:meth:`_Search.pressure`), not one more run.

``rtol`` is :data:`RTOL` (1e-6) unless given: the mean force then equals the weight to about a
millionth, a thousandth of how well a body weight is known (0.1 kg in 70 kg). Each further digit
costs about one more run of the sensor model over the trial: on 14 sessions of the simulated
thesis-size study (``python -m psmat.bench study``), the searches ran the model 21.4 times a
session with 1e-10 against 16.5, and the sessions took 7.6-19.6 % more CPU time (five
alternating pairs, median 8.3 %); the metrics moved by at most 4.4e-7 (relative).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import ArrayLike
from scipy import optimize

from .. import _checks
from ..profile import default_geometry
from ..sensor import MPICreep, frame_periods, steps_over_gaps
from ..units import PSI_PA

__all__ = ["scale_factor", "mean_force_n", "scale_factors", "RTOL"]

#: Relative tolerance on ``f`` of every search (module docstring).
RTOL = 1e-6


def trial_cells(g: ArrayLike) -> np.ndarray:
    """A trial's cell conductances (T, R, C) in S, checked, as (T, R·C); NaN marks a missing frame."""
    a = _checks.real_array(g, "g", unit="S", allow_nan=True)
    if a.ndim != 3:
        raise ValueError(f"g must be a trial of frames (T, R, C) in S, got shape {a.shape}")
    if np.any(a < 0):
        raise ValueError("g has negative conductances; pass cell conductances (S) after IECM")
    return a.reshape(a.shape[0], -1)


def mean_force_n(g: ArrayLike, dt: float | ArrayLike, f: float = 1.0, sensor: MPICreep | None = None,
                 cell_area_cm2: float | None = None) -> float:
    """Left side of eq. 3.3 (N): the trial's mean of ``Σ M(f·g)·A`` over its complete frames."""
    cells = trial_cells(g)
    usable, steps = usable_steps(cells, frame_periods(dt, cells.shape[0]))
    return _mean_force(cells[usable], steps, f, sensor or MPICreep.thesis(),
                       _cell_area(cell_area_cm2))


def _cell_area(cell_area_cm2: float | None) -> float:
    """The cell area (cm²), checked; None: the default profile's (docs/spec.md §5 "Device profiles")."""
    return _checks.positive("cell_area_cm2", default_geometry().cell_area_cm2 if cell_area_cm2 is None
                            else cell_area_cm2)


def usable_steps(cells: np.ndarray, periods: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Complete frames (T,) of ``cells`` (T, n) and their sensor-model steps (s) over the missing
    ones (:func:`psmat.sensor.steps_over_gaps`, the policy of :mod:`psmat.process`)."""
    usable = np.all(np.isfinite(cells), axis=1)
    return usable, steps_over_gaps(periods, usable)[0]


def _mean_force(cells: np.ndarray, steps: np.ndarray, f: float, sensor: MPICreep, area_cm2: float,
                in_mean: np.ndarray | None = None) -> float:
    """Mean force (N) of the complete frames ``cells`` (U, n) stepped by ``steps`` (U,): one run over the trial;
    the mean over the frames ``in_mean`` (U,) bool, default all."""
    force = sensor.inverse(f * cells, steps).sum(axis=1)
    return float(np.mean(force if in_mean is None else force[in_mean]) * PSI_PA * area_cm2 * 1e-4)


def scale_factor(g: ArrayLike, dt: float | ArrayLike, weight_n: float, sensor: MPICreep | None = None,
                 cell_area_cm2: float | None = None, *, bracket: tuple[float, float] = (1e-3, 1e3),
                 rtol: float = RTOL, mean_over: ArrayLike | None = None) -> float:
    """Solve eq. 3.3 for ``f``.

    Parameters
    ----------
    g : array, (T, R, C)
        Cell conductances of one trial (S), after IECM (and the unloaded leakage removed);
        frames with NaN are missing: left out of the mean, the sensor model stepped over them
        (the policy of :mod:`psmat.process`).
    dt : float or (T,) array
        Frame period (s), or each frame's time since the previous one: the creep depends on it.
    weight_n : float
        Body weight W (N).
    sensor : MPICreep, optional
        The nominal sensor model (the pneumatic fit); default the thesis' (Table 2.11).
    cell_area_cm2 : float, optional
        Cell area A (cm²); default the default profile's (4 cm² on the thesis mat).
    bracket : (low, high)
        Where ``f`` is searched.
    rtol : float
        Relative tolerance on ``f`` (dimensionless; default :data:`RTOL`, 1e-6).
    mean_over : (T,) bool array, optional
        The frames whose force enters the mean (default all): e.g. only those with the load
        settled; the sensor model still runs over every complete frame (the load's history).

    Returns
    -------
    float
        ``f`` with the trial's mean force equal to ``weight_n``.

    Raises
    ------
    ValueError
        When no ``f`` in ``bracket`` reaches the weight (e.g. too few loaded cells: the
        inverse model saturates at ``p_max``), with the force reached at the bracket's ends.
    """
    return _Search(g, dt, weight_n, sensor, cell_area_cm2, bracket, rtol, mean_over).solve()


class _Search:
    """One trial's eq. 3.3, checked and reduced to its loaded cells and complete frames (:func:`scale_factor`)."""

    def __init__(self, g: ArrayLike, dt: float | ArrayLike, weight_n: float, sensor: MPICreep | None,
                 cell_area_cm2: float | None, bracket: tuple[float, float], rtol: float,
                 mean_over: ArrayLike | None) -> None:
        cells = trial_cells(g)
        periods = frame_periods(dt, cells.shape[0])
        self.w = _checks.positive("weight_n", weight_n)
        self.area = _cell_area(cell_area_cm2)
        self.lo, self.hi = _checks.pair("bracket", bracket, labels="low, high")
        self.rtol = _checks.positive("rtol", rtol)
        if not 0 < self.lo < self.hi:
            raise ValueError(f"bracket must satisfy 0 < low < high, got {bracket!r}")
        self.sensor = sensor or MPICreep.thesis()
        if not np.any(np.all(np.isfinite(cells), axis=1)):
            raise ValueError("g has no complete frame: nothing to scale")
        self.loaded = np.nanmax(cells, axis=0) > 0  # cells that never conduct add M(0) = 0 at any f
        complete = np.all(np.isfinite(cells), axis=1)  # frames complete on every cell, loaded or not
        every_cell = bool(self.loaded.all())
        if not every_cell:  # (no copy where every cell conducts at some frame, as on a noisy mat)
            cells = cells[:, self.loaded]
        if cells.shape[1] == 0:
            raise ValueError("g is zero everywhere: no f can carry the weight")
        # once: every evaluation of the root reuses them
        if every_cell:
            self.usable, self.steps = complete, steps_over_gaps(periods, complete)[0]
        else:
            self.usable, self.steps = usable_steps(cells, periods)
        self.cells = cells if self.usable.all() else cells[self.usable]  # read only: each run scales a copy
        # the model's frames are those of the whole mat (no frame missing on a quiet cell only)
        self.whole_frames = bool(np.array_equal(complete, self.usable))
        self.in_mean = None
        if mean_over is not None:
            chosen = np.asarray(mean_over, dtype=bool)
            if chosen.shape != self.usable.shape:
                raise ValueError(f"mean_over must be one flag per frame {self.usable.shape}, got shape {chosen.shape}")
            self.in_mean = chosen[self.usable]
            if not self.in_mean.any():
                raise ValueError("mean_over leaves no complete frame in the mean")
        # the secant's two starting points, log f; ``run`` at them is what the search evaluates first
        self.start = [float(np.log(np.clip(f, self.lo, self.hi))) for f in (1.0, 0.5)]
        self.kept: tuple[float, np.ndarray] | None = None  # (f, pressures) of the latest run
        self.seen: list[Callable[[float, np.ndarray], None]] = []  # told of every run (scale_factors)

    def start_f(self) -> list[float]:
        """The factors of the secant's two starting evaluations, exactly as :meth:`solve` evaluates them."""
        return [float(np.exp(u)) for u in self.start]

    def run(self, f: float, given: np.ndarray | None = None) -> np.ndarray:
        """The sensor model at ``f·g`` over the trial's complete frames: pressures (U, n loaded cells), psi.

        ``given``: the trial's pressures (T, R, C) at ``f`` already computed by
        :func:`psmat.sensor.inverse_over_gaps` (e.g. CHC's, ``f`` = 1), taken instead of a run where
        the search's frames are the whole mat's (:attr:`whole_frames`): the model acts cell by cell
        from rest, so their loaded cells on the complete frames are this run's pressures, bit for bit."""
        if given is not None and self.whole_frames:
            pressure = given.reshape(given.shape[0], -1)
            if not self.usable.all():
                pressure = pressure[self.usable]
            if not self.loaded.all():
                pressure = pressure[:, self.loaded]
            pressure = np.ascontiguousarray(pressure)  # as a run's: its sums in the same order
        else:
            pressure = self.sensor.inverse(f * self.cells, self.steps)
        self.kept = (f, pressure)
        for tell in self.seen:
            tell(f, pressure)
        return pressure

    def pressure(self, f: float, shape: tuple[int, ...]) -> np.ndarray | None:
        """The trial's pressures (T, R, C), psi, at ``f`` when the latest :meth:`run` was at exactly
        ``f``: what :func:`psmat.sensor.inverse_over_gaps` gives for ``f·g`` (NaN on the incomplete
        frames, 0 on the cells that never conduct, the sensor model acting cell by cell), without
        running the model again; else None (also when a frame misses a cell that never conducts:
        :func:`~psmat.sensor.inverse_over_gaps` leaves that frame out, the search did not)."""
        if self.kept is None or self.kept[0] != f or not self.whole_frames:
            return None
        if self.loaded.all() and self.usable.all():  # the run's own array (read only), as (T, R, C)
            return self.kept[1].reshape(shape)
        out = np.full((shape[0], int(self.loaded.size)), np.nan)
        rows = np.zeros((int(self.usable.sum()), int(self.loaded.size)))
        rows[:, self.loaded] = self.kept[1]
        out[self.usable] = rows
        return out.reshape(shape)

    def force_n(self, pressure_psi: np.ndarray) -> float:
        """The mean force (N) of one :meth:`run`'s pressures: left side of eq. 3.3 (as :func:`_mean_force`)."""
        force = pressure_psi.sum(axis=1)
        return float(np.mean(force if self.in_mean is None else force[self.in_mean]) * PSI_PA * self.area * 1e-4)

    def force_of_means(self, mean_psi: np.ndarray) -> float:
        """:meth:`force_n` from the cells' means over the frames instead (the mean of the frames' sums is the
        sum of the cells' means; only with every frame in the mean)."""
        if self.in_mean is not None:
            raise ValueError("the cells' means give the mean force only when every frame is in the mean")
        return float(mean_psi.sum() * PSI_PA * self.area * 1e-4)

    def solve(self, known: dict[float, float] | None = None, nearest: bool = False) -> float:
        """``f`` (the root of eq. 3.3); ``known`` maps a factor to its mean force (N) already computed
        (e.g. by :meth:`force_n` of a :meth:`run` shared with another search), so it is not run again.
        ``nearest``: the secant starts from the two known factors nearest the root (the force
        closest to the weight, and the next closest at least 0.1 % away in log f) instead of
        f = 1 and 0.5."""
        known = known or {}
        w, lo, hi, rtol = self.w, self.lo, self.hi, self.rtol

        def excess(f: float) -> float:
            return (known[f] if f in known else self.force_n(self.run(f))) - w

        def log_ratio(u: float) -> float:
            with np.errstate(divide="ignore"):
                return float(np.log((excess(float(np.exp(u))) + w) / w))

        start = self.start
        if nearest:
            start = _nearest_pair(known, w, (lo, hi)) or start
        u = _secant(log_ratio, start[0], start[1], (np.log(lo), np.log(hi)), rtol) if start[0] != start[1] else None
        if u is not None:
            return float(np.exp(u))
        e_lo, e_hi = excess(lo), excess(hi)
        if e_lo > 0 or e_hi < 0:
            raise ValueError(f"the weight {w:g} N cannot be reached with f in [{lo:g}, {hi:g}]: the mean force is "
                             f"{e_lo + w:.4g} N at f = {lo:g} and {e_hi + w:.4g} N at f = {hi:g}")
        return float(optimize.brentq(excess, lo, hi, xtol=rtol * lo, rtol=max(rtol, 4 * np.finfo(float).eps)))


def scale_factors(g: ArrayLike, dt: float | ArrayLike, weight_n: float, sensor: MPICreep | None = None,
                  cell_area_cm2: float | None = None, *, factor: int = 2,
                  full: bool = True) -> tuple[float | None, dict[tuple[int, int], float]]:
    """Eq. 3.3 for the full mat and for each emulated coarser mat (:func:`psmat.balance.subgrids`) at once.

    The same ``f`` as :func:`scale_factor` on ``g`` and on each sub-grid ``g[:, r0::factor,
    c0::factor]`` (cell area ``factor²·A``), with the defaults of its other parameters; the sensor
    model acts cell by cell, so the full mat's two starting runs (``f`` = 1 and 0.5) give each
    sub-grid's starting forces as sums of their columns, and the sub-grid searches only run the
    sensor model from their third evaluation on. Where the sub-grid's complete frames are not
    the full mat's (a frame missing on some cells only), its search runs on its own.

    Parameters
    ----------
    g, dt, weight_n, sensor, cell_area_cm2
        As :func:`scale_factor` (``cell_area_cm2``: the full mat's cell area, cm²).
    factor : int
        Rows and columns of the full mat per row and column of the coarser one.
    full : bool
        Also solve the full mat's ``f`` (else the first value returned is None).

    Returns
    -------
    (float or None, dict)
        The full mat's ``f``, and ``{(r0, c0): f}`` of each sub-grid, in the order of
        :func:`psmat.balance.subgrids`.
    """
    cells = _checks.real_array(g, "g", unit="S", allow_nan=True)
    if cells.ndim != 3:
        raise ValueError(f"g must be a trial of frames (T, R, C) in S, got shape {cells.shape}")
    return _shared_searches(cells, dt, weight_n, sensor, cell_area_cm2, _checks.positive_int("factor", factor),
                            full)[0]


def _shared_searches(cells: np.ndarray, dt: float | ArrayLike, weight_n: float, sensor: MPICreep | None,
                     cell_area_cm2: float | None, k: int, full: bool, at_one: np.ndarray | None = None
                     ) -> tuple[tuple[float | None, dict[tuple[int, int], float]], _Search, dict[tuple[int, int], _Search]]:
    """:func:`scale_factors`, and the searches that found the factors (the full mat's, and each
    sub-grid's by its ``(r0, c0)``), whose last runs give the variants' pressures (:meth:`_Search.pressure`).

    Every run of the full mat's search gives each sub-grid its force at that ``f`` too (the sum of
    its columns), so a sub-grid's search starts from the two of those nearest its root. ``at_one``:
    the trial's pressures at ``f`` = 1 when already computed (CHC's), the full mat's first run
    (:meth:`_Search.run`'s ``given``)."""
    search = _Search(cells, dt, weight_n, sensor, cell_area_cm2, (1e-3, 1e3), RTOL, None)
    R, C = cells.shape[1:]
    where = np.flatnonzero(search.loaded)  # flat cell index of each loaded column of the runs
    subs: dict[tuple[int, int], _Search] = {}
    shared: dict[tuple[int, int], tuple[np.ndarray, dict[float, float]]] = {}
    for r0 in range(k):
        for c0 in range(k):
            sub = subs[(r0, c0)] = _Search(cells[:, r0::k, c0::k], dt, weight_n, search.sensor,
                                           search.area * (k * k), (1e-3, 1e3), RTOL, None)
            mine = ((where // C) % k == r0) & ((where % C) % k == c0)  # loaded cells of this sub-grid, in order
            if np.array_equal(sub.usable, search.usable) and int(mine.sum()) == sub.cells.shape[1]:
                shared[(r0, c0)] = (mine, {})

    def tell(f: float, pressure: np.ndarray) -> None:
        means = pressure.mean(axis=0)  # each loaded cell's mean over the frames: one pass for every sub-grid
        for key, (mine, forces) in shared.items():
            forces[f] = subs[key].force_of_means(means[mine])

    search.seen.append(tell)
    starts = search.start_f()
    runs = [search.run(f, at_one if f == 1.0 else None) for f in starts]
    known = {f: search.force_n(r) for f, r in zip(starts, runs)}
    del runs
    f_full = search.solve(known) if full else None
    search.seen.clear()
    out = {key: (sub.solve(shared[key][1], nearest=True) if key in shared else sub.solve())
           for key, sub in subs.items()}
    return (f_full, out), search, subs


def _nearest_pair(known: dict[float, float], w: float, bracket: tuple[float, float]) -> list[float] | None:
    """log f of the two factors of ``known`` (f -> mean force, N) nearest the root of eq. 3.3 for the
    weight ``w`` (N), in ``bracket``: the one whose force is closest to ``w`` (in log) last, the
    next closest at least 0.1 % away before it; None without two such (a force of zero has no log)."""
    by_gap = sorted((abs(float(np.log(force / w))), float(np.log(f))) for f, force in known.items()
                    if force > 0 and np.isfinite(force) and bracket[0] <= f <= bracket[1])
    if not by_gap:
        return None
    best = by_gap[0][1]
    other = next((u for _, u in by_gap[1:] if abs(u - best) >= 1e-3), None)
    return None if other is None else [other, best]


def _secant(h, u0: float, u1: float, bounds: tuple[float, float], tol: float, max_iter: int = 30) -> float | None:
    """A root of ``h`` by the secant method from ``u0``, ``u1``, to ``|Δu| <= tol``; None when an
    iterate leaves ``bounds``, ``h`` is not finite there (a zero force) or it does not converge."""
    h0, h1 = h(u0), h(u1)
    for _ in range(max_iter):
        if not (np.isfinite(h0) and np.isfinite(h1)) or h1 == h0:
            return None
        u2 = u1 - h1 * (u1 - u0) / (h1 - h0)
        if not bounds[0] <= u2 <= bounds[1]:
            return None
        if abs(u2 - u1) <= tol:
            return u1  # within tol of the root too, and the model has run there (_Search.pressure)
        u0, h0, u1, h1 = u1, h1, u2, h(u2)
    return None

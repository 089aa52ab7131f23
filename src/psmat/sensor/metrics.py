"""Material metrics of the pneumatic tests: variability, drift, creep, hysteresis (thesis §2.1.3, §2.4.3).

The four figures of merit the thesis uses to choose the mat's sensing material (eq. 2.1-2.4,
Tables 2.5-2.10, Fig. 2.34), computed as docs/spec.md §4 defines them:

variability (eq. 2.1, fast cyclic tests)
    ``CV² = std(ḡ)² / mean(ḡ)²`` over the set of values ``ḡ[cycle, cell]``, each the mean
    of the cell's conductance over the last Δt = 30 s of a load pulse; the SD is taken over
    cycles *and* cells together (so it holds both sources of variability).
drift (eq. 2.2, long test)
    ``mean(σ_window,cell) / g_mean``: per loaded step, the first half is discarded, the
    second half is cut into non-overlapping 30-s windows, ``σ_window,cell`` is the SD of one
    cell in one window, the mean is over windows and cells, ``g_mean`` the mean conductance
    over the same samples.
creep (eq. 2.3, long test)
    ``|slope(g)| / ḡ`` over the second half ``[t_e − ΔT/2, t_e]`` of each loaded step (a
    least-squares line against time), per cell, then averaged over cells; in 1/s.
hysteresis (eq. 2.4, hysteresis tests)
    ``max|g_up − g_down| / (max g − min g)`` of the cell-averaged (and repetition-averaged)
    loop; one value per loop (Tables 2.8, 2.9), Table 2.10 averages all loops.

A *run* is a :class:`~psmat.sensor.pneumatic.PneumaticRun` or anything with attributes
``t`` (s, (T,)), ``p`` (psi, (T,)), ``g`` (S, (T,) or (T, cells...)) and ``segments``
(:class:`~psmat.sensor.protocols.Segment` or tuples), or a tuple ``(t, p, g, segments)``.
Segments are the constant-pressure plateaus; those at a pressure > 0 are the load pulses /
loaded steps. NaN samples (e.g. shorted DAQ readings) leave the cell out of the average where
they occur; nothing here emits warnings.

Standard deviations use ``ddof=1`` (sample SD) by default; pass ``ddof=0`` for the
population SD.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import NDArray

from .protocols import Segment, as_segments

__all__ = [
    "StepMetric",
    "HysteresisLoop",
    "Run",
    "as_run",
    "pulse_means",
    "variability_by_level",
    "variability",
    "drift_by_step",
    "drift",
    "creep_by_step",
    "creep",
    "hysteresis_loops",
    "hysteresis",
    "material_table",
    "table_summary",
    "format_table",
    "CREEP_RADAR_TIME_S",
    "RADAR_AXES",
]

#: Creep is shown × 25 min in the radar chart (thesis Fig. 2.34: the load period of the long test).
CREEP_RADAR_TIME_S: float = 25 * 60.0

#: Axes of the radar chart, in order: (metric, label).
RADAR_AXES: tuple[tuple[str, str], ...] = (
    ("variability", "Variability (CV²)"),
    ("drift", "Drift"),
    ("creep", "Creep × 25 min"),
    ("hysteresis", "Hysteresis"),
)


class StepMetric(NamedTuple):
    """A metric of one loaded step of a long test.

    Attributes
    ----------
    step : int
        1-based position of the step among the run's plateaus (thesis numbering: "2) 5 PSI").
    level : float
        Applied pressure (psi).
    value : float
        The metric (drift: dimensionless; creep: 1/s).
    """

    step: int
    level: float
    value: float


@dataclass
class HysteresisLoop:
    """One hysteresis loop, averaged over cells and repetitions (eq. 2.4).

    Attributes
    ----------
    kind : str
        ``"descending"``: a 0 → P → 0 excursion, labelled by its peak P (Table 2.9);
        ``"ascending"``: the minor loop top → m → top inside a 0 → top → m → top → 0
        excursion, labelled by its valley m (Table 2.8).
    level : float
        The label: peak (descending) or valley (ascending), psi.
    p_psi : ndarray
        Pressures present on both branches (psi), increasing.
    g_up, g_down : ndarray
        Cell- and repetition-averaged conductance on the rising and falling branch at
        ``p_psi`` (S).
    value : float
        ``max|g_up − g_down| / (max g − min g)``, max/min over all plateaus of both branches;
        NaN when the loop has no range.
    n_repetitions : int
        Number of repetitions averaged.
    """

    kind: str
    level: float
    p_psi: NDArray[np.float64]
    g_up: NDArray[np.float64]
    g_down: NDArray[np.float64]
    value: float
    n_repetitions: int


# --------------------------------------------------------------------------- run handling
@dataclass
class Run:
    """A pneumatic run normalised for the metrics: samples ``t`` (s), pressure ``p`` (psi),
    conductance ``g`` (T, cells) in S, sampling period ``dt`` (s) and its plateaus."""

    name: str
    t: NDArray[np.float64]
    p: NDArray[np.float64]
    g: NDArray[np.float64]  # (T, cells)
    dt: float
    segments: list[Segment]


def as_run(run: Any) -> Run:
    """Normalise a run-like object (a :class:`~psmat.sensor.pneumatic.PneumaticRun`, anything with
    ``t``, ``p``, ``g``, ``segments``, or a ``(t, p, g, segments)`` tuple) to a :class:`Run`."""
    if isinstance(run, Run):
        return run
    if isinstance(run, tuple):
        if len(run) != 4:
            raise TypeError("a run tuple must be (t, p, g, segments)")
        t, p, g, segs = run
        name = "run"
    else:
        try:
            t, p, g, segs = run.t, run.p, run.g, run.segments
        except AttributeError:
            raise TypeError(f"a run needs attributes t, p, g, segments; got {type(run).__name__}") from None
        name = str(getattr(run, "name", "run"))
    t = np.asarray(t, dtype=np.float64)
    p = np.asarray(p, dtype=np.float64)
    g = np.asarray(g, dtype=np.float64)
    if t.ndim != 1 or p.shape != t.shape:
        raise ValueError(f"t and p must be (T,) arrays of the same length, got {t.shape} and {p.shape}")
    if g.ndim < 1 or g.shape[0] != t.shape[0]:
        raise ValueError(f"g must have T = {t.shape[0]} samples on its first axis, got shape {g.shape}")
    g = g.reshape(g.shape[0], -1)
    if t.size > 1 and np.any(np.diff(t) <= 0):
        raise ValueError("t must be strictly increasing")
    dt = float(getattr(run, "dt", np.nan)) if not isinstance(run, tuple) else np.nan
    if not (math.isfinite(dt) and dt > 0):
        dt = float(np.median(np.diff(t))) if t.size > 1 else 1.0
    segments = as_segments(segs, p)
    for s in segments:
        if s.stop > t.shape[0]:
            raise ValueError(f"segment [{s.start}, {s.stop}) beyond the run's {t.shape[0]} samples")
    return Run(name, t, p, g, dt, segments)


def _n_window(window_s: float, dt: float) -> int:
    if not (math.isfinite(window_s) and window_s > 0):
        raise ValueError(f"window_s must be finite and > 0 s, got {window_s!r}")
    return max(1, int(round(window_s / dt)))


def _nanmean(a: NDArray[np.float64], axis: int | None = None) -> Any:
    """Mean ignoring NaN, NaN (no warning) where nothing is left."""
    a = np.asarray(a, dtype=np.float64)
    ok = ~np.isnan(a)
    n = ok.sum(axis=axis)
    s = np.where(ok, a, 0.0).sum(axis=axis)
    with np.errstate(invalid="ignore", divide="ignore"):
        out = s / n
    return float(out) if np.ndim(out) == 0 else out


def _nanvar(a: NDArray[np.float64], ddof: int) -> float:
    v = np.asarray(a, dtype=np.float64).ravel()
    v = v[~np.isnan(v)]
    if v.size <= ddof:
        return math.nan
    return float(np.var(v, ddof=ddof))


def _loaded(segments: Sequence[Segment], min_level_psi: float) -> list[tuple[int, Segment]]:
    """(1-based position, segment) of the plateaus above ``min_level_psi``."""
    return [(k + 1, s) for k, s in enumerate(segments) if s.level > min_level_psi]


def _loaded_steps(r: Any, discard_fraction: float, min_level_psi: float) -> list[tuple[int, Segment]]:
    """Loaded steps of a long test (drift, creep), with the arguments they share checked."""
    if not (0.0 <= discard_fraction < 1.0):
        raise ValueError(f"discard_fraction must be in [0, 1), got {discard_fraction!r}")
    steps = _loaded(r.segments, min_level_psi)
    if not steps:
        raise ValueError(f"run {r.name!r}: no loaded step (plateau above {min_level_psi} psi)")
    return steps


def _kept_part(s: Segment, discard_fraction: float) -> tuple[int, int]:
    """Sample range of a step with its first ``discard_fraction`` discarded."""
    n = s.stop - s.start
    return s.start + int(math.floor(n * discard_fraction + 1e-9)), s.stop


# --------------------------------------------------------------------------- variability
def pulse_means(run: Any, window_s: float = 30.0, min_level_psi: float = 0.0
                ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Mean conductance of every cell over the last ``window_s`` of every load pulse (eq. 2.1).

    Parameters
    ----------
    run : run-like
        See the module docstring; load pulses are the plateaus above ``min_level_psi``.
    window_s : float
        Δt (s): ``ḡ = mean(g[t_e − Δt : t_e])``, i.e. the last ``round(Δt/dt)`` samples of
        the pulse. Thesis: 30 s of 120-s pulses.
    min_level_psi : float
        Plateaus at or below this pressure (psi) are rests.

    Returns
    -------
    levels : ndarray, shape (pulses,)
        Pressure of each pulse (psi).
    means : ndarray, shape (pulses, cells)
        ``ḡ[pulse, cell]`` (S).

    Raises
    ------
    ValueError
        When there is no load pulse, or a pulse is shorter than ``window_s``.
    """
    r = as_run(run)
    n = _n_window(window_s, r.dt)
    pulses = _loaded(r.segments, min_level_psi)
    if not pulses:
        raise ValueError(f"run {r.name!r}: no load pulse (plateau above {min_level_psi} psi)")
    out = np.empty((len(pulses), r.g.shape[1]))
    for k, (_, s) in enumerate(pulses):
        if s.stop - s.start < n:
            raise ValueError(f"run {r.name!r}: pulse [{s.start}, {s.stop}) is shorter than the "
                             f"{window_s} s window ({n} samples)")
        out[k] = _nanmean(r.g[s.stop - n:s.stop], axis=0)
    return np.array([s.level for _, s in pulses]), out


def variability_by_level(run: Any, window_s: float = 30.0, ddof: int = 1, min_level_psi: float = 0.0
                         ) -> dict[float, float]:
    """Variability CV² (eq. 2.1) of each load level of a fast cyclic run.

    ``CV² = var(ḡ[cycle, cell]) / mean(ḡ[cycle, cell])²`` with ``ḡ`` from
    :func:`pulse_means`; variance and mean over all (cycle, cell) pairs of the level.

    Returns
    -------
    dict
        Load pressure (psi) → CV² (dimensionless), increasing pressure.
    """
    levels, means = pulse_means(run, window_s, min_level_psi)
    out: dict[float, float] = {}
    for lv in sorted(set(levels.tolist())):
        v = means[levels == lv]
        mu = _nanmean(v)
        out[float(lv)] = _nanvar(v, ddof) / mu**2 if mu != 0 else math.nan
    return out


def variability(run: Any, window_s: float = 30.0, ddof: int = 1, min_level_psi: float = 0.0) -> float:
    """Variability CV² (eq. 2.1) of a fast cyclic run; the mean over levels if it has several.

    Parameters
    ----------
    run : run-like
        Fast cyclic run (load pulses = plateaus above ``min_level_psi`` psi).
    window_s : float
        Δt before the end of each pulse (s). Thesis: 30 s.
    ddof : int
        Delta degrees of freedom of the SD (1: sample SD).
    min_level_psi : float
        Plateaus at or below it are rests (psi).

    Returns
    -------
    float
        CV² (dimensionless).
    """
    return float(np.mean(list(variability_by_level(run, window_s, ddof, min_level_psi).values())))


# --------------------------------------------------------------------------- drift
def drift_by_step(run: Any, window_s: float = 30.0, discard_fraction: float = 0.5, ddof: int = 1,
                  min_level_psi: float = 0.0) -> list[StepMetric]:
    """Drift (eq. 2.2) of every loaded step of a long test.

    Per step: discard the first ``discard_fraction`` of it, cut the rest into non-overlapping
    windows of ``window_s`` (an incomplete last window is dropped), take the SD of each cell
    in each window, ``σ_window,cell``; drift = ``mean(σ_window,cell) / g_mean`` with both
    means over windows and cells (the same samples).

    Parameters
    ----------
    run : run-like
        Long staircase run.
    window_s : float
        Window length (s). Thesis: 30 s.
    discard_fraction : float
        Leading part of each step discarded. Thesis: one half.
    ddof : int
        Delta degrees of freedom of the window SD.
    min_level_psi : float
        Steps at or below this pressure (psi) are skipped (the thesis reports 5-30 psi).

    Returns
    -------
    list of StepMetric
        Dimensionless drift per step.

    Raises
    ------
    ValueError
        When a step's kept part is shorter than one window, or there is no loaded step.
    """
    r = as_run(run)
    n = _n_window(window_s, r.dt)
    steps = _loaded_steps(r, discard_fraction, min_level_psi)
    out = []
    for pos, s in steps:
        a, b = _kept_part(s, discard_fraction)
        nw = (b - a) // n
        if nw < 1:
            raise ValueError(f"run {r.name!r}: step {pos} keeps {b - a} samples, fewer than one "
                             f"{window_s} s window ({n} samples)")
        w = r.g[a:a + nw * n].reshape(nw, n, -1)  # (windows, samples, cells)
        ok = ~np.isnan(w)
        cnt = ok.sum(axis=1)  # (windows, cells)
        with np.errstate(invalid="ignore", divide="ignore"):
            mu = np.where(ok, w, 0.0).sum(axis=1) / cnt
            ss = np.where(ok, (w - mu[:, None, :]) ** 2, 0.0).sum(axis=1)
            sd = np.where(cnt > ddof, np.sqrt(ss / (cnt - ddof)), np.nan)  # σ_window,cell
        g_mean = _nanmean(w)
        out.append(StepMetric(pos, s.level, _nanmean(sd) / g_mean if g_mean != 0 else math.nan))
    return out


def drift(run: Any, window_s: float = 30.0, discard_fraction: float = 0.5, ddof: int = 1,
          min_level_psi: float = 0.0) -> float:
    """Drift (eq. 2.2) of a long test: the mean of :func:`drift_by_step` over loaded steps (dimensionless)."""
    return float(_nanmean(np.array([m.value for m in drift_by_step(run, window_s, discard_fraction, ddof,
                                                                    min_level_psi)])))


# --------------------------------------------------------------------------- creep
def creep_by_step(run: Any, discard_fraction: float = 0.5, min_level_psi: float = 0.0) -> list[StepMetric]:
    """Creep (eq. 2.3) of every loaded step of a long test, in 1/s.

    Per step and cell: the least-squares slope of ``g`` against ``t`` (S/s) over the second
    half ``[t_e − ΔT/2, t_e]`` of the step, ``|slope| / mean(g)`` over the same samples;
    then the average over cells (cells with NaN samples in the window are left out).

    Parameters
    ----------
    run : run-like
        Long staircase run.
    discard_fraction : float
        Leading part of each step discarded (thesis: one half, ΔT/2).
    min_level_psi : float
        Steps at or below this pressure (psi) are skipped.

    Returns
    -------
    list of StepMetric
        Creep per step (1/s).
    """
    r = as_run(run)
    steps = _loaded_steps(r, discard_fraction, min_level_psi)
    out = []
    for pos, s in steps:
        a, b = _kept_part(s, discard_fraction)
        if b - a < 2:
            raise ValueError(f"run {r.name!r}: step {pos} keeps fewer than 2 samples for a slope")
        x = r.t[a:b] - r.t[a:b].mean()
        y = r.g[a:b]  # (n, cells)
        ybar = y.mean(axis=0)  # NaN for cells with a NaN sample
        slope = (x[:, None] * (y - ybar)).sum(axis=0) / (x**2).sum()  # eq. 2.3 numerator, S/s
        with np.errstate(divide="ignore", invalid="ignore"):
            per_cell = np.abs(slope) / ybar
        per_cell[~np.isfinite(per_cell)] = np.nan
        out.append(StepMetric(pos, s.level, _nanmean(per_cell)))
    return out


def creep(run: Any, discard_fraction: float = 0.5, min_level_psi: float = 0.0) -> float:
    """Creep (eq. 2.3) of a long test: the mean of :func:`creep_by_step` over loaded steps (1/s)."""
    return float(_nanmean(np.array([m.value for m in creep_by_step(run, discard_fraction, min_level_psi)])))


# --------------------------------------------------------------------------- hysteresis
def _step_values(r: Run, settle_fraction: float) -> NDArray[np.float64]:
    """Cell-averaged conductance of each plateau over its last ``settle_fraction`` (S)."""
    gm = _nanmean(r.g, axis=1)  # cycles averaged over cells first (eq. 2.4)
    vals = np.empty(len(r.segments))
    for k, s in enumerate(r.segments):
        n = s.stop - s.start
        keep = max(1, int(math.ceil(n * settle_fraction - 1e-9)))
        vals[k] = _nanmean(gm[s.stop - keep:s.stop])
    return vals


def _key(level: float) -> float:
    return round(float(level), 6)


def hysteresis_loops(run: Any, settle_fraction: float = 0.5, zero_psi: float = 1e-6) -> list[HysteresisLoop]:
    """Hysteresis loops of a hysteresis run, with eq. 2.4 for each.

    The loops are found from the plateaus' pressures alone (so a CSV schedule works as well
    as a :class:`~psmat.sensor.protocols.Protocol`): every excursion between two 0-psi
    plateaus is one loop. If its maximum is reached once (0 → P → 0, descending series) the
    rising branch runs from the 0-psi plateau before it to the peak and the falling branch
    from the peak to the 0-psi plateau after it; label P. If the maximum is reached twice
    with a valley m between (0 → top → m → top → 0, ascending series) the loop is the minor
    one, falling top → m and rising m → top; label m.

    Each plateau contributes the cell-averaged conductance over its last ``settle_fraction``
    (the platform needs time to stabilise each 6-s step). Loops with the same kind and label
    (the repetitions) are averaged level by level before eq. 2.4, as the thesis does.

    Parameters
    ----------
    run : run-like
        Descending or ascending hysteresis run (one or several repetitions).
    settle_fraction : float
        Trailing part of each plateau averaged, in (0, 1].
    zero_psi : float
        Plateaus at or below this pressure (psi) are rests.

    Returns
    -------
    list of HysteresisLoop
        Sorted by kind, then label (as Tables 2.8, 2.9).

    Raises
    ------
    ValueError
        When the run has no loop.
    """
    r = as_run(run)
    if not (0.0 < settle_fraction <= 1.0):
        raise ValueError(f"settle_fraction must be in (0, 1], got {settle_fraction!r}")
    vals = _step_values(r, settle_fraction)
    lv = np.array([s.level for s in r.segments])
    zeros = np.flatnonzero(np.abs(lv) <= zero_psi)
    groups: dict[tuple[str, float], list[tuple[dict[float, list[float]], dict[float, list[float]]]]] = {}

    def branch(idx: Iterable[int]) -> dict[float, list[float]]:
        d: dict[float, list[float]] = {}
        for i in idx:
            d.setdefault(_key(lv[i]), []).append(float(vals[i]))
        return d

    for a, b in zip(zeros[:-1], zeros[1:]):
        if b <= a + 1:
            continue
        inner = np.arange(a, b + 1)
        L = lv[inner]
        top = L.max()
        pos = np.flatnonzero(np.abs(L - top) <= zero_psi)
        if np.all(np.diff(pos) == 1):  # one peak plateau: 0 → P → 0
            up, down = inner[:pos[0] + 1], inner[pos[-1]:]
            kind, label = "descending", top
        else:  # top → m → top inside the excursion
            i1, i2 = pos[0], pos[-1]
            j = i1 + int(np.argmin(L[i1:i2 + 1]))
            down, up = inner[i1:j + 1], inner[j:i2 + 1]
            kind, label = "ascending", L[j]
        groups.setdefault((kind, _key(label)), []).append((branch(up), branch(down)))
    if not groups:
        raise ValueError(f"run {r.name!r}: no hysteresis loop (excursion between two 0-psi plateaus)")

    loops = []
    for (kind, label), reps in groups.items():
        def avg(which: int) -> dict[float, float]:
            acc: dict[float, list[float]] = {}
            for rep in reps:
                for k, v in rep[which].items():
                    acc.setdefault(k, []).append(float(np.mean(v)))
            return {k: _nanmean(np.array(v)) for k, v in acc.items()}

        gu, gd = avg(0), avg(1)
        common = sorted(set(gu) & set(gd))
        allv = np.array(list(gu.values()) + list(gd.values()))
        allv = allv[~np.isnan(allv)]
        pu = np.array([gu[k] for k in common])
        pd = np.array([gd[k] for k in common])
        rng = float(allv.max() - allv.min()) if allv.size else 0.0
        diff = np.abs(pu - pd)
        diff = diff[~np.isnan(diff)]
        value = float(diff.max() / rng) if (rng > 0 and diff.size) else math.nan  # eq. 2.4
        loops.append(HysteresisLoop(kind, float(label), np.array(common, dtype=np.float64), pu, pd, value,
                                    len(reps)))
    loops.sort(key=lambda h: (h.kind, h.level))
    return loops


def hysteresis(run: Any, settle_fraction: float = 0.5, zero_psi: float = 1e-6) -> float:
    """Hysteresis (eq. 2.4) of a run: the mean over its loops (dimensionless)."""
    return float(_nanmean(np.array([h.value for h in hysteresis_loops(run, settle_fraction, zero_psi)])))


# --------------------------------------------------------------------------- tables
def _runs_of(obj: Any) -> list[Any]:
    if isinstance(obj, Mapping):
        return list(obj.values())
    if isinstance(obj, (list, tuple)) and not (len(obj) == 4 and isinstance(obj, tuple)
                                                and isinstance(obj[0], np.ndarray)):
        return list(obj)
    return [obj]


def material_table(runs_by_material: Mapping[str, Any], *, window_s: float = 30.0, ddof: int = 1
                   ) -> list[dict[str, Any]]:
    """Tidy table of the material metrics, like the thesis' Tables 2.5-2.10.

    Parameters
    ----------
    runs_by_material : mapping
        Material name → its runs (a sequence, a mapping of labels to runs, or one run). Each
        run is dispatched by its ``name``: ``"fast_cyclic…"`` → variability per load level
        (Table 2.5); ``"long_staircase…"`` → creep (Table 2.6) and drift (Table 2.7) per loaded
        step; ``"…hysteresis…"`` → hysteresis per loop (Tables 2.8, 2.9). Several runs of the
        same kind are averaged condition by condition.
    window_s : float
        Δt of eq. 2.1 and the drift window of eq. 2.2 (s). Thesis: 30 s.
    ddof : int
        Delta degrees of freedom of the SDs.

    Returns
    -------
    list of dict
        Rows ``{"material", "metric", "condition", "level_psi", "value", "unit"}`` with metric
        in ``"variability"``, ``"drift"``, ``"creep"``, ``"hysteresis"``; condition ``"5 psi"``
        (variability), ``"2) 5 psi"`` (creep, drift: step number and level),
        ``"ascending 4 psi"`` / ``"descending 32 psi"`` (hysteresis), and one ``"mean"`` row per
        metric: over levels (Table 2.5 "Mean"), over steps (Fig. 2.31-2.32), over all loops of
        both series (Table 2.10). Creep in 1/s, the rest dimensionless (unit ``""``).

    Raises
    ------
    ValueError
        For a run whose name is none of the above.
    """
    rows: list[dict[str, Any]] = []
    for material, runs in runs_by_material.items():
        acc: dict[str, dict[str, tuple[float | None, list[float]]]] = {
            m: {} for m in ("variability", "drift", "creep", "hysteresis")}

        def add(metric: str, cond: str, level: float | None, value: float) -> None:
            acc[metric].setdefault(cond, (level, []))[1].append(value)

        for run in _runs_of(runs):
            name = str(getattr(run, "name", ""))
            if name.startswith("fast_cyclic"):
                for lvl, v in variability_by_level(run, window_s, ddof).items():
                    add("variability", f"{lvl:g} psi", lvl, v)
            elif name.startswith("long_staircase"):
                for m in creep_by_step(run):
                    add("creep", f"{m.step}) {m.level:g} psi", m.level, m.value)
                for m in drift_by_step(run, window_s, ddof=ddof):
                    add("drift", f"{m.step}) {m.level:g} psi", m.level, m.value)
            elif "hysteresis" in name:
                for h in hysteresis_loops(run):
                    add("hysteresis", f"{h.kind} {h.level:g} psi", h.level, h.value)
            else:
                raise ValueError(f"material {material!r}: cannot tell the test of run {name!r}; expected a name "
                                 "starting with fast_cyclic or long_staircase, or containing hysteresis")
        for metric, conds in acc.items():
            if not conds:
                continue
            unit = "1/s" if metric == "creep" else ""
            items = list(conds.items())
            if metric == "hysteresis":  # Tables 2.8/2.9 order: ascending loops, then descending
                items.sort(key=lambda kv: (kv[0].split()[0], kv[1][0]))
            elif metric == "variability":
                items.sort(key=lambda kv: kv[1][0])
            vals = []
            for cond, (level, vs) in items:
                v = _nanmean(np.array(vs))
                vals.append(v)
                rows.append(dict(material=material, metric=metric, condition=cond, level_psi=level, value=v,
                                 unit=unit))
            rows.append(dict(material=material, metric=metric, condition="mean", level_psi=None,
                             value=_nanmean(np.array(vals)), unit=unit))
    return rows


def table_summary(table: Sequence[Mapping[str, Any]]) -> dict[str, dict[str, float]]:
    """The ``"mean"`` rows of a :func:`material_table` as ``{material: {metric: value}}``."""
    out: dict[str, dict[str, float]] = {}
    for row in table:
        if row["condition"] == "mean":
            out.setdefault(row["material"], {})[row["metric"]] = float(row["value"])
    return out


def format_table(table: Sequence[Mapping[str, Any]], metric: str, fmt: str = ".3g") -> str:
    """Plain-text pivot of one metric: materials as rows, conditions as columns (like Table 2.5).

    Parameters
    ----------
    table : list of dict
        Output of :func:`material_table`.
    metric : str
        ``"variability"``, ``"drift"``, ``"creep"`` or ``"hysteresis"``.
    fmt : str
        Format spec of the values.
    """
    sel = [r for r in table if r["metric"] == metric]
    if not sel:
        raise ValueError(f"no rows for metric {metric!r}")
    conds: list[str] = []
    mats: list[str] = []
    for r in sel:
        if r["condition"] not in conds:
            conds.append(r["condition"])
        if r["material"] not in mats:
            mats.append(r["material"])
    cell = {(r["material"], r["condition"]): format(r["value"], fmt) for r in sel}
    head = ["material"] + conds
    body = [[m] + [cell.get((m, c), "") for c in conds] for m in mats]
    widths = [max(len(x) for x in col) for col in zip(head, *body)]
    lines = ["  ".join(x.ljust(w) for x, w in zip(row, widths)).rstrip() for row in [head] + body]
    return "\n".join(lines)

"""Pneumatic test protocols for material characterisation (thesis §2.4.2, docs/spec.md §4).

The thesis characterises sensing materials on a pneumatic platform (Tekscan PB100E) with four
pressure patterns, all sampled by the material DAQ every 500 ms (2 Hz):

* **fast cyclic** (repeatability, eq. 2.1): 20 × (2 min at P, 2 min at 0 psi), P = 5 and
  15 psi as two independent runs (≥ 80 min of rest between them, Fig. 2.23);
* **long staircase** (creep, eq. 2.3, and drift, eq. 2.2): 0 → 5 → 15 → 30 → 15 → 5 → 0 psi,
  25 min per step (Fig. 2.24);
* **descending hysteresis** (eq. 2.4, Table 2.9): 2-psi steps of 6 s,
  0→32→0→28→0→…→4→0 (Fig. 2.25);
* **ascending hysteresis** (eq. 2.4, Table 2.8): 2-psi steps of 6 s,
  0→32→4→32→0→32→8→32→0 … →32→28→32→0 (Fig. 2.26).

The hysteresis series are repeated ten times. Each generator returns a :class:`Protocol`: the
applied pressure at the sampling rate plus a list of :class:`Segment` — one per
constant-pressure plateau (a load pulse, a rest, a staircase step, a 6-s hysteresis step) — so
that the material metrics (:mod:`psmat.sensor.metrics`) can find them.

Conventions
-----------
* Times in s, pressures in psi, sample ``k`` at ``t = k·dt`` and holding the pressure applied
  during ``[k·dt, (k+1)·dt)``.
* Segment indices are Python slice bounds: ``p[seg.start:seg.stop]`` is the plateau.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._checks import positive, positive_int

__all__ = [
    "Segment",
    "Protocol",
    "fast_cyclic",
    "long_staircase",
    "descending_hysteresis",
    "ascending_hysteresis",
    "standard_protocols",
    "segments_from_pressure",
    "as_segments",
    "PROTOCOL_NAMES",
]

#: Names carried by :attr:`Protocol.name` (and by runs made from the protocols).
PROTOCOL_NAMES: tuple[str, ...] = (
    "fast_cyclic",
    "long_staircase",
    "descending_hysteresis",
    "ascending_hysteresis",
)


class Segment(NamedTuple):
    """One constant-pressure plateau of a protocol.

    Attributes
    ----------
    start, stop : int
        Sample indices, slice convention (``stop`` excluded).
    label : str
        ``"load"`` / ``"rest"`` (fast cyclic), ``"step"`` (staircase), ``"up"`` / ``"down"`` /
        ``"rest"`` (hysteresis steps: how the level was reached; ``"rest"`` at 0 psi),
        ``"hold"`` (from :func:`segments_from_pressure`).
    level : float
        Applied pressure on the plateau (psi).
    cycle : int
        Cycle (fast cyclic), step (staircase) or loop (hysteresis) number within the
        repetition, 0-based; -1 when not meaningful.
    repetition : int
        Repetition of the whole series, 0-based.
    """

    start: int
    stop: int
    label: str
    level: float
    cycle: int = -1
    repetition: int = 0


@dataclass
class Protocol:
    """An applied-pressure protocol sampled at a fixed rate.

    Attributes
    ----------
    name : str
        One of :data:`PROTOCOL_NAMES` for the generators of this module.
    t_s : ndarray, shape (T,)
        Sample times (s), ``k·dt_s``.
    p_psi : ndarray, shape (T,)
        Applied pressure (psi).
    dt_s : float
        Sampling period (s); the material DAQ sends every 0.5 s.
    segments : list of Segment
        Constant-pressure plateaus in time order, covering every sample exactly once.
    params : dict
        The generator's arguments (for records and re-generation).
    """

    name: str
    t_s: NDArray[np.float64]
    p_psi: NDArray[np.float64]
    dt_s: float
    segments: list[Segment]
    params: dict[str, Any] = field(default_factory=dict)

    @property
    def n_samples(self) -> int:
        """Number of samples T."""
        return int(self.p_psi.shape[0])

    @property
    def duration_s(self) -> float:
        """Total duration ``T·dt`` (s)."""
        return self.n_samples * self.dt_s

    def levels(self) -> list[float]:
        """Plateau pressures in order (psi), one per segment."""
        return [s.level for s in self.segments]


# --------------------------------------------------------------------------- helpers
def _n_samples(name: str, duration_s: float, dt: float) -> int:
    """Whole number of samples in ``duration_s`` (s) at period ``dt`` (s)."""
    duration_s = positive(name, duration_s)
    n = duration_s / dt
    k = round(n)
    if k < 1 or abs(n - k) > 1e-9 * max(1.0, n):
        raise ValueError(f"{name} = {duration_s} s is not a whole number of samples of dt = {dt} s")
    return int(k)


def _build(name: str, plateaus: Sequence[tuple[str, float, int, int, int]], dt: float,
           params: dict[str, Any]) -> Protocol:
    """Protocol from plateaus ``(label, level_psi, n_samples, cycle, repetition)``."""
    lengths = np.array([pl[2] for pl in plateaus], dtype=np.int64)
    p = np.repeat(np.array([pl[1] for pl in plateaus], dtype=np.float64), lengths)
    bounds = np.concatenate(([0], np.cumsum(lengths)))
    segments = [
        Segment(int(bounds[k]), int(bounds[k + 1]), pl[0], float(pl[1]), int(pl[3]), int(pl[4]))
        for k, pl in enumerate(plateaus)
    ]
    t = np.arange(p.shape[0], dtype=np.float64) * dt
    return Protocol(name=name, t_s=t, p_psi=p, dt_s=dt, segments=segments, params=params)


def _walk(points: Sequence[float], step_psi: float) -> list[float]:
    """Levels visited going through the turning ``points`` in ``step_psi`` increments.

    Each turning point appears once (it is one plateau); e.g. ``[0, 4, 0]`` with 2-psi steps
    gives ``[0, 2, 4, 2, 0]``.
    """
    units = []
    for pt in points:
        u = pt / step_psi
        if abs(u - round(u)) > 1e-9:
            raise ValueError(f"turning point {pt} psi is not a multiple of the {step_psi} psi step")
        units.append(int(round(u)))
    levels = [units[0]]
    for a, b in zip(units[:-1], units[1:]):
        if b == a:
            raise ValueError("consecutive turning points must differ")
        d = 1 if b > a else -1
        levels.extend(range(a + d, b + d, d))
    return [u * step_psi for u in levels]


def _hysteresis_plateaus(points: Sequence[float], step_psi: float, n_step: int,
                         repetitions: int) -> list[tuple[str, float, int, int, int]]:
    """Plateaus of a hysteresis series, ``(label, level, n_step, loop, repetition)``.

    Loops are the excursions away from 0 psi, numbered from 0 within a repetition; a 0-psi
    plateau carries the number of the loop it precedes (the last one: of the loop it ends).
    """
    levels = _walk(points, step_psi)
    labels: list[str] = []
    loops: list[int] = []
    loop = -1
    for k, lv in enumerate(levels):
        if lv == 0.0:
            labels.append("rest")
            loops.append(-1)
            continue
        if k == 0 or levels[k - 1] == 0.0:
            loop += 1
        labels.append("up" if k == 0 or lv > levels[k - 1] else "down")
        loops.append(loop)
    nxt = max(loop, 0)
    for k in range(len(levels) - 1, -1, -1):  # zeros: the loop that follows, else the last
        if loops[k] == -1:
            loops[k] = nxt
        else:
            nxt = loops[k]
    return [(labels[k], float(levels[k]), n_step, loops[k], rep)
            for rep in range(repetitions) for k in range(len(levels))]


# --------------------------------------------------------------------------- generators
def fast_cyclic(level_psi: float = 5.0, cycles: int = 20, on_s: float = 120.0, off_s: float = 120.0,
                dt: float = 0.5) -> Protocol:
    """Fast cyclic test: ``cycles`` × (``on_s`` at ``level_psi``, ``off_s`` at 0) (thesis §2.4.2, Fig. 2.23).

    Used for variability (eq. 2.1, Δt = 30 s before the end of each load pulse). The thesis
    runs it at 5 and at 15 psi as two independent runs with at least 80 min of rest between
    them: call this function once per level.

    Parameters
    ----------
    level_psi : float
        Load pressure P (psi), > 0. Thesis: 5 and 15 psi.
    cycles : int
        Number of load/unload cycles. Thesis: 20.
    on_s, off_s : float
        Duration of the load and of the unload part of each cycle (s). Thesis: 120 s each.
    dt : float
        Sampling period (s). Material DAQ: 0.5 s.

    Returns
    -------
    Protocol
        ``name="fast_cyclic"``; segments alternate ``"load"`` and ``"rest"``, ``cycle`` = cycle
        number. The run starts with the first load pulse and ends with the last rest.
    """
    dt = positive("dt", dt)
    level = positive("level_psi", level_psi)
    cycles = positive_int("cycles", cycles)
    n_on, n_off = _n_samples("on_s", on_s, dt), _n_samples("off_s", off_s, dt)
    plateaus = []
    for k in range(cycles):
        plateaus.append(("load", level, n_on, k, 0))
        plateaus.append(("rest", 0.0, n_off, k, 0))
    params = dict(level_psi=level, cycles=cycles, on_s=float(on_s), off_s=float(off_s), dt=dt)
    return _build("fast_cyclic", plateaus, dt, params)


def long_staircase(levels: Sequence[float] = (0, 5, 15, 30, 15, 5, 0), step_s: float = 25 * 60,
                   dt: float = 0.5) -> Protocol:
    """Long test: a pressure staircase, ``step_s`` per step (thesis §2.4.2, Fig. 2.24).

    Used for creep (eq. 2.3, second half of each step) and drift (eq. 2.2, 30-s windows in
    the second half of each step).

    Parameters
    ----------
    levels : sequence of float
        Pressure of each step (psi), >= 0. Thesis: 0, 5, 15, 30, 15, 5, 0.
    step_s : float
        Duration of each step (s). Thesis: 25 min = 1500 s.
    dt : float
        Sampling period (s).

    Returns
    -------
    Protocol
        ``name="long_staircase"``; one ``"step"`` segment per level, ``cycle`` = step number
        (0-based; the thesis' tables number them from 1: "2) 5 PSI" is ``cycle`` 1).
    """
    dt = positive("dt", dt)
    lv = [float(v) for v in levels]
    if not lv:
        raise ValueError("levels must not be empty")
    if any(not math.isfinite(v) or v < 0 for v in lv):
        raise ValueError(f"levels must be finite and >= 0 psi, got {list(levels)!r}")
    n = _n_samples("step_s", step_s, dt)
    plateaus = [("step", v, n, k, 0) for k, v in enumerate(lv)]
    return _build("long_staircase", plateaus, dt, dict(levels=tuple(lv), step_s=float(step_s), dt=dt))


def descending_hysteresis(step_psi: float = 2.0, step_s: float = 6.0, p_max: float = 32.0,
                          repetitions: int = 10, dt: float = 0.5, peak_step_psi: float = 4.0) -> Protocol:
    """Descending hysteresis series 0→32→0→28→0→…→4→0 (thesis §2.4.2 list 1, Fig. 2.25).

    Every change is made in ``step_psi`` steps held ``step_s`` each; each loop climbs from 0 to
    its peak and back to 0, the peak ``peak_step_psi`` lower than the previous one, down to
    ``peak_step_psi``. Turning points (the peak, the zeros between loops) are one plateau
    each, so one repetition with the defaults has ``1 + Σ peaks/2·2 = 145`` plateaus of 6 s
    (870 s; 1740 samples at 2 Hz) — identical to ``reference/mpi_creep_descending.json``.

    Parameters
    ----------
    step_psi : float
        Pressure increment (psi). Thesis: 2.
    step_s : float
        Duration of each plateau (s). Thesis: 6.
    p_max : float
        Peak of the first loop (psi). Thesis: 32.
    repetitions : int
        Number of times the whole series is applied. Thesis: 10. Repetitions are
        concatenated as they are: each starts and ends with its own 0-psi plateau, so
        consecutive repetitions are separated by two 0-psi plateaus (12 s).
    dt : float
        Sampling period (s).
    peak_step_psi : float
        Decrease of the peak from one loop to the next (psi). Thesis: 4.

    Returns
    -------
    Protocol
        ``name="descending_hysteresis"``; one segment per plateau labelled ``"up"``,
        ``"down"`` or ``"rest"`` (0 psi), ``cycle`` = loop number (0: peak 32 psi),
        ``repetition``. The loop labelled by its peak P (Table 2.9) is the 0→P→0 excursion.
    """
    dt = positive("dt", dt)
    step_psi, p_max = positive("step_psi", step_psi), positive("p_max", p_max)
    dec = positive("peak_step_psi", peak_step_psi)
    repetitions = positive_int("repetitions", repetitions)
    n = _n_samples("step_s", step_s, dt)
    n_loops = int(math.floor(p_max / dec + 1e-9))
    peaks = [p_max - k * dec for k in range(n_loops) if p_max - k * dec > 1e-9]
    points: list[float] = [0.0]
    for pk in peaks:
        points += [pk, 0.0]
    plateaus = _hysteresis_plateaus(points, step_psi, n, repetitions)
    params = dict(step_psi=step_psi, step_s=float(step_s), p_max=p_max, repetitions=repetitions, dt=dt,
                  peak_step_psi=dec, peaks=tuple(peaks))
    return _build("descending_hysteresis", plateaus, dt, params)


def ascending_hysteresis(step_psi: float = 2.0, step_s: float = 6.0, p_max: float = 32.0,
                         repetitions: int = 10, dt: float = 0.5, valley_step_psi: float = 4.0) -> Protocol:
    """Ascending hysteresis series 0→32→4→32→0→32→8→32→0 … →32→28→32→0 (thesis §2.4.2 list 2, Fig. 2.26).

    Each loop climbs from 0 to ``p_max``, goes down to its valley m, back up to ``p_max`` (the
    minor loop "in the upper part of the conductance vs. pressure diagram" that Table 2.8
    labels by m) and returns to 0; the valley rises by ``valley_step_psi`` from one loop to
    the next: m = 4, 8, …, 28 psi (7 loops). Every change is made in ``step_psi`` steps held
    ``step_s`` each, turning points being one plateau each: one repetition with the defaults
    has ``1 + Σ_m (64 − m) = 337`` plateaus (2022 s; 4044 samples at 2 Hz).

    Parameters
    ----------
    step_psi : float
        Pressure increment (psi). Thesis: 2.
    step_s : float
        Duration of each plateau (s). Thesis: 6.
    p_max : float
        Top of every loop (psi). Thesis: 32.
    repetitions : int
        Number of times the whole series is applied (concatenated as for
        :func:`descending_hysteresis`). Thesis: 10.
    dt : float
        Sampling period (s).
    valley_step_psi : float
        Increase of the valley from one loop to the next, also the first valley (psi).
        Thesis: 4.

    Returns
    -------
    Protocol
        ``name="ascending_hysteresis"``; segments as in :func:`descending_hysteresis`.
    """
    dt = positive("dt", dt)
    step_psi, p_max = positive("step_psi", step_psi), positive("p_max", p_max)
    inc = positive("valley_step_psi", valley_step_psi)
    repetitions = positive_int("repetitions", repetitions)
    n = _n_samples("step_s", step_s, dt)
    valleys = []
    k = 1
    while k * inc < p_max - 1e-9:
        valleys.append(k * inc)
        k += 1
    if not valleys:
        raise ValueError(f"valley_step_psi = {inc} leaves no valley below p_max = {p_max}")
    points: list[float] = [0.0]
    for m in valleys:
        points += [p_max, m, p_max, 0.0]
    plateaus = _hysteresis_plateaus(points, step_psi, n, repetitions)
    params = dict(step_psi=step_psi, step_s=float(step_s), p_max=p_max, repetitions=repetitions, dt=dt,
                  valley_step_psi=inc, valleys=tuple(valleys))
    return _build("ascending_hysteresis", plateaus, dt, params)


def standard_protocols(dt: float = 0.5) -> dict[str, Protocol]:
    """The five runs of the thesis' material characterisation (§2.4.2), at period ``dt`` (s).

    Returns
    -------
    dict
        ``"fast_cyclic_5"``, ``"fast_cyclic_15"``, ``"long_staircase"``,
        ``"descending_hysteresis"``, ``"ascending_hysteresis"`` with the thesis' numbers
        (20 cycles, 25-min steps, 10 repetitions). The fast cyclic runs are independent (the
        thesis rests the material ≥ 80 min between them): simulate them separately.
    """
    return {
        "fast_cyclic_5": fast_cyclic(5.0, dt=dt),
        "fast_cyclic_15": fast_cyclic(15.0, dt=dt),
        "long_staircase": long_staircase(dt=dt),
        "descending_hysteresis": descending_hysteresis(dt=dt),
        "ascending_hysteresis": ascending_hysteresis(dt=dt),
    }


# --------------------------------------------------------------------------- segments
def segments_from_pressure(p_psi: ArrayLike, *, tol_psi: float = 1e-6) -> list[Segment]:
    """Constant-pressure plateaus of a stepwise pressure trace.

    Parameters
    ----------
    p_psi : array_like, shape (T,)
        Applied pressure (psi), e.g. a schedule read from CSV and held between its rows.
    tol_psi : float
        Changes of at most this much (psi) do not start a new plateau.

    Returns
    -------
    list of Segment
        Label ``"hold"``, ``cycle`` = plateau number; NaN samples (no schedule) are left out.
    """
    p = np.asarray(p_psi, dtype=np.float64)
    if p.ndim != 1:
        raise ValueError(f"p_psi must be 1-D, got shape {p.shape}")
    out: list[Segment] = []
    k, T = 0, p.shape[0]
    while k < T:
        if np.isnan(p[k]):
            k += 1
            continue
        j = k + 1
        while j < T and not np.isnan(p[j]) and abs(p[j] - p[k]) <= tol_psi:
            j += 1
        out.append(Segment(k, j, "hold", float(p[k]), len(out), 0))
        k = j
    return out


def as_segments(segments: Iterable[Any], p_psi: ArrayLike | None = None) -> list[Segment]:
    """Normalise segment descriptions to :class:`Segment`, sorted by start.

    Accepts :class:`Segment` objects, tuples ``(start, stop, label, level[, cycle[, repetition]])``
    and tuples ``(start, stop, level)`` or ``(start, stop, label)``; in the last form the
    level is the median of ``p_psi`` over the plateau (psi).

    Raises
    ------
    ValueError
        For a malformed entry, or an empty/reversed index range.
    """
    p = None if p_psi is None else np.asarray(p_psi, dtype=np.float64)
    out: list[Segment] = []
    for k, s in enumerate(segments):
        if isinstance(s, Segment):
            seg = s
        else:
            tup = tuple(s)
            if len(tup) == 3:
                start, stop, x = tup
                if isinstance(x, str):
                    if p is None:
                        raise ValueError(f"segment {k}: a (start, stop, label) segment needs p_psi for its level")
                    seg = Segment(int(start), int(stop), x, float(np.median(p[int(start):int(stop)])))
                else:
                    seg = Segment(int(start), int(stop), "hold", float(x))
            elif 4 <= len(tup) <= 6:
                start, stop, label, level, *rest = tup
                seg = Segment(int(start), int(stop), str(label), float(level), *(int(v) for v in rest))
            else:
                raise ValueError(f"segment {k}: expected 3 to 6 fields, got {len(tup)}")
        if seg.stop <= seg.start or seg.start < 0:
            raise ValueError(f"segment {k}: empty or reversed index range [{seg.start}, {seg.stop})")
        if p is not None and seg.stop > p.shape[0]:
            raise ValueError(f"segment {k}: stop {seg.stop} beyond the {p.shape[0]} samples")
        out.append(seg)
    return sorted(out, key=lambda s: (s.start, s.stop))

"""Pneumatic-platform runs: simulated ones and the material DAQ's logs (thesis §2.4.1, docs/spec.md §4-5).

A :class:`PneumaticRun` is what the material metrics (:mod:`psmat.sensor.metrics`) consume:
sample times ``t`` (s), applied pressure ``p`` (psi), the conductance of every sensor ``g``
(S, shape ``(T, cells)``) and the constant-pressure plateaus (``segments``) of the protocol.

* :func:`simulate_run` plays a :class:`~psmat.sensor.protocols.Protocol` through the direct
  sensor model (:class:`~psmat.sensor.MPICreep`, thesis Table 2.11 by default) for a number of
  cells, with cell-to-cell variability and measurement noise.
* :func:`load_daq_log` reads the text stream of the material DAQ (ATmega4809 on an Arduino
  Nano Every, thesis §2.4.1 / Fig. 2.22): one line every 500 ms with the readings of its 10
  sensors, converts the ADC readings to conductance through the DAQ's voltage divider and
  aligns them with the applied-pressure schedule.

The divider (Fig. 2.22 is only a picture in the text; §2.4.1: "the mux output is connected to a
voltage divider circuit", "each sensor has a different line (ground is common)"): the sensor
sits between the multiplexer output and the common ground, the divider resistor ``R_o``
between the ADC node and ``V_ref`` — the same topology as the mat's reading circuit (§2.1.4,
Fig. 2.3)::

    V = V_ref · R_s / (R_o + R_s)        ⇒   g = 1/R_s = (V_ref − V) / (R_o · V)

(``sensor_side="high"`` selects the mirrored divider, ``V = V_ref · R_o / (R_o + R_s)``).
The thesis gives no component values for this DAQ; the defaults are the thesis' divider
resistor (R_o = 2.2 kΩ, §2.2.1) with the ATmega4809's 10-bit ADC referred to the Nano Every's
5 V supply. Counts are converted at the code centre ``V = count/(2**bits − 1)·V_ref``, so
``V_ref`` only matters for logs written in volts.
"""

from __future__ import annotations

import csv
import io
import math
import os
import re
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal, NamedTuple, Union

import numpy as np
from numpy.typing import NDArray

from .._checks import conductances, fraction, positive, positive_int
from .._text import NotTextError, read_text
from ..circuit import OPEN, Circuit
from ..protocol import parse_daq_fields
from ..units import header_unit, kpa_per_unit, psi_from_kpa, s_per_unit
from ._mpi_creep import MPICreep
from .protocols import Protocol, Segment, segments_from_pressure

__all__ = [
    "PneumaticRun",
    "SkippedLine",
    "simulate_run",
    "load_daq_log",
    "load_daq_session",
    "load_schedule_csv",
    "divider_conductance",
    "divider_counts",
    "DAQ_R_O",
    "DAQ_V_REF",
    "DAQ_BITS",
    "DAQ_PERIOD_S",
    "DAQ_N_SENSORS",
]

#: Divider resistor of the material DAQ (Ω): the thesis' R_o (§2.2.1); not stated for Fig. 2.22.
DAQ_R_O: float = 2200.0
#: Reference voltage of the material DAQ's ADC (V): the Nano Every's 5 V (USB powered).
DAQ_V_REF: float = 5.0
#: ADC resolution of the ATmega4809 (bits).
DAQ_BITS: int = 10
#: Period of the material DAQ's lines (s): "every 500 ms" (§2.4.1).
DAQ_PERIOD_S: float = 0.5
#: Number of sensors on each material PCB (§2.4.1: "10 interdigital electrodes").
DAQ_N_SENSORS: int = 10

PathOrLines = Union[str, "os.PathLike[str]", Iterable[str]]


class SkippedLine(NamedTuple):
    """A line of a log that was left out, with why.

    Attributes
    ----------
    line_no : int
        1-based line number in the source.
    text : str
        The line, without its end-of-line characters.
    reason : str
        E.g. ``"trailing partial line"``.
    """

    line_no: int
    text: str
    reason: str


@dataclass
class PneumaticRun:
    """One pneumatic-platform run: applied pressure and the sensors' conductance.

    Attributes
    ----------
    name : str
        The protocol's name (``"fast_cyclic"``, ``"long_staircase"``,
        ``"descending_hysteresis"``, ``"ascending_hysteresis"``) or a user label.
    t : ndarray, shape (T,)
        Sample times (s).
    p : ndarray, shape (T,)
        Applied pressure (psi); NaN where no schedule is known.
    g : ndarray, shape (T, cells)
        Conductance of each sensor (S).
    dt : float
        Sampling period (s).
    segments : list of Segment
        Constant-pressure plateaus, as sample-index ranges of this run.
    flags : ndarray of uint8, shape (T, cells), optional
        Reading flags of a DAQ log (:data:`psmat.circuit.OK`, ``SHORT``, ``OPEN``).
    skipped : list of SkippedLine
        Lines of a DAQ log that were left out (a trailing partial line).
    meta : dict
        Provenance: model, gains, noise, circuit parameters, alignment.
    """

    name: str
    t: NDArray[np.float64]
    p: NDArray[np.float64]
    g: NDArray[np.float64]
    dt: float
    segments: list[Segment]
    flags: NDArray[np.uint8] | None = None
    skipped: list[SkippedLine] = field(default_factory=list)
    meta: dict[str, Any] = field(default_factory=dict)

    @property
    def n_cells(self) -> int:
        """Number of sensors (columns of ``g``)."""
        return int(self.g.shape[1])


# --------------------------------------------------------------------------- simulation
def simulate_run(protocol: Protocol, model: MPICreep | None = None, cells: int = 10, variability: float = 0.1,
                 noise_rel: float = 0.005, rng: np.random.Generator | int | None = None) -> PneumaticRun:
    """Simulate the material DAQ's output for a protocol.

    Each cell follows the direct sensor model (eq. 2.15-2.25) from rest; cell ``c`` has its
    own output gain ``k_c`` and every sample its own relative noise::

        g[t, c] = k_c · model.direct(p)[t] · (1 + noise_rel · ε[t, c]),   ε ~ N(0, 1)
        k_c ~ LogNormal(μ, s²),  s² = ln(1 + variability²),  μ = −s²/2

    so that ``E[k] = 1`` and ``SD[k]/E[k] = variability`` exactly (the log-normal keeps the
    gains positive). Cell-to-cell gain spread is what makes the thesis' CV² (eq. 2.1) larger
    than the cycle-to-cycle spread alone.

    Parameters
    ----------
    protocol : Protocol
        Applied pressure (psi) at period ``protocol.dt_s`` (s).
    model : MPICreep, optional
        Direct sensor model; default :meth:`MPICreep.thesis` (Table 2.11, Velostat).
    cells : int
        Number of sensors (thesis PCBs: 10).
    variability : float
        Relative SD of the per-cell gain (dimensionless, >= 0; 0 = identical cells).
    noise_rel : float
        Relative SD of the per-sample Gaussian noise (dimensionless, >= 0).
    rng : numpy.random.Generator or int, optional
        Random source or seed (default: fresh entropy).

    Returns
    -------
    PneumaticRun
        ``g`` of shape (T, cells) in S; ``meta["gains"]`` holds the ``k_c``.
    """
    if not isinstance(protocol, Protocol):
        raise TypeError(f"protocol must be a Protocol, got {type(protocol).__name__}")
    cells = positive_int("cells", cells)
    variability = fraction("variability", variability, 0.0, math.inf)
    noise_rel = fraction("noise_rel", noise_rel, 0.0, math.inf)
    model = MPICreep.thesis() if model is None else model
    gen = np.random.default_rng(rng)
    g0 = model.direct(protocol.p_psi, protocol.dt_s)  # (T,) S, one cell from rest
    s2 = math.log1p(float(variability) ** 2)
    gains = np.exp(gen.normal(-s2 / 2.0, math.sqrt(s2), size=cells)) if s2 > 0 else np.ones(cells)
    g = g0[:, None] * gains[None, :]
    if noise_rel > 0:
        g = g * (1.0 + float(noise_rel) * gen.standard_normal(g.shape))
    meta = dict(model=repr(model), gains=gains, variability=float(variability), noise_rel=float(noise_rel),
                protocol_params=dict(protocol.params))
    return PneumaticRun(name=protocol.name, t=protocol.t_s.copy(), p=protocol.p_psi.copy(), g=g,
                        dt=protocol.dt_s, segments=list(protocol.segments), meta=meta)


# --------------------------------------------------------------------------- divider
def _check_divider(r_o: float, v_ref: float, bits: int, sensor_side: str) -> None:
    positive("r_o", r_o)  # Ω
    positive("v_ref", v_ref)  # V
    if isinstance(bits, bool) or int(bits) != bits or not 1 <= int(bits) <= 16:
        raise ValueError(f"bits must be an integer in 1..16, got {bits!r}")
    if sensor_side not in ("low", "high"):
        raise ValueError(f"sensor_side must be 'low' or 'high', got {sensor_side!r}")


def _divider(r_o: float, sensor_side: str, bits: int = 16) -> Circuit:
    """The material DAQ's divider as the measurement chain of :class:`psmat.Circuit` (V_ref
    normalised to 1, no multiplexer, ideal ADC, the sensor on either side): one home for the
    divider equations."""
    return Circuit(r_o=float(r_o), r_mux=0.0, r_adc=np.inf, v_ref=1.0, bits=int(bits), sensor_side=sensor_side)


def divider_conductance(x: NDArray[np.float64], r_o: float = DAQ_R_O,
                        sensor_side: Literal["low", "high"] = "low", open_value: float = 0.0
                        ) -> tuple[NDArray[np.float64], NDArray[np.uint8]]:
    """Sensor conductance from the divider ratio ``x = V/V_ref``.

    Parameters
    ----------
    x : ndarray
        Divider ratio in [0, 1] (dimensionless).
    r_o : float
        Divider resistor (Ω).
    sensor_side : {"low", "high"}
        ``"low"``: sensor between the node and ground, ``x = R_s/(R_o + R_s)``,
        ``g = (1 − x)/(R_o x)``; ``"high"``: ``x = R_o/(R_o + R_s)``, ``g = x/(R_o (1 − x))``.
    open_value : float
        Conductance reported for an open reading (S). Default 0: an unloaded sensor beyond
        the divider's range is, physically, no conductance (finite, unlike a short).

    Returns
    -------
    g : ndarray
        Conductance (S); NaN for shorts, ``open_value`` for opens.
    flags : ndarray of uint8
        :data:`~psmat.circuit.OK`, :data:`~psmat.circuit.SHORT` (zero resistance:
        ``x = 0`` low side, ``x = 1`` high side), :data:`~psmat.circuit.OPEN` (the other
        end of the range).
    """
    _check_divider(float(r_o), 1.0, 1, sensor_side)
    x = np.asarray(x, dtype=np.float64)
    g, flags = _divider(r_o, sensor_side).conductance_from_voltage(x, return_flags=True)
    return np.where(flags == OPEN, float(open_value), g), flags


def divider_counts(g: NDArray[np.float64], r_o: float = DAQ_R_O, bits: int = DAQ_BITS,
                   sensor_side: Literal["low", "high"] = "low") -> NDArray[np.int64]:
    """ADC counts that the divider gives for sensor conductances ``g`` (S) (the forward of
    :func:`divider_conductance`, rounded and clipped to ``[0, 2**bits − 1]``); for tests and
    simulations of the DAQ."""
    _check_divider(float(r_o), 1.0, bits, sensor_side)
    g = np.asarray(g, dtype=np.float64)
    g = conductances(g, "g")
    return _divider(r_o, sensor_side, bits).counts(g).astype(np.int64)


# --------------------------------------------------------------------------- text sources
def _read_lines(source: PathOrLines, what: str) -> tuple[list[str], str, bool]:
    """Lines of a path, file object or iterable of strings.

    Returns the lines (without end-of-line), a name for messages, and whether the last line
    was known to be terminated by a newline.
    """
    if isinstance(source, (str, os.PathLike)):
        path = Path(source)
        if not path.is_file():
            raise FileNotFoundError(f"{what}: no such file: {path}")
        try:
            text = read_text(path)
        except NotTextError as exc:
            raise ValueError(f"{what} {path} {exc}") from None
        return text.splitlines(), str(path), text.endswith(("\n", "\r"))
    if isinstance(source, (bytes, bytearray)):
        raise TypeError(f"{what}: pass a path, a text file object or an iterable of str, not bytes")
    raw = list(source)
    for k, ln in enumerate(raw):
        if not isinstance(ln, str):
            raise TypeError(f"{what}: line {k + 1} is {type(ln).__name__}, expected str")
    terminated = bool(raw) and raw[-1].endswith(("\n", "\r"))
    lines = [ln.rstrip("\r\n") for ln in raw]
    name = getattr(source, "name", None) or "<lines>"
    return lines, str(name), terminated


def _parse_number(tok: str) -> float:
    v = float(tok)  # ValueError on garbage
    if not math.isfinite(v):
        raise ValueError(f"non-finite value {tok!r}")
    return v


def _schedule_units(header: list[str], name: str, no: int) -> tuple[float, float]:
    """(s, psi) per unit of a schedule's two columns, from their header names (load_schedule_csv)."""
    if len(header) != 2:
        raise ValueError(f"{name}: line {no}: expected a header time_s,pressure_psi, got {','.join(header)!r}")
    t_col, p_col = header_unit(header[0], ("time", "t")), header_unit(header[1], ("pressure", "p"))
    if t_col is None or p_col is None:
        raise ValueError(f"{name}: line {no}: header {','.join(header)!r} names no time and pressure column: "
                         "expected time_s,pressure_psi (or the time in ms, the pressure in kPa, bar, ...)")
    try:
        return s_per_unit(t_col[1] or "s"), float(psi_from_kpa(kpa_per_unit(p_col[1] or "psi")))
    except ValueError as exc:
        raise ValueError(f"{name}: line {no}: {exc}") from None


def load_schedule_csv(source: PathOrLines) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Read an applied-pressure schedule: CSV rows ``time_s,pressure_psi``.

    A header row (first data row not numeric), blank lines and ``#`` comments are allowed. The
    header names the units: ``time_s`` (or ``time``, ``t``; ``time_ms``, ``time [ms]``, ...) and
    ``pressure_psi`` (or ``pressure``, ``p``; ``pressure_kpa``, ``pressure [bar]``... any pressure
    unit :func:`psmat.units.kpa_per_unit` knows); the values are converted to s and psi. A header
    that names neither is an error: read as psi, a schedule in kPa would be 6.9 times too high. A row
    separated by a semicolon or a tab may write its decimals with a comma (``10,5;2,5``: the European
    CSV, or a spreadsheet saved as text). The file may be UTF-8, UTF-16 with its byte-order mark or
    Windows-1252 (as spreadsheets save it). Each row gives the pressure applied from its time on (a zero-order hold); the last row's
    time is the end of the schedule.

    Parameters
    ----------
    source : path or iterable of str
        The CSV file or its lines.

    Returns
    -------
    t_s, p_psi : ndarray, shape (N,)
        Breakpoint times (s, strictly increasing) and pressures (psi, >= 0).

    Raises
    ------
    ValueError
        For a malformed row (with its line number), decreasing times or negative pressure.
    """
    lines, name, _ = _read_lines(source, "schedule")
    ts: list[float] = []
    ps: list[float] = []
    header_seen = False
    s_per, psi_per = 1.0, 1.0  # the header's units (none: s and psi)
    for no, text in enumerate(lines, start=1):
        s = text.split("#", 1)[0].strip()
        if not s:
            continue
        if ";" in s or "\t" in s:  # the European CSV or a spreadsheet's text: a decimal comma read as a point
            row = [c.strip().replace(",", ".") for c in re.split(r"[;\t]", s)]
        else:
            row = [c.strip() for c in next(csv.reader(io.StringIO(s)))]
        try:
            if len(row) != 2:
                raise ValueError(f"expected 2 columns (time_s, pressure_psi), got {len(row)}")
            t, p = _parse_number(row[0]), _parse_number(row[1])
        except ValueError as exc:
            if not ts and not header_seen:
                header_seen = True
                s_per, psi_per = _schedule_units(row, name, no)
                continue
            raise ValueError(f"{name}: line {no}: {exc}: {text!r}") from None
        t, p = t * s_per, p * psi_per
        if p < 0:
            raise ValueError(f"{name}: line {no}: negative pressure {p} psi")
        if ts and t <= ts[-1]:
            raise ValueError(f"{name}: line {no}: time {t} s does not increase (previous {ts[-1]} s)")
        ts.append(t)
        ps.append(p)
    if len(ts) < 2:
        raise ValueError(f"{name}: a schedule needs at least 2 rows (time_s, pressure_psi), found {len(ts)}")
    return np.asarray(ts), np.asarray(ps)


def _parse_daq_lines(lines: Sequence[str], name: str, terminated: bool, n_fields: int, counts_from: int,
                     comment: str) -> tuple[list[int], NDArray[np.float64], list[SkippedLine]]:
    """Numeric rows of a DAQ log (each through :func:`psmat.protocol.parse_daq_fields`, the
    wire's parser); returns their line numbers, the (N, n_fields) values, skipped lines."""
    rows: list[NDArray[np.float64]] = []
    line_nos: list[int] = []
    skipped: list[SkippedLine] = []
    last = max((k for k, ln in enumerate(lines) if ln.split(comment, 1)[0].strip()), default=-1)
    for k, text in enumerate(lines):
        s = text.split(comment, 1)[0].strip()
        if not s:
            continue
        try:
            vals = parse_daq_fields(s, n_fields, counts_from=counts_from)
        except ValueError as exc:
            if k == last and not terminated:
                skipped.append(SkippedLine(k + 1, text, f"trailing partial line ({exc})"))
                continue
            raise ValueError(f"{name}: line {k + 1}: malformed reading ({exc}): {text!r}") from None
        rows.append(vals)
        line_nos.append(k + 1)
    if not rows:
        raise ValueError(f"{name}: no readings found")
    return line_nos, np.asarray(rows, dtype=np.float64), skipped


def load_daq_log(path_or_lines: PathOrLines, schedule: Protocol | PathOrLines | None = None, *,
                 n_sensors: int = DAQ_N_SENSORS, dt: float = DAQ_PERIOD_S, r_o: float = DAQ_R_O,
                 v_ref: float = DAQ_V_REF, bits: int = DAQ_BITS, sensor_side: Literal["low", "high"] = "low",
                 unit: Literal["counts", "volts"] = "counts", time_column: bool = False, offset_s: float = 0.0,
                 open_value: float = 0.0, name: str | None = None, comment: str = "#") -> PneumaticRun:
    """Load a material-DAQ log and align it with the applied-pressure schedule.

    The DAQ (thesis §2.4.1) sends one text line every 500 ms with the readings of its
    ``n_sensors`` sensors, separated by whitespace, commas or semicolons; each line goes
    through :func:`psmat.protocol.parse_daq_fields`, the parser the live reader uses, so counts
    are decimal digits (readings in volts and the time column any decimal number). Blank lines and
    ``comment`` lines are ignored; a last line cut short (no newline at the end of the file
    and not a full, numeric line — the acquisition stopped mid-line) is left out and listed in
    ``skipped``. Any other malformed line is an error.

    Readings are turned into conductance through the divider (module docstring): the ratio
    ``x = count/(2**bits − 1)`` (or ``V/V_ref`` for ``unit="volts"``), then
    :func:`divider_conductance`.

    Parameters
    ----------
    path_or_lines : str, path-like, text file object or iterable of str
        A ``str`` is a file name; pass a list of lines (or ``io.StringIO``) for text.
    schedule : Protocol, path, or iterable of str, optional
        The applied pressure: a :class:`Protocol` (its segments are mapped onto the log), or
        a CSV ``time_s,pressure_psi`` (:func:`load_schedule_csv`; plateaus are derived from
        it). Without it ``p`` is NaN and there are no segments.
    n_sensors : int
        Readings per line (thesis: 10).
    dt : float
        Line period (s), used for the time base unless ``time_column``. Thesis: 0.5 s.
    r_o : float
        Divider resistor (Ω).
    v_ref : float
        ADC reference (V); only used with ``unit="volts"``.
    bits : int
        ADC resolution (bits); readings in counts must lie in ``[0, 2**bits − 1]``.
    sensor_side : {"low", "high"}
        Where the sensor sits in the divider (module docstring).
    unit : {"counts", "volts"}
        What the readings are.
    time_column : bool
        The first field of each line is the DAQ's clock in ms (``millis()``); times are taken
        from it (relative to the first line) instead of ``k·dt``.
    offset_s : float
        Schedule time of the log's first line (s): sample ``k`` is at ``offset_s + t_k`` on
        the schedule's clock.
    open_value : float
        Conductance reported for open readings (S), see :func:`divider_conductance`.
    name : str, optional
        Run name; default the protocol's name, else ``"daq_log"``.
    comment : str
        Comment marker; the rest of a line after it is ignored.

    Returns
    -------
    PneumaticRun
        ``t`` (s, schedule clock), ``p`` (psi), ``g`` (S, shape (T, n_sensors)), ``flags``,
        ``segments``, ``skipped``; ``meta`` has the raw readings (``"readings"``), their line
        numbers, the divider parameters and how many samples fell outside the schedule
        (they are dropped).

    Raises
    ------
    ValueError
        Malformed or out-of-range lines (message names the line), a log with no readings,
        a non-increasing time column, a schedule that does not overlap the log.
    FileNotFoundError
        For a missing file.
    """
    n_sensors = positive_int("n_sensors", n_sensors)
    dt = positive("dt", dt)  # s
    if unit not in ("counts", "volts"):
        raise ValueError(f"unit must be 'counts' or 'volts', got {unit!r}")
    _check_divider(float(r_o), float(v_ref), bits, sensor_side)
    if not comment:
        raise ValueError("comment must be a non-empty string")

    lines, src_name, terminated = _read_lines(path_or_lines, "DAQ log")
    n_fields = n_sensors + (1 if time_column else 0)
    counts_from = (1 if time_column else 0) if unit == "counts" else n_fields
    line_nos, vals, skipped = _parse_daq_lines(lines, src_name, terminated, n_fields, counts_from, comment)
    readings = vals[:, 1:] if time_column else vals

    # range of the readings, reported with the line that breaks it
    full = float(2 ** int(bits) - 1) if unit == "counts" else float(v_ref)
    bad = (readings < 0) | (readings > full)
    if bad.any():
        r, c = np.argwhere(bad)[0]
        rng_txt = f"[0, {int(full)}] counts ({bits} bits)" if unit == "counts" else f"[0, {v_ref}] V"
        raise ValueError(f"{src_name}: line {line_nos[r]}: sensor {c + 1} reading {readings[r, c]:g} "
                         f"outside {rng_txt}")
    if time_column:
        tt = (vals[:, 0] - vals[0, 0]) * 1e-3
        dec = np.flatnonzero(np.diff(tt) <= 0)
        if dec.size:
            k = int(dec[0]) + 1
            raise ValueError(f"{src_name}: line {line_nos[k]}: time {vals[k, 0]:g} ms does not increase")
        t_log = tt
    else:
        t_log = np.arange(readings.shape[0], dtype=np.float64) * dt
    t_log = t_log + float(offset_s)

    g, flags = divider_conductance(readings / full, r_o=float(r_o), sensor_side=sensor_side,
                                   open_value=open_value)

    # ------------------------------------------------------------ alignment with the schedule
    segments: list[Segment] = []
    p = np.full(t_log.shape, np.nan)
    keep = np.ones(t_log.shape, dtype=bool)
    run_name = name
    if schedule is not None:
        eps = 1e-9 * max(1.0, float(np.max(np.abs(t_log))))
        if isinstance(schedule, Protocol):
            t_sched = schedule.t_s
            p_sched = schedule.p_psi
            t_end = float(schedule.t_s[-1] + schedule.dt_s)  # the last sample holds for dt
            keep = (t_log >= t_sched[0] - eps) & (t_log < t_end - eps)
            run_name = run_name or schedule.name
        else:
            t_sched, p_sched = load_schedule_csv(schedule)
            t_end = float(t_sched[-1])
            keep = (t_log >= t_sched[0] - eps) & (t_log <= t_end + eps)
        if not keep.any():
            raise ValueError(f"{src_name}: the log ({t_log[0]:g}…{t_log[-1]:g} s) does not overlap the schedule "
                             f"({t_sched[0]:g}…{t_end:g} s); check offset_s")
        idx = np.clip(np.searchsorted(t_sched, t_log + eps, side="right") - 1, 0, len(t_sched) - 1)
        p = np.where(keep, p_sched[idx], np.nan)
        t_log, p, g, flags, readings = t_log[keep], p[keep], g[keep], flags[keep], readings[keep]
        kept_lines = [ln for ln, k in zip(line_nos, keep) if k]
        if isinstance(schedule, Protocol):
            # map each plateau's time span onto the log's samples
            for s in schedule.segments:
                t0 = schedule.t_s[0] + s.start * schedule.dt_s
                t1 = schedule.t_s[0] + s.stop * schedule.dt_s
                a = int(np.searchsorted(t_log, t0 - eps, side="left"))
                b = int(np.searchsorted(t_log, t1 - eps, side="left"))
                if b > a:
                    segments.append(s._replace(start=a, stop=b))
        else:
            segments = segments_from_pressure(p)
        line_nos = kept_lines
    meta = dict(readings=readings, line_numbers=np.asarray(line_nos), source=src_name, r_o=float(r_o),
                v_ref=float(v_ref), bits=int(bits), sensor_side=sensor_side, unit=unit, offset_s=float(offset_s),
                n_outside_schedule=int((~keep).sum()))
    period = float(np.median(np.diff(t_log))) if (time_column and t_log.size > 1) else float(dt)
    return PneumaticRun(name=run_name or "daq_log", t=t_log, p=p, g=g, dt=period, segments=segments,
                        flags=flags, skipped=skipped, meta=meta)


def load_daq_session(path: str | os.PathLike[str], schedule: Protocol | PathOrLines | None = None,
                     **kwargs: Any) -> PneumaticRun:
    """A material-DAQ session recorded by ``psmat record --device daq`` (:mod:`psmat.io`) as a
    :class:`PneumaticRun`, aligned with the applied-pressure ``schedule``.

    The session's valid rows become the DAQ's text lines with the host's arrival time (ms)
    as the time column, then go through :func:`load_daq_log` (same divider conversion,
    alignment and checks; keyword arguments are passed on). Rows that failed on the wire are
    left out; their time slots stay empty rather than shifting later samples. Lines that reached
    the host in one serial chunk share its arrival time; they are spread back from it by the
    DAQ's line period (:func:`psmat.io.frame_times`), estimated from the lines that are at their
    arrival (:func:`psmat.io.run_end_period_s`; the thesis' 0.5 s when the session cannot tell).
    """
    from ..io import frame_times, load_session, run_end_period_s

    s = load_session(path)
    if s.kind != "daq":
        raise ValueError(f"{path}: a {s.kind!r} session; load_daq_session reads material-DAQ (daq) sessions")
    if not s.valid.any():
        raise ValueError(f"{path}: no valid DAQ rows")
    period_s = run_end_period_s(s.host_time_s)
    host_s = frame_times(s.host_time_s, s.device_time_us,
                         period_s=period_s if math.isfinite(period_s) else DAQ_PERIOD_S)
    t_ms = (host_s - host_s[s.valid][0]) * 1e3
    lines = [f"{t:.3f}," + ",".join(str(int(c)) for c in row)
             for t, row, ok in zip(t_ms, s.counts, s.valid) if ok]
    kwargs.setdefault("name", Path(path).stem)
    return load_daq_log(lines, schedule, n_sensors=s.counts.shape[1], time_column=True, **kwargs)

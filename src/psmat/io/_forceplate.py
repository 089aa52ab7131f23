"""Force-platform centre-of-pressure recordings (docs/spec.md §6, §7).

* :func:`load_forceplate_csv` — a generic CSV/TSV with columns time, x, y [, Fz]. Following
  docs/spec.md §7 (the mat's convention), ``x`` is medial–lateral and ``y`` anterior–posterior;
  pass ``swap_axes=True`` for files that use the opposite convention.
* :func:`load_bds` — a trial of the BDS public data set (Santos & Duarte 2016, PeerJ
  4:e2648, CC BY 4.0): tab-separated, header
  ``Time[s] Fx[N] Fy[N] Fz[N] Mx[Nm] My[Nm] Mz[Nm] COPx[cm] COPy[cm]``, 100 Hz. In that data
  set **COPx is anterior–posterior and COPy medial–lateral**.
* :func:`bds_dir`, :func:`bds_files`, :func:`bds_trial`, :func:`bds_trials_table` — the 24 BDS
  trials shipped with psmat (``psmat/data/bds``, xz-compressed text, with their attribution), or
  the folder named by the environment variable ``PSMAT_BDS_DIR`` (for example a larger copy of the
  data set). Nothing else is searched.

All loaders return a :class:`ForcePlateRecording` with CoP in cm, time in s, Fz in N.
"""

from __future__ import annotations

import csv
import io
import lzma
import os
import re
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .. import _checks
from .._text import NotTextError, read_text
from .._wallclock import DAY_S, parse_clock
from ..units import cm_per_unit, n_per_unit, s_per_unit

__all__ = [
    "ForcePlateRecording",
    "bds_dir",
    "bds_files",
    "bds_trial",
    "bds_trials_table",
    "load_bds",
    "load_forceplate_csv",
]



#: a platform sample whose |Fz| is below this share of the recording's median has no CoP (a
#: standing subject loads the plate with their weight; stepping off leaves a few N):
#: :meth:`ForcePlateRecording.samples` leaves it out
FZ_SHARE = 0.05


@dataclass(eq=False)
class ForcePlateRecording:
    """A force-platform recording.

    Attributes
    ----------
    t : ndarray (T,)
        Time (s).
    cop_ml_cm, cop_ap_cm : ndarray (T,)
        Centre of pressure, medial–lateral and anterior–posterior (cm).
    fz_n : ndarray (T,) or None
        Vertical force (N), if the file has it (its header's unit, kN, kgf or lbf, converted; a unit that
        is no force, such as %BW, kept as written and said in ``meta["fz_unit"]``: only its share of the
        median is used, :meth:`samples`).
    meta : dict
        Source file, trial information, other channels (``meta["channels"]``: name → array).
    """

    t: NDArray[np.float64]
    cop_ml_cm: NDArray[np.float64]
    cop_ap_cm: NDArray[np.float64]
    fz_n: NDArray[np.float64] | None = None
    meta: dict[str, Any] = field(default_factory=dict)

    @property
    def n(self) -> int:
        return int(self.t.shape[0])

    @property
    def rate_hz(self) -> float:
        """Sampling rate from the time column, ``(T - 1) / (t_last - t_first)``."""
        d = float(self.t[-1] - self.t[0]) if self.n >= 2 else 0.0
        return (self.n - 1) / d if d > 0 else float("nan")

    @property
    def cop_cm(self) -> NDArray[np.float64]:
        """``(T, 2)`` CoP as (ML, AP) in cm — the layout of :func:`psmat.balance.cop`."""
        return np.column_stack([self.cop_ml_cm, self.cop_ap_cm])

    def samples(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """``(t (s), CoP (cm) (N, 2))`` of the samples that have a time and a CoP: the ones to analyse.

        A sample without (NaN: a platform's software writes one where Fz fell below its threshold,
        the subject off the plate, or a dropout) is left out as a lost sample, and so is one whose
        vertical force, where the file has it, is below :data:`FZ_SHARE` of the recording's median
        (CoP = moment / Fz is undefined without a load: such software writes 0 or noise there). In a
        file without Fz, a sample at exactly (0, 0) that lies more than :data:`ZERO_MADS` median
        absolute deviations of the trace from its median, on an axis, is what such software writes
        while no one stands on a plate whose origin is off the feet (a corner): a lost sample too. The
        others keep their times.

        Raises
        ------
        ValueError
            Fewer than two such samples, or times that do not advance (median step <= 0); the
            message names the file.
        """
        name = Path(str(self.meta.get("source", "the recording"))).name
        t, c = np.asarray(self.t, np.float64), self.cop_cm
        ok = np.isfinite(t) & np.all(np.isfinite(c), axis=1)
        if self.fz_n is not None:
            fz = np.abs(np.asarray(self.fz_n, np.float64))  # a platform may count downward force negative
            if np.isfinite(fz).any():
                ok &= fz >= FZ_SHARE * float(np.nanmedian(fz))  # NaN compares False: lost too
        else:
            ok &= ~_off_the_plate(c, ok)
        if ok.sum() < 2:
            raise ValueError(f"force-platform file {name} has {int(ok.sum())} sample(s) with a time and a CoP; "
                             "it needs at least 2")
        t, c = t[ok], c[ok]
        step = float(np.median(np.diff(t)))
        if not step > 0:
            raise ValueError(f"force-platform file {name}: its times do not advance (median step {step:g} s "
                             "between samples)")
        back = np.flatnonzero(np.diff(t) <= 0)
        if back.size:
            k = int(back[0])
            raise ValueError(f"force-platform file {name}: its time goes from {t[k]:.6g} s back to {t[k + 1]:.6g} s "
                             f"({back.size} such step(s)): it holds more than one recording, or its clock started "
                             "again; keep one")
        return t, c

    def __repr__(self) -> str:
        src = self.meta.get("source", "")
        return f"ForcePlateRecording(n={self.n}, rate_hz={self.rate_hz:.3g}, fz={'yes' if self.fz_n is not None else 'no'}, source={src!r})"


#: median absolute deviations of a trace beyond which a sample at exactly (0, 0) is not the body's
#: CoP but a platform's fill while no one stands on it (ForcePlateRecording.samples)
ZERO_MADS = 10.0


def _off_the_plate(c: NDArray[np.float64], ok: NDArray[np.bool_]) -> NDArray[np.bool_]:
    """The samples at exactly (0, 0) far outside the rest of the trace (:data:`ZERO_MADS`)."""
    zero = ok & np.all(c == 0.0, axis=1)
    rest = c[ok & ~zero]
    if not zero.any() or len(rest) < 2:
        return np.zeros(len(c), bool)
    med = np.median(rest, axis=0)
    mad = np.median(np.abs(rest - med), axis=0)
    far = np.any(np.abs(med) > ZERO_MADS * mad, axis=0)  # the origin, from the trace, on either axis
    return zero if bool(far) else np.zeros(len(c), bool)


# ---------------------------------------------------------------------- generic CSV
def _norm(name: str) -> str:
    """``"COPx[cm]"`` → ``"copx"``; ``"Time (s)"`` → ``"time"``; ``"cop_x"`` → ``"copx"``."""
    n = re.sub(r"[\[(].*?[\])]", "", name.strip().lower())
    return re.sub(r"[^a-z0-9]", "", n)


def _unit_of(name: str) -> str | None:
    m = re.search(r"[\[(]\s*([a-zA-Z]+)\s*[\])]", name)
    return m.group(1).lower() if m else None


_TIME = ("time", "t", "times", "timestamp", "timesec", "timems", "timeus")


def _time_unit_of(name: str) -> str:
    """The time column's unit: ``"Time [ms]"`` → ``"ms"``, ``"time_ms"`` → ``"ms"``, ``"time"`` → ``"s"``."""
    m = re.search(r"[\[(]\s*([^\])\s]+)\s*[\])]", name)
    if m:
        return m.group(1).lower()
    n = _norm(name)
    return "ms" if n == "timems" else "us" if n == "timeus" else "s"
_X = ("x", "copx", "copml", "ml", "xcop", "coml")
_Y = ("y", "copy", "copap", "ap", "ycop", "coap")
_FZ = ("fz", "forcez", "force", "vgrf", "fzn")


def _numeric(row: list[str]) -> bool:
    """Whether every field of ``row`` is a number (an empty field: a missing one)."""
    try:
        [float(c) for c in row if c]
    except ValueError:
        return False
    return any(row)


#: a field of a units row under the header: ``s``, ``mm``, ``[N]``, ``(N.m)``, ``µs``, ``%``
_UNIT_FIELD = re.compile(r"[\[(]?\s*[A-Za-zµ°%/.*·^²\-]{1,8}\s*[\])]?")


def _without_trailing_empties(row: list[str]) -> list[str]:
    k = len(row)
    while k and not row[k - 1]:
        k -= 1
    return row[:k]


def _units_row(row: list[str]) -> bool:
    return any(row) and all(not c or _UNIT_FIELD.fullmatch(c) or _CLOCK_UNIT.fullmatch(c) for c in row)


#: the units row's field over a column of clock times: ``hh:mm:ss``, ``hh:mm:ss.sss``
_CLOCK_UNIT = re.compile(r"(?i)[\[(]?\s*hh?:mm:ss(?:[.,]s+)?\s*[\])]?")


def _clock_columns(rows: list[list[str]]) -> list[set[int]]:
    """Turns the clock times of ``rows`` into seconds, in place (as text; :func:`psmat._wallclock.parse_clock`: of
    the day, or since 1970 for a date and time; any clock serves, the platform's lag to the mat is searched);
    per row, the columns that held one."""
    clock: list[set[int]] = []
    for r in rows:
        clock.append(set())
        for k, c in enumerate(r):
            if ":" in c and (v := parse_clock(c)) is not None:
                r[k] = repr(v.seconds)
                clock[-1].add(k)
    return clock


def _past_midnight(t: NDArray[np.float64]) -> NDArray[np.float64]:
    """Times of the day that pass midnight (23:59:59.9, then 00:00:00.0) carried on past 24 h: a step
    back of more than half a day is a new day, not a clock that went back."""
    ok = np.flatnonzero(np.isfinite(t))
    days = np.zeros_like(t)
    days[ok[1:]] = np.cumsum(np.diff(t[ok]) < -DAY_S / 2)
    return t + days * DAY_S


Table = tuple[list[str] | None, NDArray[np.float64], list[str], set[int]]


def _read_table(path: Path, delimiter: str | None) -> Table:
    """(header, data, preamble, clock) of a platform's table: the header (with a units row's units in
    brackets), the numbers (an empty field: NaN, a lost sample), the lines above the header (the
    software's own notes) and the columns of clock times (``12:30:01.250``, read as seconds of the day,
    carried past midnight; a date and time as POSIX seconds).

    The header is the first row of names followed by numbers (or by a units row, ``s;mm;mm;N``, and
    numbers); the rows above it are a preamble (the software's name, the subject, the rate...), kept
    unread, unless a row of numbers is among them: then the first row is the header, as in a file
    without a preamble, and the malformed rows are errors.

    A plain table (below its header: numbers only, every field filled, no clock times, quotes or
    trailing separators) is read by :func:`_plain_table`, its numbers by NumPy at once; any other by
    :func:`_table`, field by field. Both give the same result where the first applies.
    """
    try:
        text = read_text(path)
    except NotTextError as exc:
        raise ValueError(f"{path}: {exc}") from None
    lines = [ln for ln in text.splitlines() if ln.strip() and not ln.lstrip().startswith("#")]
    if not lines:
        raise ValueError(f"{path}: empty file")
    if delimiter is None:  # from the last line, a data line: a header may hold any character
        probe = lines[-1]
        delimiter = "\t" if "\t" in probe else ";" if ";" in probe else "," if "," in probe else None
    plain = _plain_table(lines, delimiter)
    return plain if plain is not None else _table(path, lines, delimiter)


def _rows(lines: list[str], delimiter: str | None) -> tuple[list[list[str]], list[set[int]]]:
    """The fields of ``lines`` (stripped; a decimal comma read as a point where the separator is not a
    comma) and, per row, the columns whose clock times were turned into seconds (:func:`_clock_columns`)."""
    if delimiter:
        rows = [[c.strip() for c in r] for r in csv.reader(io.StringIO("\n".join(lines)), delimiter=delimiter)]
    else:
        rows = [ln.split() for ln in lines]
    if delimiter != ",":  # tabs, semicolons or spaces: a decimal comma read as a point (the European CSV)
        rows = [[c.replace(",", ".") for c in r] for r in rows]
    return rows, _clock_columns(rows)


def _header(rows: list[list[str]], width: int, complete: bool = True) -> tuple[list[str] | None, int, int] | None:
    """(header, the first data row, the header's row) of ``rows`` whose last row has ``width`` fields (the
    rule of :func:`_read_table`). Not ``complete``: ``rows`` are the table's first rows only, and None
    when the rule would look past them."""
    if _numeric(rows[0]):
        return None, 0, 0
    for i in range(len(rows) - 1):
        if not complete and i + 2 >= len(rows):
            return None
        if _numeric(rows[i]) and len(rows[i]) == width:
            break  # numbers above any later header: no preamble
        if len(rows[i]) != width or _numeric(rows[i]):
            continue
        if _numeric(rows[i + 1]):
            return rows[i], i + 1, i
        if i + 2 < len(rows) and len(rows[i + 1]) <= width and _units_row(rows[i + 1]) and _numeric(rows[i + 2]):
            units = rows[i + 1] + [""] * (width - len(rows[i + 1]))
            return [h if not u or _unit_of(h) else f"{h} [{u.strip('[]() ')}]" for h, u in zip(rows[i], units)], i + 2, i
    return rows[0], 1, 0


def _table(path: Path, lines: list[str], delimiter: str | None) -> Table:
    """:func:`_read_table` field by field: any layout, and the errors that name the row and field."""
    rows, clocks = _rows(lines, delimiter)
    if delimiter:  # a delimiter that ends every line adds no field; an empty last field of one row is a missing value
        trail = [len(r) - len(_without_trailing_empties(r)) for r in rows]
        numbers = [k for r, k in zip(rows, trail) if _numeric(r)]
        common = min(numbers) if numbers else min(trail)
        rows = [r[:len(r) - min(k, common)] for r, k in zip(rows, trail)]
    header, start, at = _header(rows, len(rows[-1]))  # type: ignore[misc]  # complete rows: never None
    preamble = lines[:at]
    rows, clock = rows[start:], set().union(*clocks[start:])  # (clock times in the data, not the preamble)
    if not rows:
        raise ValueError(f"{path}: no data rows")
    width = len(rows[0])
    for k, r in enumerate(rows):
        if len(r) != width:
            raise ValueError(f"{path}: row {k + 1 + start} has {len(r)} fields, expected {width}")
    data = np.empty((len(rows), width))
    for k, r in enumerate(rows):
        try:
            data[k] = [float(c) if c else np.nan for c in r]
        except ValueError:
            bad = next(c for c in r if c and not _numeric([c]))
            raise ValueError(f"{path}: row {k + 1 + start}: {bad!r} is not a number") from None
    for k in clock:
        if np.nanmax(data[:, k]) < DAY_S:  # times of the day (not dates and times)
            data[:, k] = _past_midnight(data[:, k])
    return header, data, preamble, clock


#: the lines :func:`_plain_table` reads field by field to find the header (a preamble longer than this: :func:`_table`)
_HEAD_LINES = 64


def _plain_table(lines: list[str], delimiter: str | None) -> Table | None:
    """:func:`_read_table` for a plain table, None for any other (then :func:`_table` reads it).

    Plain: the header found by :func:`_header` within the first :data:`_HEAD_LINES` lines (read field by
    field, clock times and decimal commas as :func:`_table` reads them), and below it rows of numbers
    only, as many in each row as in the first, with no quotes, clock times (``:``) or empty fields.
    NumPy reads those rows at once, each number to the value :func:`float` gives; a number it refuses
    (some that :func:`float` takes, ``1_000``) makes it None, and none it takes was refused by
    :func:`float` in the cases tried. With no empty field in the data rows, :func:`_table` drops no
    trailing field anywhere, so the header and widths agree.
    """
    if any(ln.count('"') % 2 for ln in lines[:_HEAD_LINES]):  # a quoted field that may go on to the next line
        return None
    head, _ = _rows(lines[:_HEAD_LINES], delimiter)
    complete = len(lines) <= _HEAD_LINES
    width = len(head[-1]) if complete else len(_rows(lines[-1:], delimiter)[0][0])
    found = _header(head, width, complete)
    if found is None:
        return None
    header, start, at = found
    if start >= min(len(lines), _HEAD_LINES):  # no data row among the rows read
        return None
    body = "\n".join(lines[start:])
    if '"' in body or ":" in body:
        return None
    if delimiter != ",":  # a decimal comma, as _rows reads it
        body = body.replace(",", ".")
    try:  # (an empty or whitespace field, a row of another width, a non-number: ValueError)
        data = np.loadtxt(io.StringIO(body), delimiter=delimiter, ndmin=2, dtype=np.float64, comments=None)
    except ValueError:
        return None
    if data.shape != (len(lines) - start, len(head[start])):
        return None
    return header, data, lines[:at], set()


def _find(header: list[str], names: Sequence[str], given: str | int | None, what: str, path: Path, required: bool = True,
          arg: str | None = None) -> int | None:
    """Index of the column ``given`` (a name or an index), else of the first of ``names`` found.

    ``what`` names the column in messages, ``arg`` the keyword that selects it (default ``what``).
    """
    if isinstance(given, int):
        return given
    norm = [_norm(h) for h in header]
    if given is not None:
        g = _norm(given)
        if g in norm:
            return norm.index(g)
        raise ValueError(f"{path}: column {given!r} not found (columns: {header})")
    for n in names:
        if n in norm:
            return norm.index(n)
    if required:
        raise ValueError(f"{path}: no {what} column recognised (columns: {header}); "
                         f"name it with the {arg or what}= argument")
    return None


_COUNTER = ("sample", "samples", "sampleno", "samplenr", "samplenumber", "frame", "frames", "frameno",
            "framenr", "framenumber", "index")
#: a line above the header that states the sampling rate: a word for sampling or rate, then the number
_RATE_LINE = re.compile(r"(?i)\b(sampl\w*|\w*\s?rate)\b[^0-9]{0,30}?([0-9]+(?:[.,][0-9]+)?)[\s;,:]*(k?hz)?\b")


def _unrounded(t: NDArray[np.float64], time_from: str, path: Path) -> tuple[NDArray[np.float64], str]:
    """Times written with fewer decimals than the samples need (a spreadsheet saves the digits it
    shows: a 1 kHz platform's times at 0.01 s repeat ten times each), put back on their rate.

    Times that repeat but never decrease, and lie within 3/4 of their resolution q (the smallest
    step; rounding alone leaves q/2, the fitted line's own error a little more) of one straight line
    in the sample's number, were a constant rate rounded: the line's times replace them, each within
    about q of the true one (as the written ones were within q/2, but not in order). Lost samples
    shift the later times by their periods: once that passes the tolerance, or for times off any
    line, times that repeat are an error saying why. Times that do not repeat are returned as they are.
    """
    ok = np.isfinite(t)
    d = np.diff(t[ok])
    if not (d.size and (d == 0).any() and (d >= 0).all() and (d > 0).any()):
        return t, time_from  # (times that never advance: ForcePlateRecording.samples says so)
    k = np.flatnonzero(ok).astype(np.float64)
    slope, t0 = np.polyfit(k, t[ok], 1)
    q = float(d[d > 0].min())
    line = t0 + slope * np.arange(t.size)
    if slope > 0 and np.abs(line[ok] - t[ok]).max() <= 0.75 * q:
        return line, f"{time_from}, written to {q:g} s and put back on its {1 / slope:.6g} Hz"
    raise ValueError(f"{path}: its times repeat (written to {q:g} s for samples closer than that): the time column "
                     "was saved with too few decimals (a spreadsheet saves the digits it shows), and the samples "
                     "are not evenly spaced to rebuild it; export it again with every decimal")


_MX, _MY = ("mx", "momentx", "mxnm"), ("my", "momenty", "mynm")
_FX, _FY = ("fx", "forcex", "fxn"), ("fy", "forcey", "fyn")


def _newtons(header: list[str] | None, k: int, path: Path, strict: bool = True) -> float | None:
    """N per unit of the force column ``k``: the unit its header names in brackets (``Fz [kgf]``), else N.
    A unit that is no force (``%BW``, ``N/kg``): an error, or None when not ``strict``."""
    m = re.search(r"[\[(]\s*([^\])]+?)\s*[\])]", header[k]) if header else None
    if m is None:
        return 1.0
    try:
        return n_per_unit(m.group(1).replace(" ", ""))
    except ValueError as exc:
        if not strict:
            return None
        raise ValueError(f"{path}: the force column {header[k]!r}: {exc}") from None


def _cop_from_moments(header: list[str], data: NDArray[np.float64], ifz: int | None, surface_z_mm: float,
                      path: Path) -> tuple[NDArray[np.float64], NDArray[np.float64], list[int]] | None:
    """(x, y (cm), the columns used) of a file of forces and moments without a CoP column; None when the
    file has a CoP column or no Fz, Mx and My.

    A force F applied at r = (x, y, z) of the plate's axes has the moment M = r × F about their
    origin: Mx = y Fz − z Fy, My = z Fx − x Fz, so

        x = (z Fx − My) / Fz,   y = (Mx + z Fy) / Fz,

    with z the height of the surface, ``surface_z_mm`` (0: moments about the surface, x = -My / Fz,
    y = Mx / Fz, as the BDS data set's own COP columns are, to the last digit). The moments in N·m
    unless their header names N·mm or N·cm; the forces in N unless theirs names kN, kgf or lbf."""
    norm = [_norm(h) for h in header]
    if any(n in norm for n in (*_X, *_Y)) or ifz is None:
        return None
    imx, imy, ifx, ify = (next((norm.index(n) for n in names if n in norm), None) for names in (_MX, _MY, _FX, _FY))
    if imx is None or imy is None:
        return None
    m = re.search(r"[\[(]\s*([^\])]+?)\s*[\])]", header[imx])
    unit = m.group(1).lower().replace(" ", "") if m else "nm"
    lm = re.fullmatch(r"n[.·*]?(m|mm|cm)", unit)
    if lm is None:
        raise ValueError(f"{path}: the moment column {header[imx]!r}: its unit {unit!r} is not N·m, N·cm or N·mm")
    s = cm_per_unit(lm.group(1))
    mx, my, used = data[:, imx] * s, data[:, imy] * s, [imx, imy]  # N·cm
    if surface_z_mm != 0.0:
        if ifx is None or ify is None:
            raise ValueError(f"{path}: surface_z_mm needs the horizontal forces Fx and Fy (columns: {header})")
        z = surface_z_mm * cm_per_unit("mm")  # cm
        fx, fy = data[:, ifx] * _newtons(header, ifx, path), data[:, ify] * _newtons(header, ify, path)
        mx, my, used = mx + z * fy, my - z * fx, used + [ifx, ify]
    with np.errstate(divide="ignore", invalid="ignore"):  # Fz = 0: off the plate, a lost sample (samples())
        fz = data[:, ifz] * _newtons(header, ifz, path)
        return -my / fz, mx / fz, used


def _timed_by_rate(header: list[str], data: NDArray[np.float64], preamble: list[str], rate_hz: float | None,
                   path: Path) -> tuple[NDArray[np.float64], str, str, int | None]:
    """(t (s), "s", how it was timed, the counter column or None) of a table without a time column."""
    said = ""
    if rate_hz is None:
        found = {}
        for line in preamble:
            m = _RATE_LINE.search(line)
            # a sampling or frame rate, or a number in Hz: not any "rate" ("rate of force development 120 N/s")
            if m and (m.group(3) or re.search(r"(?i)sampl|frame|captur|acqui", m.group(1))):
                found.setdefault(float(m.group(2).replace(",", ".")) * (1e3 if (m.group(3) or "").lower() == "khz"
                                                                        else 1.0), line.strip())
        if len(found) > 1:
            raise ValueError(f"{path}: no time column, and the lines above the header name {len(found)} rates "
                             f"({'; '.join(found.values())}): give rate_hz=")
        if not found:
            raise ValueError(f"{path}: no time column recognised (columns: {header}); name it with the t_column= "
                             "argument, or give the platform's rate_hz=")
        (rate_hz, line), = found.items()
        said = f" (the line {line!r})"
    if not (np.isfinite(rate_hz) and rate_hz > 0):
        raise ValueError(f"{path}: the rate must be a positive number of Hz, got {rate_hz!r}{said}")
    norm = [_norm(h) for h in header]
    ik = next((norm.index(n) for n in _COUNTER if n in norm), None)
    k = np.arange(data.shape[0], dtype=np.float64) if ik is None else data[:, ik]
    return k / rate_hz, "s", f"{'the row' if ik is None else repr(header[ik])} / {rate_hz:g} Hz{said}", ik


def load_forceplate_csv(
    path: str | os.PathLike[str],
    *,
    t_column: str | int | None = None,
    x: str | int | None = None,
    y: str | int | None = None,
    fz: str | int | None = None,
    unit: str | None = None,
    swap_axes: bool = False,
    delimiter: str | None = None,
    t_unit: str | None = None,
    rate_hz: float | None = None,
    surface_z_mm: float = 0.0,
) -> ForcePlateRecording:
    """Load a force-platform CoP file: columns time, x, y [, Fz (N)].

    The delimiter (comma, tab, semicolon or whitespace) is detected from the last line; with
    semicolons a number may have a decimal comma (the European CSV: ``0,01;1,25;-0,5``).
    With a header, columns are found by name (``time``/``t``, ``x``/``cop_x``/``COPx``,
    ``y``/…, ``Fz``; case, spaces, underscores and bracketed units ignored) or given
    explicitly (``t_column``, ``x``, ``y``, ``fz``: a column name, or its 0-based index);
    without a header they are taken in the order time, x, y[, Fz]. ``unit``: CoP length
    unit (``"cm"``, ``"mm"``, ``"m"``, ``"in"``: :func:`psmat.units.cm_per_unit`); default: the unit
    in the x column header (e.g. ``x[mm]``), else cm. ``t_unit``: ``"s"``, ``"ms"`` or ``"us"``; default: the unit in the
    time column's header (``Time [ms]``, ``time_ms``), else s; ``t`` is in s either way. ``x`` is
    medial–lateral and ``y`` anterior–posterior unless ``swap_axes``. A file of forces and moments
    without a CoP column (``Fz``, ``Mx``, ``My``: N and N·m, N·cm or N·mm) gets the CoP of moments about
    the plate's surface, ``x = -My / Fz``, ``y = Mx / Fz`` (``meta["cop_from"]`` says so); for moments
    about an origin off the surface, ``surface_z_mm`` is the surface's height in the axes of the
    moments (mm: Kistler's a_z0, negative for its z-down axes), and ``x = (z Fx - My) / Fz``,
    ``y = (Mx + z Fy) / Fz`` (M = r × F at r = (x, y, z)).

    A time column of clock times (``23:59:59,990``, ``12:30:01.25``) is read as seconds of the day,
    carried on past midnight; an ISO date and time (``2024-03-01T12:30:01.250Z``) as POSIX seconds,
    UTC unless it names its offset.

    A file with a header but no time column (platform software that writes a sample number, or
    nothing, and states its rate above the header) is timed by its rate: ``rate_hz`` (Hz), else the
    one line above the header that names a sampling or frame rate (``Sampling rate: 1000 Hz``,
    ``Rate;1 kHz``); sample k is at ``k / rate`` s, k from a ``sample``/``frame`` column when there
    is one (a skipped number keeps its gap), else the row. ``meta["time_from"]`` says which.
    """
    path = Path(path)
    surface_z = _checks.finite("surface_z_mm", surface_z_mm)
    if not path.is_file():
        raise FileNotFoundError(f"force-platform file not found: {path}")
    header, data, preamble, clock = _read_table(path, delimiter)
    cop = None
    if header is None:
        if data.shape[1] < 3:
            raise ValueError(f"{path}: need at least 3 columns (time, x, y), got {data.shape[1]}")
        it, ix, iy = (t_column if isinstance(t_column, int) else 0, x if isinstance(x, int) else 1, y if isinstance(y, int) else 2)
        ifz = fz if isinstance(fz, int) else (3 if data.shape[1] >= 4 and fz is None else None)
        names = [f"col{k}" for k in range(data.shape[1])]
    else:
        if len(header) != data.shape[1]:
            raise ValueError(f"{path}: header has {len(header)} names but rows have {data.shape[1]} fields")
        it = _find(header, _TIME, t_column, "time", path, arg="t_column", required=False)
        if it is None:  # timed by the rate
            by_rate = _timed_by_rate(header, data, preamble, rate_hz, path)
        ifz = _find(header, _FZ, fz, "Fz", path, required=False)
        cop = None if (x, y) != (None, None) else _cop_from_moments(header, data, ifz, surface_z, path)
        if cop is None:
            ix = _find(header, _X, x, "x", path)
            iy = _find(header, _Y, y, "y", path)
        names = header
    if surface_z != 0.0 and cop is None:
        raise ValueError(f"{path}: surface_z_mm is for a file of forces and moments without a CoP column "
                         f"(Fx, Fy, Fz, Mx, My; columns: {names})")
    if cop is not None:  # (a file of forces and moments: the CoP from them, cm)
        cx, cy, from_moments = cop
        ix, iy = from_moments[:2]
        u = "cm"
    else:
        u = unit or (_unit_of(names[ix]) if header else None) or "cm"
        try:
            s = cm_per_unit(u)
        except ValueError as exc:
            raise ValueError(f"{path}: the CoP columns: {exc}; or give unit=") from None
        cx, cy = data[:, ix] * s, data[:, iy] * s
    if it is None:  # (a header without a time column)
        t, tu, time_from, ik = by_rate
    else:
        if it in clock:  # clock times, read as s
            t, tu, time_from = data[:, it], "s", f"the clock times of the column {names[it]!r}"
        else:
            tu = t_unit or (_time_unit_of(names[it]) if header else "s")
            try:
                t = data[:, it] * s_per_unit(tu)
            except ValueError as exc:
                raise ValueError(f"{path}: the time column {names[it]!r}: {exc}; or give t_unit=") from None
            time_from = f"the column {names[it]!r}"
        ik = it
        t, time_from = _unrounded(t, time_from, path)
    ml, ap = (cy, cx) if swap_axes else (cx, cy)
    # (Fz in N; in a unit that is no force, %BW, as written: only its share of the median is used)
    fz_scale = None if ifz is None else _newtons(header, ifz, path, strict=False)
    used = {ix, iy, *(cop[2] if cop is not None else ())} | {k for k in (ik, ifz) if k is not None}
    return ForcePlateRecording(
        t=t,
        cop_ml_cm=ml.copy(),
        cop_ap_cm=ap.copy(),
        fz_n=None if ifz is None else data[:, ifz] * (fz_scale or 1.0),
        meta={
            "source": str(path),
            "format": "csv",
            "columns": list(names),
            "unit": u,
            "time_unit": tu,
            "time_from": time_from,
            "swap_axes": swap_axes,
            "channels": {names[k]: data[:, k].copy() for k in range(data.shape[1]) if k not in used},
            "preamble": preamble,
            "fz_unit": "N" if ifz is None or fz_scale is not None else f"as written in {names[ifz]!r}, no force unit",
            "cop_from": ("the columns" if cop is None else "-My/Fz, Mx/Fz (moments about the plate's surface)"
                         if surface_z == 0.0 else f"(z Fx - My)/Fz, (Mx + z Fy)/Fz, z = {surface_z:g} mm"),
        },
    )


# ---------------------------------------------------------------------- BDS data set
_BDS_HEADER = ["Time[s]", "Fx[N]", "Fy[N]", "Fz[N]", "Mx[Nm]", "My[Nm]", "Mz[Nm]", "COPx[cm]", "COPy[cm]"]
_BDS_CITATION = (
    "Santos DA, Duarte M. (2016) A public data set of human balance evaluations. PeerJ 4:e2648, "
    "https://doi.org/10.7717/peerj.2648 (CC BY 4.0)"
)


#: The trials shipped with the package (CC BY 4.0; see README.md there).
_PACKAGE_BDS = Path(__file__).resolve().parent.parent / "data" / "bds"
_BDS_GLOBS = ("BDS[0-9][0-9][0-9][0-9][0-9].txt", "BDS[0-9][0-9][0-9][0-9][0-9].txt.xz")


def bds_dir() -> Path:
    """The folder of the BDS trials: ``$PSMAT_BDS_DIR`` when set, else the copy shipped with psmat.

    Raises
    ------
    FileNotFoundError
        ``PSMAT_BDS_DIR`` names no folder, or the package's copy is missing (a broken install).
    """
    env = os.environ.get("PSMAT_BDS_DIR")
    if env:
        p = Path(env).expanduser()
        if not p.is_dir():
            raise FileNotFoundError(f"PSMAT_BDS_DIR={env!r} is not a directory")
        return p
    if not _PACKAGE_BDS.is_dir():
        raise FileNotFoundError(f"the BDS trials shipped with psmat are missing ({_PACKAGE_BDS}): reinstall psmat, "
                                "or set PSMAT_BDS_DIR to a folder of BDS?????.txt files")
    return _PACKAGE_BDS


def _trial_name(path: Path) -> str:
    """``BDS00001`` for ``BDS00001.txt`` and ``BDS00001.txt.xz``."""
    return Path(path.name.removesuffix(".xz")).stem


def bds_files() -> list[Path]:
    """The BDS trial files available (``BDS?????.txt`` or ``.txt.xz``; one per trial, sorted by trial)."""
    d = bds_dir()
    found: dict[str, Path] = {}
    for pattern in reversed(_BDS_GLOBS):  # a plain .txt wins over its .xz
        for f in d.glob(pattern):
            found[_trial_name(f)] = f
    return [found[k] for k in sorted(found)]


def bds_trials_table() -> list[dict[str, Any]]:
    """Rows of ``trials.tsv`` (subject, vision, surface, age, …, published sway measures) as dicts.

    Numeric fields become floats (Subject an int). Empty list if the file is absent.
    """
    p = bds_dir() / "trials.tsv"
    if not p.is_file():
        return []
    out = []
    with open(p, newline="", encoding="utf-8") as fh:
        for row in csv.DictReader(fh, delimiter="\t"):
            d: dict[str, Any] = {}
            for k, v in row.items():
                if k is None:
                    continue
                v = (v or "").strip()
                if k == "Subject":
                    d[k] = int(v) if v else None
                else:
                    try:
                        d[k] = float(v)
                    except ValueError:
                        d[k] = v
            out.append(d)
    return out


def load_bds(path: str | os.PathLike[str], *, with_trial_info: bool = True) -> ForcePlateRecording:
    """Load one BDS trial file (``BDS000NN.txt``). COPx is AP and COPy ML in this data set.

    ``meta``: ``source``, ``trial`` (e.g. ``"BDS00001"``), ``citation``, ``channels``
    (Fx, Fy, Mx, My, Mz arrays) and, when ``trials.tsv`` is beside the file and
    ``with_trial_info``, ``trial_info`` (that trial's row).
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"BDS file not found: {path}")
    opener = lzma.open if path.suffix == ".xz" else open
    try:
        with opener(path, "rt", newline="", encoding="utf-8") as fh:
            rows = [r for r in csv.reader(fh, delimiter="\t") if r and any(c.strip() for c in r)]
    except lzma.LZMAError as e:
        raise ValueError(f"{path}: not a valid xz file ({e})") from None
    if not rows:
        raise ValueError(f"{path}: empty file")
    header = [c.strip() for c in rows[0]]
    if [_norm(h) for h in header] != [_norm(h) for h in _BDS_HEADER]:
        raise ValueError(f"{path}: not a BDS file (header {header}, expected {_BDS_HEADER})")
    try:
        data = np.array([[float(c) for c in r] for r in rows[1:]], dtype=np.float64)
    except ValueError as e:
        raise ValueError(f"{path}: non-numeric value ({e})") from None
    if data.ndim != 2 or data.shape[1] != len(_BDS_HEADER):
        raise ValueError(f"{path}: rows must have {len(_BDS_HEADER)} fields")
    col = {h: data[:, k] for k, h in enumerate(_BDS_HEADER)}
    meta: dict[str, Any] = {
        "source": str(path),
        "format": "bds",
        "trial": _trial_name(path),
        "citation": _BDS_CITATION,
        "axes": "COPx[cm] = anterior-posterior, COPy[cm] = medial-lateral",
        "channels": {h: col[h].copy() for h in ("Fx[N]", "Fy[N]", "Mx[Nm]", "My[Nm]", "Mz[Nm]")},
    }
    if with_trial_info:
        tsv = path.parent / "trials.tsv"
        if tsv.is_file():
            with open(tsv, newline="", encoding="utf-8") as fh:
                for row in csv.DictReader(fh, delimiter="\t"):
                    if row.get("Trial", "").strip() == _trial_name(path):
                        meta["trial_info"] = {k: v.strip() for k, v in row.items() if k is not None}
                        break
    return ForcePlateRecording(
        t=col["Time[s]"].copy(),
        cop_ml_cm=col["COPy[cm]"].copy(),
        cop_ap_cm=col["COPx[cm]"].copy(),
        fz_n=col["Fz[N]"].copy(),
        meta=meta,
    )


def bds_trial(n: int | str) -> ForcePlateRecording:
    """Load BDS trial ``n`` (e.g. ``1`` → ``BDS00001``, or the name ``"BDS00001"``).

    Raises
    ------
    FileNotFoundError
        One line naming the trial, the folder searched and the trials it has.
    """
    name = n if isinstance(n, str) else f"BDS{int(n):05d}"
    name = _trial_name(Path(name))
    files = {_trial_name(f): f for f in bds_files()}
    if name not in files:
        avail = sorted(files)
        raise FileNotFoundError(f"BDS trial {n!r} ({name}) not found in {bds_dir()} (available: "
                                f"{', '.join(avail[:5])}{' …' if len(avail) > 5 else ''}{'none' if not avail else ''})")
    return load_bds(files[name])

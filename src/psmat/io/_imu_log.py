"""The thesis' spine-IMU text logs (docs/spec.md §6, §8; thesis §4.2).

The IMU box reads five BNO055 sensors (sensor 1 the cervical one .. 5 the sacral one) and
sends their Euler angles (heading, roll, pitch, degrees) at 10 Hz; the PC stores "one line per
sample, numbers with five decimals separated by spaces" (docs/spec.md §6). Two layouts are accepted,
told apart by the number of fields on the file's lines:

* **15 numbers**: h1 r1 p1  h2 r2 p2 .. h5 r5 p5 — the thesis' log. It has no time column:
  sample ``k`` is at ``k / rate_hz`` s on the log's own clock (10 Hz by default).
* **16 numbers**: a time in s, then the 15 above (a logger that stamps its lines).

Blank lines and lines starting with ``#`` are not samples. Every other line is one sample. The
layout is the most common field count among the lines that are all finite numbers (so a first
line cut by a capture started mid-line does not decide it); a file whose layout is neither is
refused with a :class:`~psmat.io.SessionFormatError` naming the file and the
first such line. A malformed line (another field count, a token that is not a finite number, a
damaged byte, a time out of order: outside the longest subsequence of lines whose times
increase) costs that line only: it is kept as an invalid sample (angles NaN) so the time base
holds, and ``meta["invalid_lines"]`` notes it.

:func:`write_imu_log` writes the same format, so a simulated study can produce logs "recorded
apart" from the mat (thesis §4.3, Fig. 4.11).
"""

from __future__ import annotations

import os
from bisect import bisect_left
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .. import _checks
from .session import SessionFormatError

__all__ = ["ANGLE_NAMES", "IMU_SENSORS", "ImuLog", "load_imu_log", "write_imu_log"]

IMU_SENSORS = 5  # thesis §4.2: five BNO055 along the spine
ANGLE_NAMES = ("heading", "roll", "pitch")  # BNO055 Euler angles, the order of each sensor's three numbers
_N_ANGLES = IMU_SENSORS * len(ANGLE_NAMES)
_LAYOUTS = {_N_ANGLES: "angles", _N_ANGLES + 1: "time+angles"}


@dataclass(eq=False)
class ImuLog:
    """A spine-IMU log read by :func:`load_imu_log`.

    Attributes
    ----------
    t_s : ndarray, (T,) float64
        Sample times (s) on the log's clock: ``k / rate_hz`` for the 15-number layout, the
        file's time column for the 16-number one (an invalid line's time interpolated from
        its valid neighbours by line index).
    angles_deg : ndarray, (T, 5, 3) float64
        Heading, roll, pitch (degrees) of sensors 1..5; NaN on invalid samples.
    valid : ndarray, (T,) bool
        False where the line was malformed.
    meta : dict
        ``source`` (path), ``layout`` (``"angles"`` or ``"time+angles"``), ``rate_hz``,
        ``invalid_lines`` (line number → why).
    """

    t_s: NDArray[np.float64]
    angles_deg: NDArray[np.float64]
    valid: NDArray[np.bool_]
    meta: dict[str, Any] = field(default_factory=dict)

    @property
    def n(self) -> int:
        return int(self.t_s.shape[0])

    @property
    def pitch_deg(self) -> NDArray[np.float64]:
        """``(T, 5)`` pitch of each sensor (degrees), the angle of the spine model (docs/spec.md §8)."""
        return self.angles_deg[:, :, ANGLE_NAMES.index("pitch")]

    def __repr__(self) -> str:
        return (f"ImuLog(n={self.n}, invalid={int((~self.valid).sum())}, layout={self.meta.get('layout')!r}, "
                f"source={self.meta.get('source', '')!r})")


def _parse(tokens: list[str]) -> NDArray[np.float64] | None:
    """The line's numbers, or None when a token is not a finite number."""
    try:
        x = np.array([float(s) for s in tokens], dtype=np.float64)
    except ValueError:
        return None
    return x if np.all(np.isfinite(x)) else None


def _increasing(t: list[float]) -> set[int]:
    """Indices of a longest strictly increasing subsequence of ``t`` (patience sorting): the
    lines whose times keep order, so that one damaged time costs its own line only."""
    tails: list[float] = []
    tail_at: list[int] = []
    prev = [-1] * len(t)
    for i, x in enumerate(t):
        j = bisect_left(tails, x)
        if j == len(tails):
            tails.append(x)
            tail_at.append(i)
        else:
            tails[j], tail_at[j] = x, i
        prev[i] = tail_at[j - 1] if j > 0 else -1
    keep, i = set(), tail_at[-1] if tail_at else -1
    while i >= 0:
        keep.add(i)
        i = prev[i]
    return keep


def _times(index: NDArray[np.int64], t_valid: NDArray[np.float64], n: int, rate_hz: float) -> NDArray[np.float64]:
    """Times of all ``n`` samples from those of the valid ones (at ``index``): linear in the line
    index between them, and at their median step (``1 / rate_hz`` with one valid sample) beyond."""
    k = np.arange(n, dtype=np.float64)
    step = float(np.median(np.diff(t_valid) / np.diff(index))) if index.size >= 2 else 1.0 / rate_hz
    t = np.interp(k, index, t_valid)
    t[k < index[0]] = t_valid[0] - (index[0] - k[k < index[0]]) * step
    t[k > index[-1]] = t_valid[-1] + (k[k > index[-1]] - index[-1]) * step
    return t


def load_imu_log(path: str | os.PathLike[str], *, rate_hz: float = 10.0) -> ImuLog:
    """Load a spine-IMU text log (the layouts of the module docstring).

    Parameters
    ----------
    path : str or PathLike
        The log.
    rate_hz : float
        Sampling rate of the IMU box (Hz): the time base of the 15-number layout (thesis: 10 Hz).

    Returns
    -------
    ImuLog

    Raises
    ------
    FileNotFoundError
        No such file.
    SessionFormatError
        No sample, or lines of a layout other than 15 or 16 numbers (``FILE:LINE: ...``).
    """
    rate_hz = _checks.positive("rate_hz", rate_hz)
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"IMU log not found: {path}")
    # a damaged byte becomes U+FFFD, which fails its line's parse: it costs that line only (docs/spec.md §6);
    # a byte-order mark (a log opened and saved by an editor on Windows) is no part of the first line
    text = path.read_bytes().decode("utf-8-sig", errors="replace")
    lines = [(k + 1, ln.split()) for k, ln in enumerate(text.splitlines())
             if ln.strip() and not ln.lstrip().startswith("#")]
    if not lines:
        raise SessionFormatError(f"{path}: no samples (an IMU log holds one line of {_N_ANGLES} numbers per sample)")
    parsed = [_parse(tok) for _, tok in lines]
    counts = Counter(x.size for x in parsed if x is not None)
    if not counts:
        raise SessionFormatError(f"{path}:{lines[0][0]}: not a line of finite numbers; an IMU log line holds "
                                 f"{_N_ANGLES} numbers (5 sensors x heading, roll, pitch in degrees)")
    width = counts.most_common(1)[0][0]
    if width not in _LAYOUTS:
        first = next(no for (no, _), x in zip(lines, parsed) if x is not None and x.size == width)
        raise SessionFormatError(f"{path}:{first}: {width} numbers on the line; an IMU log line holds {_N_ANGLES} "
                                 f"(5 sensors x heading, roll, pitch in degrees) or {_N_ANGLES + 1} (time in s, then those)")
    timed = width == _N_ANGLES + 1
    n = len(lines)
    angles = np.full((n, _N_ANGLES), np.nan)
    valid = np.zeros(n, dtype=bool)
    t_file = np.full(n, np.nan)
    invalid: dict[int, str] = {}
    ok = [(i, x) for i, x in enumerate(parsed) if x is not None and x.size == width]
    in_order = {ok[j][0] for j in _increasing([float(x[0]) for _, x in ok])} if timed else {i for i, _ in ok}
    for i, ((no, _), x) in enumerate(zip(lines, parsed)):
        if x is None:
            invalid[no] = "a field is not a finite number"
        elif x.size != width:
            invalid[no] = f"{x.size} numbers, expected {width}"
        elif i not in in_order:
            invalid[no] = f"time {x[0]:g} s out of order with the other lines"
        else:
            valid[i] = True
            angles[i] = x[1:] if timed else x
            t_file[i] = x[0]
    if timed:
        idx = np.flatnonzero(valid)
        t = _times(idx, t_file[idx], n, rate_hz)
    else:
        t = np.arange(n, dtype=np.float64) / rate_hz
    meta = {"source": str(path), "layout": _LAYOUTS[width], "rate_hz": rate_hz, "invalid_lines": invalid}
    return ImuLog(t_s=t, angles_deg=angles.reshape(n, IMU_SENSORS, len(ANGLE_NAMES)), valid=valid, meta=meta)


def write_imu_log(path: str | os.PathLike[str], angles_deg: ArrayLike, *, t_s: ArrayLike | None = None) -> Path:
    """Write a spine-IMU text log that :func:`load_imu_log` reads back.

    Parameters
    ----------
    path : str or PathLike
        File to write (replaced if it exists).
    angles_deg : array_like, (T, 5, 3) or (T, 15)
        Heading, roll, pitch (degrees) of sensors 1..5 per sample. A sample holding NaN is
        written with ``nan`` fields and loads back as an invalid sample (a dropout).
    t_s : array_like, (T,), optional
        Sample times (s), written as a leading column (the 16-number layout); without it the
        thesis' 15-number layout.

    Returns
    -------
    Path
        ``path``.
    """
    a = _checks.real_array(angles_deg, "angles_deg", unit="deg", allow_nan=True)
    if a.ndim == 3 and a.shape[1:] == (IMU_SENSORS, len(ANGLE_NAMES)):
        a = a.reshape(a.shape[0], _N_ANGLES)
    if a.ndim != 2 or a.shape[1] != _N_ANGLES or a.shape[0] < 1:
        raise ValueError(f"angles_deg must have shape (T, 5, 3) or (T, 15) in degrees with T >= 1, got {np.shape(angles_deg)}")
    if t_s is not None:
        t = _checks.vector("t_s", t_s)
        if t.shape != (a.shape[0],):
            raise ValueError(f"t_s must have shape ({a.shape[0]},) to match angles_deg, got {t.shape}")
        if not np.all(np.diff(t) > 0):
            raise ValueError("t_s must increase strictly")
        a = np.column_stack([t, a])
    path = Path(path)
    np.savetxt(path, a, fmt="%.5f", delimiter=" ")  # thesis: five decimals separated by spaces
    return path

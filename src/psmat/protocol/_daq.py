"""Material DAQ text protocol (thesis §2.4.1, docs/protocol.md).

While running, the DAQ sends one line every 500 ms: the 10 sensors' 10-bit ADC counts in
decimal, separated by commas, ending ``\\r\\n``::

    512,498,1023,0,77,301,290,288,1001,12\\r\\n

Host commands are single characters: ``s`` starts, ``f`` stops. :class:`DaqLineDecoder`
splits an arbitrary byte stream into lines (keeping a partial line, at most ``max_line``
bytes, for the next chunk) and reports malformed lines instead of raising; a longer line is
garbage, dropped up to its newline without being held. Logs on disk are read by
:func:`psmat.sensor.load_daq_log`. Both go through :func:`parse_daq_fields`, the one parser
of these lines (which also takes semicolons or white space between the fields, as logs saved
by other tools have them).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from typing import Literal, Union

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._checks import as_bytes

__all__ = [
    "DAQ_SENSORS", "DAQ_MAX_COUNT", "DAQ_PERIOD_S", "DAQ_START", "DAQ_STOP",
    "encode_daq_line", "parse_daq_fields", "parse_daq_line", "encode_daq_command",
    "DaqSample", "DaqMalformed", "DaqLineDecoder",
]

#: Sensors per line.
DAQ_SENSORS: int = 10
#: Largest reading (10-bit ADC).
DAQ_MAX_COUNT: int = 1023
#: Line period while running (s).
DAQ_PERIOD_S: float = 0.5
#: Command byte that starts the acquisition.
DAQ_START: bytes = b"s"
#: Command byte that stops it.
DAQ_STOP: bytes = b"f"


def encode_daq_line(counts: ArrayLike, *, n_sensors: int = DAQ_SENSORS) -> bytes:
    """Format one DAQ line (what the DAQ sends).

    Parameters
    ----------
    counts : array_like of int, shape (n_sensors,)
        ADC counts in ``[0, 1023]``.

    Returns
    -------
    bytes
        e.g. ``b"512,498,1023,0,77,301,290,288,1001,12\\r\\n"``.
    """
    arr = np.asarray(counts)
    if arr.dtype == np.bool_ or not np.issubdtype(arr.dtype, np.integer):
        raise TypeError(f"counts must be integers, got dtype {arr.dtype}")
    if arr.shape != (n_sensors,):
        raise ValueError(f"counts must have shape ({n_sensors},), got {arr.shape}")
    if arr.size and (int(arr.min()) < 0 or int(arr.max()) > DAQ_MAX_COUNT):
        raise ValueError(f"counts must lie in [0, {DAQ_MAX_COUNT}], got range [{int(arr.min())}, {int(arr.max())}]")
    return (",".join(str(int(v)) for v in arr) + "\r\n").encode("ascii")


# Separators between fields: the DAQ prints commas (thesis §2.4.1); logs saved by other tools
# use semicolons or white space. Spaces around a separator are tolerated.
_SEPARATOR = re.compile(r"[ \t]*[,;][ \t]*|[ \t]+")
# A reading in counts: the decimal digits the DAQ prints (9 at most, so int() stays cheap).
_COUNT = re.compile(r"[0-9]{1,9}")
# Any decimal number (a reading in volts, the time column in ms): no inf/nan, no "1_000".
_DECIMAL = re.compile(r"[+-]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?")


def parse_daq_fields(line: str | bytes, n_fields: int = DAQ_SENSORS, *, counts_from: int = 0
                     ) -> NDArray[np.float64]:
    """Split one DAQ text line into its numbers: the one parser of the DAQ's lines.

    Used by the wire decoder (:func:`parse_daq_line`, :class:`DaqLineDecoder`) and by the
    log loader (:func:`psmat.sensor.load_daq_log`), so that both accept and reject the same lines.

    Parameters
    ----------
    line : str or bytes
        One line, with or without its ``\\r\\n``; bytes must be ASCII.
    n_fields : int
        Number of fields the line must have.
    counts_from : int
        Fields ``counts_from`` and later must be counts (decimal digits only, as the DAQ
        prints them); earlier fields (a time column in ms, readings in V) may be any finite
        decimal number. ``n_fields`` makes every field a decimal number.

    Returns
    -------
    ndarray of float64, shape (n_fields,)
        The values (no range check: the range depends on the ADC, see the callers).

    Raises
    ------
    ValueError
        Not exactly ``n_fields`` fields separated by commas, semicolons or white space, a
        field that is not a number of its kind, or non-ASCII bytes.
    TypeError
        ``line`` is neither str nor bytes.
    """
    if isinstance(line, (bytes, bytearray, memoryview)):
        try:
            text = bytes(line).decode("ascii")
        except UnicodeDecodeError:
            raise ValueError("DAQ line is not ASCII") from None
    elif isinstance(line, str):
        text = line
    else:
        raise TypeError(f"line must be str or bytes, got {type(line).__name__}")
    text = text.rstrip("\r\n").strip(" \t")
    fields = _SEPARATOR.split(text)
    if len(fields) != n_fields:
        raise ValueError(f"DAQ line: expected {n_fields} values, got {len(fields)} fields: {text[:80]!r}")
    out = np.empty(n_fields, dtype=np.float64)
    for i, f in enumerate(fields):
        if i >= counts_from:
            if not _COUNT.fullmatch(f):
                raise ValueError(f"DAQ field {i} is not a decimal count: {f[:20]!r}")
        elif not _DECIMAL.fullmatch(f) or not math.isfinite(float(f)):
            raise ValueError(f"DAQ field {i} is not a finite decimal number: {f[:20]!r}")
        out[i] = float(f)
    return out


def parse_daq_line(line: str | bytes, *, n_sensors: int = DAQ_SENSORS) -> NDArray[np.int16]:
    """Parse one DAQ line from the wire (with or without its ``\\r\\n``).

    Returns
    -------
    ndarray of int16, shape (n_sensors,)
        The counts.

    Raises
    ------
    ValueError
        What :func:`parse_daq_fields` rejects, or a count above ``DAQ_MAX_COUNT`` (1023).
    """
    values = parse_daq_fields(line, n_sensors)
    over = np.flatnonzero(values > DAQ_MAX_COUNT)
    if over.size:
        i = int(over[0])
        raise ValueError(f"DAQ field {i} = {int(values[i])} exceeds {DAQ_MAX_COUNT}")
    return values.astype(np.int16)


def encode_daq_command(command: Literal["start", "stop"]) -> bytes:
    """The byte to send: ``b"s"`` for ``"start"``, ``b"f"`` for ``"stop"``."""
    if command == "start":
        return DAQ_START
    if command == "stop":
        return DAQ_STOP
    raise ValueError(f"command must be 'start' or 'stop', got {command!r}")


@dataclass(frozen=True, slots=True, eq=False)
class DaqSample:
    """One well-formed line: ``counts`` (int16, shape (n_sensors,)), its 0-based ``line`` number."""

    counts: NDArray[np.int16]
    line: int


@dataclass(frozen=True, slots=True)
class DaqMalformed:
    """A line that could not be parsed: the ``raw`` bytes (without ``\\r\\n``), why, and its number."""

    raw: bytes
    reason: str
    line: int


DaqEvent = Union[DaqSample, DaqMalformed]


class DaqLineDecoder:
    """Incremental DAQ line splitter and parser.

    Parameters
    ----------
    n_sensors : int
        Fields per line (10).
    max_line : int
        Longest line kept (bytes before its ``\\n``, >= 1; a 10-sensor DAQ line holds at most
        50, its ``\\r`` included). A longer
        line is garbage: one :class:`DaqMalformed` (its first 80 bytes) as soon as
        ``max_line`` is exceeded, then its bytes are dropped up to and including the next
        ``\\n`` without being held, and counted in ``skipped``. So the decoder holds at most
        ``max_line`` bytes whatever the stream.

    Notes
    -----
    Lines end at ``\\n`` (a preceding ``\\r`` is removed). Blank lines are ignored (counted
    in ``blank``). Counters: ``bytes_in``, ``lines`` (non-blank lines seen, overlong ones
    included), ``samples``, ``malformed``, ``blank``, ``skipped`` (bytes of overlong lines).
    """

    def __init__(self, n_sensors: int = DAQ_SENSORS, max_line: int = 256) -> None:
        self.n_sensors = int(n_sensors)
        self.max_line = int(max_line)
        if self.max_line < 1:
            raise ValueError(f"max_line must be >= 1 byte, got {max_line}")
        self._partial = bytearray()
        self._discarding = False   # inside an overlong line: drop bytes up to the next newline
        self.bytes_in = 0
        self.lines = 0
        self.samples = 0
        self.malformed = 0
        self.blank = 0
        self.skipped = 0

    @property
    def stats(self) -> dict[str, int]:
        """The counters as a dict."""
        return {k: getattr(self, k) for k in ("bytes_in", "lines", "samples", "malformed", "blank", "skipped")}

    @property
    def pending(self) -> int:
        """Bytes held for the next :meth:`feed` (a partial line, at most ``max_line``)."""
        return len(self._partial)

    def _overlong(self, head: bytes, events: list[DaqEvent]) -> None:
        self.lines += 1
        self.malformed += 1
        events.append(DaqMalformed(bytes(head[:80]), f"line longer than {self.max_line} bytes", self.lines - 1))

    def _line(self, raw: bytes, events: list[DaqEvent]) -> None:
        raw = raw.rstrip(b"\r")
        if not raw.strip():
            self.blank += 1
            return
        number = self.lines
        self.lines += 1
        try:
            counts = parse_daq_line(raw, n_sensors=self.n_sensors)
        except ValueError as exc:
            self.malformed += 1
            events.append(DaqMalformed(bytes(raw), str(exc), number))
            return
        self.samples += 1
        events.append(DaqSample(counts, number))

    def feed(self, data: bytes | bytearray | memoryview) -> list[DaqEvent]:
        """Add a chunk; return the :class:`DaqSample` / :class:`DaqMalformed` of the lines it completed."""
        chunk = bytes(as_bytes(data))
        self.bytes_in += len(chunk)
        events: list[DaqEvent] = []
        if self._discarding:
            nl = chunk.find(b"\n")
            if nl < 0:
                self.skipped += len(chunk)
                return events
            self.skipped += nl + 1
            chunk = chunk[nl + 1:]
            self._discarding = False
        if b"\n" in chunk:       # the held partial line is copied once, when its line ends
            parts = (bytes(self._partial) + chunk).split(b"\n")
            self._partial = bytearray()
            tail = parts.pop()
            for raw in parts:
                if len(raw) > self.max_line:
                    self._overlong(raw.rstrip(b"\r"), events)
                    self.skipped += len(raw) + 1
                else:
                    self._line(raw, events)
        else:
            tail = chunk
        if len(self._partial) + len(tail) > self.max_line:      # overlong: report, then drop
            self._overlong(bytes(self._partial[:80]) + tail[:80], events)
            self.skipped += len(self._partial) + len(tail)
            self._discarding = True
            self._partial = bytearray()
        else:
            self._partial += tail
        return events

    def finish(self) -> list[DaqEvent]:
        """End of stream: a pending partial line is parsed if complete, else reported malformed."""
        events: list[DaqEvent] = []
        self._discarding = False
        if self._partial:
            raw, self._partial = bytes(self._partial), bytearray()
            self._line(raw, events)
        return events

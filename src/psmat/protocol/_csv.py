"""The csv text protocol of do-it-yourself mats (docs/spec.md §5; grammar in docs/protocol.md, "csv").

A home-made mat (an Arduino reading a Velostat grid through two multiplexers) prints its ADC
counts as ASCII integers, in one of two layouts:

* ``line``: one frame per line, ``R·C`` numbers, row-major (``a = i*C + p``);
* ``block``: ``R`` lines of ``C`` numbers, closed by a blank line or by a marker line (a
  line whose first character is not a digit, e.g. ``# frame 12``).

Numbers are separated by ``,``, ``;``, tab or spaces, mixed at will; a run of separators
counts as one and a separator may start or end a line (sketches often print one after
every number); line ends are ``\\n`` or ``\\r\\n``. A line whose first character is not a
digit (nor a sign followed by a digit) is text: a header (skipped, never an invalid row) or,
when a block is open, the marker that closes it. :class:`CsvDecoder` reads the stream at a
bounded cost and memory per byte, whatever it holds; :func:`encode_csv` writes it.
"""

from __future__ import annotations

from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._checks import as_bytes, int_frame, is_int, shape2
from ._decoder import Frame

__all__ = ["CSV_SEPARATORS", "CSV_REASONS", "encode_csv", "CsvDecoder", "decode_csv"]

#: Separators :func:`encode_csv` writes (the decoder takes any mix of ``,``, ``;``, tab and space).
CSV_SEPARATORS: tuple[str, ...] = (",", ";", "\t", " ", ", ", "; ")
#: Why a frame was invalid (the keys of :attr:`CsvDecoder.reasons`).
CSV_REASONS: tuple[str, ...] = ("count", "token", "range", "long", "short_block", "long_block", "unclosed")

_SEP = np.zeros(256, dtype=bool)
_SEP[list(b",; \t\r\n")] = True
_MAX_DIGITS = 18                                    # longer tokens are never a count (int64 stays exact)
_POW10 = 10 ** np.arange(_MAX_DIGITS + 1, dtype=np.int64)
_PIECE = 1 << 18                                    # bytes parsed at once: bounds the temporary arrays
_BLANK, _TEXT, _DATA = 0, 1, 2


def _first_kind(head: bytes) -> int:
    """Kind of a line from its first bytes: blank, text (header/marker) or data."""
    s = head.lstrip(b",; \t\r")
    if not s:
        return _BLANK
    if 48 <= s[0] <= 57 or (s[0] in b"+-" and len(s) > 1 and 48 <= s[1] <= 57):
        return _DATA
    return _TEXT


def encode_csv(frame: ArrayLike, layout: Literal["line", "block"] = "line", sep: str = ",",
               marker: str | None = None, *, eol: str = "\n") -> bytes:
    """Format one frame of counts as a csv mat sends it.

    Parameters
    ----------
    frame : array_like of int, shape (R, C)
        ADC counts in ``[0, 65535]``.
    layout : {"line", "block"}
        ``"line"``: one line of ``R·C`` numbers, row-major. ``"block"``: ``R`` lines of ``C``
        numbers, then a blank line, or the ``marker`` line when one is given.
    sep : str
        One of :data:`CSV_SEPARATORS`.
    marker : str, optional
        Block layout: the closing line instead of a blank one; ASCII, not starting with a
        digit, a sign, a separator or white space (e.g. ``"#"``).
    eol : {"\\n", "\\r\\n"}
        Line end (an Arduino's ``Serial.println`` writes ``"\\r\\n"``).

    Returns
    -------
    bytes
        ASCII text.

    Raises
    ------
    TypeError, ValueError
        A frame that is not a 2-D array of counts, or a bad option.
    """
    arr = int_frame(frame, "frame", 65535)
    if layout not in ("line", "block"):
        raise ValueError(f"layout must be 'line' or 'block', got {layout!r}")
    if sep not in CSV_SEPARATORS:
        raise ValueError(f"sep must be one of {CSV_SEPARATORS!r}, got {sep!r}")
    if eol not in ("\n", "\r\n"):
        raise ValueError(f"eol must be '\\n' or '\\r\\n', got {eol!r}")
    if marker is not None:
        if layout != "block":
            raise ValueError("a marker closes a block: use layout='block'")
        if (not isinstance(marker, str) or not marker or not marker.isascii() or not marker.isprintable()
                or marker[0] in "0123456789+-,; \t"):
            raise ValueError(f"marker must be printable ASCII text not starting with a digit, a sign, a separator "
                             f"or a space, got {marker!r}")
    if layout == "line":
        return (sep.join(map(str, arr.ravel().tolist())) + eol).encode("ascii")
    rows = eol.join(sep.join(map(str, row)) for row in arr.tolist())
    return (rows + eol + (marker or "") + eol).encode("ascii")


class CsvDecoder:
    """Incremental decoder of a csv mat's stream (both layouts, told apart line by line).

    Parameters
    ----------
    shape : (int, int)
        The mat's ``(R, C)`` (not on the wire).
    bits : int
        ADC resolution, 1 ... 16: a count above ``2**bits - 1`` is invalid. Default 10 (an
        Arduino Uno's ADC).
    max_line : int, optional
        Longest line kept (bytes before its ``\\n``). Default ``R·C·(D + 8)`` with ``D`` the
        digits of ``2**bits - 1``: a number with its separators (and any leading zeros) in
        at most ``D + 8`` bytes. A longer line is cut: its bytes are dropped up to its
        newline without being held, and it counts as a bad data line (reason ``"long"``),
        unless it starts as text (a long banner, then it is skipped).
    opened : bool
        The stream is a port just opened, which may begin within a line or a block: the first
        frame, when invalid, is the cut piece of the one the board was sending, and its bytes
        are skipped (counted in ``skipped``, like the binary decoders' bytes before their first
        frame), not an invalid row. A valid first frame is kept. Default False: a whole log
        (:func:`decode_csv`), whose first frame is judged like any other.

    Notes
    -----
    Every line is classified by its first token: *blank* (no token), *text* (first
    character neither a digit nor a sign followed by a digit: a header or a marker) or
    *data*. A data line holds a *good* count when each token is decimal digits (at most 18)
    of a value ``<= 2**bits - 1``; otherwise the line is bad (reason ``"token"`` for a
    non-number, a negative number included, ``"range"`` for a value beyond the bits). Then:

    * a data line of ``R·C`` numbers is a frame (layout ``line``): valid when its numbers are
      good; a block open at that moment ends as one invalid frame (``"unclosed"``);
    * a data line of ``C`` numbers (``R > 1``) is a row of the open block, or opens one;
      every data line while a block is open is one of its rows too, whatever its count; so
      is a data line of a wrong count when the last layout seen was ``block``;
    * a blank or text line closes the open block: one frame, valid when it holds exactly
      ``R`` rows, all good (else invalid: ``"short_block"`` for fewer rows, or the first bad
      row's reason); outside a block such a line is skipped (a header: no row);
    * a block that already holds ``R`` rows when another row comes is one invalid frame
      (``"long_block"``), and the new row opens a block that is invalid too (rows after a
      missing closing line cannot be trusted: a 32-row mat read as 16 rows never yields
      valid frames); so a lost closing line costs two frames, ``n`` rows without any
      closing line give about ``n / R`` invalid frames (the time base is kept);
    * a data line of a wrong count outside a block (layout ``line`` or not yet known) is one
      invalid frame (``"count"``).

    A data line whose first character was corrupted into a non-digit reads as text: in the
    line layout that frame is absent without a row (the csv protocol has no sequence numbers
    to count it by). At :meth:`finish` a last line without its newline is judged as it
    stands and an open block is closed as by a closing line.

    Cost: each byte is looked at by a few NumPy passes (pieces of 256 KiB at most) and each
    line by O(1) Python steps; memory: at most ``max_line`` held bytes plus one block's rows
    beside the chunk being fed. Counters (attributes, also :attr:`stats`): ``bytes_in``,
    ``frames`` (valid), ``invalid`` (invalid rows), ``skipped`` (bytes of blank, header and
    marker lines that close no block, and of a cut first frame: ``opened``), ``dropped``,
    ``replies``, ``restarts`` (always 0: no sequence numbers, no replies); :attr:`reasons`
    counts the invalid rows by reason.
    """

    def __init__(self, shape: tuple[int, int], bits: int = 10, *, max_line: int | None = None,
                 opened: bool = False) -> None:
        r, c = shape2(shape)
        if not is_int(bits) or not 1 <= bits <= 16:
            raise ValueError(f"bits must be an integer 1 ... 16, got {bits!r}")
        self.shape = (r, c)
        self.bits = int(bits)
        self.max_value = (1 << self.bits) - 1
        if max_line is None:
            max_line = r * c * (len(str(self.max_value)) + 8)
        if not is_int(max_line) or max_line < 1:
            raise ValueError(f"max_line must be a positive number of bytes, got {max_line!r}")
        self.max_line = int(max_line)
        self._partial = bytearray()
        self._line_off = 0                       # stream offset of the line being held
        self._long: tuple[int, int] | None = None  # (offset, kind) of an overlong line being dropped
        self._rows: list[list[int]] = []
        self._block_n = 0                        # row lines of the open block (0: none open)
        self._block_off = 0
        self._block_bad: str | None = None
        self._layout: str | None = None
        self._at_open = bool(opened)             # no frame yet since the port opened (``opened``)
        self._zeros = np.zeros((r, c), dtype=np.uint16)
        self._zeros.setflags(write=False)
        self.bytes_in = 0
        self.frames = 0
        self.invalid = 0
        self.skipped = 0
        self.dropped = 0
        self.replies = 0
        self.restarts = 0
        self.reasons: dict[str, int] = dict.fromkeys(CSV_REASONS, 0)

    # -- public -------------------------------------------------------------------------
    @property
    def stats(self) -> dict[str, int]:
        """The counters as a dict (the keys of the other decoders)."""
        return {k: getattr(self, k) for k in
                ("bytes_in", "frames", "invalid", "skipped", "dropped", "replies", "restarts")}

    @property
    def pending(self) -> int:
        """Bytes held for the next :meth:`feed` (a partial line, at most ``max_line``)."""
        return len(self._partial)

    def feed(self, data: bytes | bytearray | memoryview) -> list[Frame]:
        """Add a chunk of the stream and return the frames it completed (never raises on bad input).

        Parameters
        ----------
        data : bytes-like
            Any number of bytes (chunk boundaries need not align with lines).

        Returns
        -------
        list of Frame
            ``kind="psm"``, uint16 ``(R, C)`` counts (zeros when ``valid`` is False),
            ``seq``/``t_us`` None, ``offset`` the stream offset of the frame's first line.
        """
        chunk = bytes(as_bytes(data))
        events: list[Frame] = []
        for a in range(0, len(chunk), _PIECE):
            self._feed(chunk[a:a + _PIECE], events)
        return events

    def finish(self) -> list[Frame]:
        """End of stream: judge the last line (even without its newline) and close an open block.

        The decoder is then empty (counters kept) and may be fed again.
        """
        events: list[Frame] = []
        if self._long is not None:
            self._end_long(events, self.bytes_in - 1)
        elif self._partial:
            region, self._partial = bytes(self._partial) + b"\n", bytearray()
            self._lines(region, self._line_off, events, no_newline=True)
        self._line_off = self.bytes_in
        if self._block_n:
            self._close_block(events, self.bytes_in)
        return events

    # -- bytes -> lines -----------------------------------------------------------------
    def _feed(self, piece: bytes, events: list[Frame]) -> None:
        start = self.bytes_in
        self.bytes_in += len(piece)
        pos = 0
        if self._long is not None:
            nl = piece.find(b"\n")
            if nl < 0:
                return
            self._end_long(events, start + nl)
            pos = nl + 1
            self._line_off = start + pos
        last = piece.rfind(b"\n", pos)
        if last >= 0:
            region = bytes(self._partial) + piece[pos:last + 1] if self._partial else piece[pos:last + 1]
            self._partial = bytearray()
            self._lines(region, self._line_off, events)
            pos = last + 1
            self._line_off = start + pos
        tail = piece[pos:]
        if len(self._partial) + len(tail) > self.max_line:   # overlong: classify, then drop unheld
            head = bytes(self._partial) + tail[:self.max_line + 1]
            self._long = (self._line_off, _first_kind(head))
            self._partial = bytearray()
        else:
            self._partial += tail

    def _end_long(self, events: list[Frame], nl_off: int) -> None:
        off, kind = self._long  # type: ignore[misc]
        self._long = None
        self._line(events, kind, off, nl_off - off + 1, -1, "long", None)

    def _lines(self, region: bytes, off: int, events: list[Frame], no_newline: bool = False) -> None:
        """Parse the complete lines of ``region`` (it ends with ``\\n``) at once, then judge each in turn."""
        a = np.frombuffer(region, dtype=np.uint8)
        nl = np.flatnonzero(a == 10)
        n_lines = nl.size
        line_start = np.empty(n_lines, dtype=np.int64)
        line_start[0] = 0
        line_start[1:] = nl[:-1] + 1
        tok = ~_SEP[a]
        edge = np.diff(tok.view(np.int8), prepend=np.int8(0), append=np.int8(0))
        tstart = np.flatnonzero(edge == 1)
        tend = np.flatnonzero(edge == -1)
        tlen = tend - tstart
        tline = np.searchsorted(nl, tstart)
        if tstart.size:
            where = np.flatnonzero(tok)
            digit = a[where].astype(np.int64) - 48
            is_digit = (digit >= 0) & (digit <= 9)
            from_end = np.repeat(tend, tlen) - where - 1
            terms = np.where(is_digit, digit, 0) * _POW10[np.minimum(from_end, _MAX_DIGITS)]
            first = np.zeros(tstart.size, dtype=np.int64)
            np.cumsum(tlen[:-1], out=first[1:])
            values = np.add.reduceat(terms, first)
            number = (np.add.reduceat((~is_digit).view(np.int8), first, dtype=np.int64) == 0) & (tlen <= _MAX_DIGITS)
            beyond = number & (values > self.max_value)
            n_tok = np.bincount(tline, minlength=n_lines)
            n_bad = np.bincount(tline, weights=~number, minlength=n_lines)
            n_beyond = np.bincount(tline, weights=beyond, minlength=n_lines)
            first_tok = np.searchsorted(tline, np.arange(n_lines))
            b0 = a[tstart[np.minimum(first_tok, tstart.size - 1)]]
            b1 = a[np.minimum(tstart[np.minimum(first_tok, tstart.size - 1)] + 1, a.size - 1)]
            data = (n_tok > 0) & (((b0 >= 48) & (b0 <= 57)) | (((b0 == 43) | (b0 == 45)) & (b1 >= 48) & (b1 <= 57)))
            values_l = values.tolist()
        else:
            n_tok = n_bad = n_beyond = np.zeros(n_lines, dtype=np.int64)
            first_tok = n_tok
            data = np.zeros(n_lines, dtype=bool)
            values_l = []
        lengths = (nl - line_start).tolist()
        R, C = self.shape
        for i, (length, start, n, bad, over, ft, is_data) in enumerate(zip(
                lengths, line_start.tolist(), n_tok.tolist(), n_bad.tolist(), n_beyond.tolist(), first_tok.tolist(),
                data.tolist())):
            nbytes = length + (0 if no_newline and i == n_lines - 1 else 1)
            kind = _DATA if is_data else (_TEXT if n else _BLANK)
            if length > self.max_line:
                self._line(events, kind, off + start, nbytes, -1, "long", None)
                continue
            reason = "token" if bad else ("range" if over else None)
            vals = values_l[ft:ft + n] if is_data and reason is None and (n == R * C or n == C) else None
            self._line(events, kind, off + start, nbytes, int(n), reason, vals)

    # -- lines -> frames ----------------------------------------------------------------
    def _line(self, events: list[Frame], kind: int, off: int, nbytes: int, n: int, reason: str | None,
              vals: list[int] | None) -> None:
        """Judge one line (``n`` tokens, -1 for an overlong line) against the open block (see the class notes)."""
        R, C = self.shape
        if kind != _DATA:
            if self._block_n:
                self._close_block(events, off + nbytes)
            else:
                self.skipped += nbytes
            return
        if n == R * C:
            if self._block_n:
                self._end_block(events, self._block_bad or "unclosed", off)
            self._layout = "line"
            self._emit(events, off, vals, reason, off + nbytes)
            return
        is_row = n == C
        if R > 1 and (is_row or self._block_n or self._layout == "block"):
            carried = None
            if self._block_n == R:
                self._end_block(events, self._block_bad or "long_block", off)
                carried = "long_block"
            if not self._block_n:
                self._block_off = off
                self._block_bad = carried
            self._block_n += 1
            bad = reason if is_row else (reason if n < 0 else "count")
            if bad is None and vals is not None:
                self._rows.append(vals)
            elif self._block_bad is None:
                self._block_bad = bad or "count"
            if is_row:
                self._layout = "block"
            return
        self._emit(events, off, None, reason if n < 0 else "count", off + nbytes)

    def _close_block(self, events: list[Frame], end: int) -> None:
        """A closing line (or the end of the stream), ending at stream offset ``end``, ends the open block."""
        reason = self._block_bad or (None if self._block_n == self.shape[0] else "short_block")
        self._end_block(events, reason, end)

    def _end_block(self, events: list[Frame], reason: str | None, end: int) -> None:
        rows = self._rows
        self._rows, self._block_n, self._block_bad = [], 0, None
        self._emit(events, self._block_off, [v for row in rows for v in row] if reason is None else None, reason,
                   end)

    def _emit(self, events: list[Frame], off: int, vals: list[int] | None, reason: str | None, end: int) -> None:
        """One frame from stream offset ``off`` to ``end`` (its bytes, its closing line's included)."""
        valid = reason is None and vals is not None
        if self._at_open:  # the first frame since the port opened: an invalid one is the cut piece (``opened``)
            self._at_open = False
            if not valid:
                self.skipped += end - off
                return
        if valid:
            self.frames += 1
            data = np.array(vals, dtype=np.uint16).reshape(self.shape)
            events.append(Frame("psm", data, True, None, None, off))
            return
        self.invalid += 1
        self.reasons[reason or "count"] += 1
        events.append(Frame("psm", self._zeros, False, None, None, off))


def decode_csv(data: bytes | bytearray | memoryview, shape: tuple[int, int],
               bits: int = 10) -> tuple[NDArray[np.uint16], NDArray[np.bool_]]:
    """Decode a whole csv stream or log (either layout) into arrays.

    Parameters
    ----------
    data : bytes-like
        The text (a last line without its newline is judged too).
    shape : (int, int)
        The mat's ``(R, C)``.
    bits : int
        ADC resolution (1 ... 16; default 10, an Arduino's).

    Returns
    -------
    frames : ndarray of uint16, shape (N, R, C)
        Counts, one row per frame; zeros in invalid rows.
    valid : ndarray of bool, shape (N,)
        False for an invalid row (see :class:`CsvDecoder`).
    """
    dec = CsvDecoder(shape, bits)
    events: list[Any] = dec.feed(data)
    events += dec.finish()
    frames = np.empty((len(events), *dec.shape), dtype=np.uint16)
    valid = np.empty(len(events), dtype=bool)
    for i, e in enumerate(events):
        frames[i] = e.data
        valid[i] = e.valid
    return frames, valid

"""Incremental stream decoders: feed them whatever the serial port delivers.

:class:`V1Decoder` (PSM v1), :class:`ImuV1Decoder` (spine IMU v1) and :class:`V2Decoder`
(every v2 packet) take arbitrary chunks through :meth:`~_Decoder.feed`, keep the bytes of an
incomplete packet for the next call, and return the events completed so far:

* :class:`Frame` - one row of the time series; ``valid=False`` for a frame that failed
  its check, kept at the position it occupied so the time base is preserved;
* :class:`Reply` - a device's answer to a command (v2 framing, recognised by all three
  decoders since devices reply in v2 even while streaming v1);
* :class:`Gap` - (v2) frames the sequence numbers say were lost, emitted just before the
  frame that revealed the gap.

Resynchronisation is byte by byte: after garbage or a failed check the decoder looks for
the next marker (``0xFF 0xFF`` for v1, ``0xA5 0x5A`` for v2) after the failed one's first
byte, so a valid frame is found wherever it starts. In v1 a failed candidate is an invalid
row, except (a) a false start: directly followed by another marker byte (``FF FF FF``), its
first byte is garbage; (b) a candidate that starts inside the span of a reported row
or reply is no row (a marker-like pair inside a corrupted frame, or garbage). In v2 a packet
with a plausible header and a bad CRC is an invalid row, but its header failed the check too
and is trusted only as far as it agrees with what is known: a candidate inside the span of
a reported row or reply is no row (the sequence numbers count a real frame lost
there), nor is one whose shape differs from the last valid frame of its type (a fake header
in garbage or in a payload).

Invalid rows never overlap and each stands for a whole frame's bytes (v1: ``2 + payload +
2``; v2: ``16 + n + 2`` of its header), so a stream of ``N`` bytes yields at most
``N // frame_bytes`` invalid rows of a shape, whatever it holds (``FF FF 00 00`` repeated
is one invalid row per frame's worth of bytes, not one per 4 bytes). The price: a frame
shortened by lost bytes and followed by a corrupted one gives one invalid row for the two
(v2's sequence numbers still count the second as dropped).

Cost per input byte is bounded whatever the input holds (counted in ``crc_bytes``,
``check_bytes``, ``candidates``, also :attr:`~_Decoder.work`):

* every marker is judged once, with O(1) work before its check: a v2 header must be
  plausible (version, type, ``n <= 8192``, ``n`` agreeing with ``R``, ``C``; ``R = C = 0``
  for a reply); a v1 candidate whose check word exceeds 4095 cannot be valid, nor can a v1
  PSM candidate whose span holds ``FF FF`` after its marker (every high byte of a valid
  frame is <= 0x0F; one scan of the span); the false starts of a run of 0xFF bytes are
  skipped in one step;
* v2 CRCs of overlapping candidates come from prefix registers
  (:class:`~psmat.protocol.SpanCrc`): at most 2 CRC bytes per input byte plus 32
  per overlapping candidate, instead of the claimed payload per candidate;
* the v1 PSM checks that pass the pre-check cover each byte at most about twice (two checked
  candidates closer than a frame are the two last positions of an ``FF`` run), and so do
  the pre-check's scans: about 4 check bytes per input byte at most; an IMU check reads 62
  bytes, and each checked IMU candidate has a 0xFF byte (its first) and a check byte <= 0x0F
  (its last) of its own, so at most half the bytes start one: 31 check bytes per input byte;
* memory: the bytes of one pending packet (at most ``16 + 8192 + 2``) plus fewer than 16
  bytes of CRC state, beside the chunk being fed.

Counters (attributes, also :attr:`~_Decoder.stats`): ``bytes_in``, ``frames`` (valid
frames), ``invalid`` (invalid rows), ``skipped`` (garbage bytes that belong to no reported
row or reply), ``dropped`` (v2: frames missing from the ``seq`` sequence, wrap-aware, net of
the invalid rows reported in their place), ``replies``, ``restarts`` (v2: ``seq`` went
backwards, i.e. the device restarted; no drop is counted). Work counters (not in ``stats``:
they depend on how the stream was chunked, the events do not): ``candidates`` (markers
judged), ``crc_bytes`` (bytes run through the CRC-16), ``check_bytes`` (bytes read by v1
checks and their pre-check).

v2 ``t_us`` is unwrapped into a 64-bit device clock (microseconds since the device's counter
origin, the first packet's raw value as the starting point), monotonic over the frames: each
packet lies within half a wrap of the packet before it, frame or reply (a frame sent after a
reply may have been scanned before it), unless a frame would then go before the last frame,
which it follows by ``(t_us - previous frame's t_us) mod 2**32`` (a wrap, or a device restart).
"""

from __future__ import annotations

import re
import struct
from abc import ABC, abstractmethod
from dataclasses import dataclass
from typing import Any, Literal, Union

import numpy as np
from numpy.typing import NDArray

from .._checks import as_bytes, shape2
from ._span_crc import SpanCrc
from ._v1 import IMU_SHAPE, V1_MAX_COUNT
from ._v2 import CRC_SIZE, HEADER_SIZE, MAX_PAYLOAD, SYNC, VERSION, Opcode, PacketType, Status

__all__ = ["Frame", "Reply", "Gap", "Event", "V1Decoder", "ImuV1Decoder", "V2Decoder", "decode_v1", "decode_imu_v1",
           "decode_v2"]

_WRAP = 1 << 32
_HALF = 1 << 31
_HDR = struct.Struct("<BBIIBBH")  # version, type, seq, t_us, rows, cols, n (from offset 2)
_MARKERS = re.compile(rb"\xff\xff|\xa5\x5a")
_NOT_FF = re.compile(rb"[^\xff]")
_NEED_MORE = -1
_BAD = -2


@dataclass(frozen=True, slots=True, eq=False)
class Frame:
    """One decoded frame (one row of the time series).

    Attributes
    ----------
    kind : {"psm", "imu"}
        PSM counts or IMU angles.
    data : ndarray
        ``psm``: uint16 counts, shape (R, C), zeros when invalid. ``imu``: float32 Euler
        angles in degrees, shape (R, C) ((5, 3) for the spine DAQ), NaN when invalid.
    valid : bool
        False when the frame failed its check (its contents are unknown).
    seq : int or None
        v2 sequence number (raw uint32); None for v1 and for invalid rows.
    t_us : int or None
        v2 device time of the scan, unwrapped (microseconds, monotonic); None for v1 and
        invalid rows.
    offset : int
        Stream offset of the frame's first byte (bytes since the decoder's start).
    """

    kind: str
    data: NDArray[Any]
    valid: bool
    seq: int | None
    t_us: int | None
    offset: int


@dataclass(frozen=True, slots=True)
class Reply:
    """A device reply (v2 type 0x11).

    Attributes
    ----------
    opcode : int or None
        The opcode answered, an :class:`~psmat.protocol.Opcode` when known (None for an
        empty payload).
    status : int or None
        :class:`~psmat.protocol.Status` value when known (None if the payload is shorter).
    text : str
        The reply text (ASCII; undecodable bytes replaced).
    seq : int
        Raw ``seq`` field.
    t_us : int
        Device time, unwrapped against the frames' clock (microseconds).
    offset : int
        Stream offset of the packet's first byte.
    """

    opcode: int | None
    status: int | None
    text: str
    seq: int
    t_us: int
    offset: int


@dataclass(frozen=True, slots=True)
class Gap:
    """``count`` frames lost just before the frame with sequence number ``seq`` (v2)."""

    count: int
    seq: int


Event = Union[Frame, Reply, Gap]


def _known(enum_type: Any, value: int) -> int:
    try:
        return enum_type(value)
    except ValueError:
        return value


class _Decoder(ABC):
    """Buffer handling, counters and the reply parser shared by the decoders."""

    #: Largest number of bytes waited for before a candidate can be judged.
    _max_packet = HEADER_SIZE + MAX_PAYLOAD + CRC_SIZE

    def __init__(self) -> None:
        self._buf = bytearray()
        self._base = 0          # stream offset of _buf[0]
        self._pos = 0           # next index of _buf to examine
        self._owned_end = 0     # stream offset where the reported rows/replies end
        self._last_t: int | None = None   # the last frame's raw time and its place on the clock
        self._clock = 0
        self._ref_t: int | None = None    # the same for the latest frame or reply
        self._ref_clock = 0
        self.bytes_in = 0
        self.frames = 0
        self.invalid = 0
        self.skipped = 0
        self.dropped = 0
        self.replies = 0
        self.restarts = 0
        self.candidates = 0
        self.check_bytes = 0
        self._span = SpanCrc()

    # -- public -------------------------------------------------------------------------
    @property
    def stats(self) -> dict[str, int]:
        """The counters as a dict."""
        return {k: getattr(self, k) for k in
                ("bytes_in", "frames", "invalid", "skipped", "dropped", "replies", "restarts")}

    @property
    def crc_bytes(self) -> int:
        """Bytes run through the CRC-16 so far (v2 packets, replies)."""
        return self._span.bytes

    @property
    def work(self) -> dict[str, int]:
        """Work done so far: ``candidates`` (markers judged), ``crc_bytes``, ``check_bytes``."""
        return {"candidates": self.candidates, "crc_bytes": self.crc_bytes, "check_bytes": self.check_bytes}

    @property
    def pending(self) -> int:
        """Bytes held for the next :meth:`feed` (an incomplete packet or a marker byte)."""
        return len(self._buf) - self._pos

    def feed(self, data: bytes | bytearray | memoryview) -> list[Event]:
        """Add a chunk of the stream and return the events it completed.

        Parameters
        ----------
        data : bytes-like
            Any number of bytes (chunk boundaries need not align with packets).

        Returns
        -------
        list of Frame, Reply, Gap
            In stream order. Never raises on malformed input.
        """
        chunk = as_bytes(data)
        self.bytes_in += len(chunk)
        self._buf += chunk
        events: list[Event] = []
        self._process(events, final=False)
        self._compact()
        return events

    def finish(self) -> list[Event]:
        """End of stream: judge what is held without waiting for more bytes.

        Incomplete packets are counted as skipped bytes; complete packets behind a
        candidate that was still waiting for its bytes are decoded. The decoder is then
        empty (its counters and clocks are kept) and may be fed again.
        """
        events: list[Event] = []
        self._process(events, final=True)
        self._skip(self._pos, len(self._buf))
        self._pos = len(self._buf)
        self._compact()
        return events

    # -- helpers ------------------------------------------------------------------------
    def _compact(self) -> None:
        cut = self._span.keep_from(self._base + self._pos) - self._base
        if cut > 0:
            del self._buf[:cut]
            self._base += cut
            self._pos -= cut

    def _skip(self, a: int, b: int) -> None:
        """Count buffer bytes [a, b) as garbage, except those inside a reported span."""
        if b > a:
            start = max(self._base + a, self._owned_end)
            end = self._base + b
            if end > start:
                self.skipped += end - start

    def _unwrap(self, t_raw: int, *, frame: bool) -> int:
        """``t_raw`` (µs, 32 bits) on the unwrapped device clock.

        A packet is placed within half a wrap of the latest packet, frame or reply, either side: a
        reply is stamped when it is sent and a frame when its scan began, so a frame sent after a
        reply may carry an earlier time. A frame never goes before the frame before it: where that
        placing would, the device wrapped or restarted, and the frame goes forwards of the last
        frame by the difference mod 2**32.
        """
        if self._ref_t is None:
            clock = t_raw
        else:
            delta = (t_raw - self._ref_t) % _WRAP
            clock = self._ref_clock + (delta - _WRAP if delta >= _HALF else delta)
        if frame:
            if self._last_t is not None and clock < self._clock:
                clock = self._clock + (t_raw - self._last_t) % _WRAP
            self._last_t, self._clock = t_raw, clock
        self._ref_t, self._ref_clock = t_raw, clock
        return clock

    def _reply(self, payload: bytes, seq: int, t_raw: int, k: int) -> Reply:
        self.replies += 1
        opcode = _known(Opcode, payload[0]) if len(payload) >= 1 else None
        status = _known(Status, payload[1]) if len(payload) >= 2 else None
        text = payload[2:].decode("ascii", errors="replace")
        return Reply(opcode, status, text, seq, self._unwrap(t_raw, frame=False), self._base + k)

    def _v2_packet(self, buf: bytearray, k: int, final: bool, accept: frozenset[int]) -> tuple[int, Any]:
        """Judge the v2 candidate at ``buf[k]`` (sync already matched).

        Returns ``(_NEED_MORE, None)``, ``(_BAD, None)`` for an implausible header, or
        ``(end, (crc_ok, type, seq, t_us, rows, cols, payload))``.
        """
        n_buf = len(buf)
        if n_buf - k < HEADER_SIZE:
            return (_BAD, None) if final else (_NEED_MORE, None)
        ver, typ, seq, t_raw, rows, cols, n = _HDR.unpack_from(buf, k + 2)
        if ver != VERSION or typ not in accept or n > MAX_PAYLOAD:
            return _BAD, None
        if typ == PacketType.PSM:
            if rows < 1 or cols < 1 or n != 2 * rows * cols:
                return _BAD, None
        elif typ == PacketType.IMU:
            if rows < 1 or cols < 1 or n != 4 * rows * cols:
                return _BAD, None
        elif rows or cols:                      # a reply has rows = cols = 0
            return _BAD, None
        end = k + HEADER_SIZE + n + CRC_SIZE
        if end > n_buf:
            return (_BAD, None) if final else (_NEED_MORE, None)
        crc = self._span.crc(buf, self._base, self._base + k + 2, self._base + end - 2)
        crc_ok = crc == (buf[end - 2] | (buf[end - 1] << 8))
        payload = bytes(buf[k + HEADER_SIZE:end - 2]) if crc_ok else b""
        return end, (crc_ok, typ, seq, t_raw, rows, cols, payload)

    @abstractmethod
    def _process(self, events: list[Event], final: bool) -> None:
        """Decode what the buffer holds into ``events`` (each framing its own)."""


_REPLY_ONLY = frozenset({PacketType.REPLY})


class _V1Base(_Decoder):
    """v1 framing: ``FF FF | payload | check``, plus interleaved v2 replies."""

    _kind: str = "psm"
    #: A candidate ``j`` inside a run of 0xFF bytes with ``buf[j + _run_fails]`` still in the
    #: run cannot pass its check (and is a false start): the whole stretch is skipped at once.
    _run_fails: int = 3

    def __init__(self, shape: tuple[int, int], payload_size: int) -> None:
        super().__init__()
        self.shape = shape
        self._payload_size = payload_size
        self._frame_size = 2 + payload_size + 2
        self._run_end = 0       # stream offset where the last 0xFF run looked at ends

    @abstractmethod
    def _check(self, payload: bytes, check: int) -> NDArray[Any] | None:
        """The frame's data if ``payload`` passes its check, else None."""

    def _may_pass(self, buf: bytearray, k: int, end: int) -> bool:
        """O(1) or one scan: False when the candidate ``buf[k:end]`` cannot pass its check."""
        return buf[end - 1] <= 0x0F             # check word <= 4095

    @abstractmethod
    def _invalid_data(self) -> NDArray[Any]:
        """The data of an invalid row (zeros / NaN)."""

    def _process(self, events: list[Event], final: bool) -> None:
        buf = self._buf
        pos = self._pos
        size = self._frame_size
        search = _MARKERS.search
        while True:
            n_buf = len(buf)
            m = search(buf, pos)
            if m is None:
                keep = 1 if (not final and n_buf > pos and buf[-1] in (0xFF, 0xA5)) else 0
                self._skip(pos, n_buf - keep)
                pos = n_buf - keep
                break
            k = m.start()
            self._skip(pos, k)
            pos = k
            if buf[k] == 0xFF:
                end = k + size
                if end > n_buf:
                    if not final:
                        break
                    self._skip(k, k + 1)
                    pos = k + 1
                    continue
                self.candidates += 1
                data = None
                if self._may_pass(buf, k, end):
                    self.check_bytes += size - 2
                    data = self._check(bytes(buf[k + 2:end - 2]), buf[end - 2] | (buf[end - 1] << 8))
                if data is not None:
                    self.frames += 1
                    events.append(Frame(self._kind, data, True, None, None, self._base + k))
                    self._owned_end = max(self._owned_end, self._base + end)
                    pos = end
                    continue
                if buf[k + 2] == 0xFF:          # FF FF FF: false start, resync one byte on
                    if self._run_end <= self._base + k + 2:
                        m = _NOT_FF.search(buf, k + 2)
                        self._run_end = self._base + (m.start() if m else n_buf)
                    nxt = max(k + 1, self._run_end - self._base - self._run_fails)
                    self._skip(k, nxt)
                    pos = nxt
                    continue
                if self._base + k >= self._owned_end:   # no overlap with a reported span
                    self.invalid += 1
                    events.append(Frame(self._kind, self._invalid_data(), False, None, None, self._base + k))
                    self._owned_end = self._base + end
                else:
                    self._skip(k, k + 2)
                pos = k + 2
            else:
                end, info = self._v2_packet(buf, k, final, _REPLY_ONLY)
                if end == _NEED_MORE:
                    break
                self.candidates += 1
                if end == _BAD or not info[0]:
                    self._skip(k, k + 1)
                    pos = k + 1
                    continue
                _, _, seq, t_raw, _, _, payload = info
                events.append(self._reply(payload, seq, t_raw, k))
                self._owned_end = max(self._owned_end, self._base + end)
                pos = end
        self._pos = pos


class V1Decoder(_V1Base):
    """Incremental decoder of a PSM v1 stream.

    Parameters
    ----------
    shape : (int, int)
        The mat's ``(R, C)`` (not on the wire).

    Notes
    -----
    A candidate at ``FF FF`` is valid when every cell is <= 4095, the check is <= 4095 and
    equals the cell sum mod 4096. Events are :class:`Frame` (``kind="psm"``, uint16
    ``(R, C)``) and :class:`Reply`. Typical throughput: some 10^5 frames of 16x16 per second.
    """

    _kind = "psm"

    def __init__(self, shape: tuple[int, int]) -> None:
        r, c = shape2(shape)
        super().__init__((r, c), 2 * r * c)
        self._zeros = np.zeros((r, c), dtype=np.uint16)
        self._zeros.setflags(write=False)

    def _may_pass(self, buf: bytearray, k: int, end: int) -> bool:
        """No ``FF FF`` after the marker and a check word <= 4095 (high bytes <= 0x0F)."""
        if buf[end - 1] > 0x0F:
            return False
        m = buf.find(b"\xff\xff", k + 2, end)
        self.check_bytes += (m + 2 if m >= 0 else end) - (k + 2)
        return m < 0

    def _check(self, payload: bytes, check: int) -> NDArray[np.uint16] | None:
        if check > V1_MAX_COUNT:
            return None
        cells = np.frombuffer(payload, dtype="<u2")
        if int(cells.max()) > V1_MAX_COUNT or (int(cells.sum()) & 0xFFF) != check:
            return None
        return cells.astype(np.uint16).reshape(self.shape)

    def _invalid_data(self) -> NDArray[np.uint16]:
        return self._zeros


class ImuV1Decoder(_V1Base):
    """Incremental decoder of a spine-IMU v1 stream (15 float32 angles per frame).

    Float bytes may contain ``FF FF``, so resynchronisation relies on the check (sum of the
    30 payload uint16 words mod 4096, and <= 4095). Events are :class:`Frame`
    (``kind="imu"``, float32 degrees, shape (5, 3), NaN when invalid) and :class:`Reply`.

    Limitation of the thesis framing, not of this reader: the check cannot see an error in
    bits 12-15 of a payload word (floats do not forbid them, unlike 12-bit counts), nor a
    shifted candidate that happens to sum right (about 1 in 65536); such a sample decodes
    as valid with wrong angles. Use v2 (CRC-16) where that matters.
    """

    _kind = "imu"
    _run_fails = 2 + 4 * IMU_SHAPE[0] * IMU_SHAPE[1] + 1    # the check's high byte

    def __init__(self) -> None:
        super().__init__(IMU_SHAPE, 4 * IMU_SHAPE[0] * IMU_SHAPE[1])
        self._nan = np.full(IMU_SHAPE, np.nan, dtype=np.float32)
        self._nan.setflags(write=False)

    def _check(self, payload: bytes, check: int) -> NDArray[np.float32] | None:
        if check > V1_MAX_COUNT or (int(np.frombuffer(payload, dtype="<u2").sum()) & 0xFFF) != check:
            return None
        return np.frombuffer(payload, dtype="<f4").astype(np.float32).reshape(IMU_SHAPE)

    def _invalid_data(self) -> NDArray[np.float32]:
        return self._nan


_V2_TYPES = frozenset({PacketType.PSM, PacketType.IMU, PacketType.REPLY})


class V2Decoder(_Decoder):
    """Incremental decoder of a v2 stream (PSM and IMU frames, replies).

    A header is trusted only within the limits of docs/protocol.md (version 2, type 0x01,
    0x02 or 0x11, ``n <= 8192``, ``n == 2*R*C`` / ``4*R*C`` with ``R, C >= 1`` for frames,
    ``R = C = 0`` for a reply); otherwise its first byte is garbage. A frame with a
    plausible header and a bad CRC is an invalid :class:`Frame` (``seq``/``t_us`` None)
    unless it starts inside the span of a reported row or reply or names another shape
    than the last valid frame of its type (then its first byte is garbage); before the
    first valid frame its shape is its header's, untrusted. A gap in ``seq`` not filled by
    invalid rows emits a :class:`Gap` and adds to ``dropped``.
    """

    def __init__(self) -> None:
        super().__init__()
        self._last_seq: int | None = None
        self._invalid_since = 0
        self._shapes: dict[int, tuple[int, int]] = {}   # packet type -> shape of its last valid frame

    def _process(self, events: list[Event], final: bool) -> None:
        buf = self._buf
        pos = self._pos
        while True:
            n_buf = len(buf)
            k = buf.find(SYNC, pos)
            if k < 0:
                keep = 1 if (not final and n_buf > pos and buf[-1] == 0xA5) else 0
                self._skip(pos, n_buf - keep)
                pos = n_buf - keep
                break
            if k > pos:
                self._skip(pos, k)
                pos = k
            end, info = self._v2_packet(buf, k, final, _V2_TYPES)
            if end == _NEED_MORE:
                break
            self.candidates += 1
            if end == _BAD:
                self._skip(k, k + 1)
                pos = k + 1
                continue
            crc_ok, typ, seq, t_raw, rows, cols, payload = info
            if not crc_ok:
                if self._is_row(typ, rows, cols, k):
                    self.invalid += 1
                    self._invalid_since += 1
                    if typ == PacketType.PSM:
                        data = np.zeros((rows, cols), dtype=np.uint16)
                        kind = "psm"
                    else:
                        data = np.full((rows, cols), np.nan, dtype=np.float32)
                        kind = "imu"
                    events.append(Frame(kind, data, False, None, None, self._base + k))
                    self._owned_end = self._base + end
                else:
                    self._skip(k, k + 1)
                pos = k + 1
                continue
            self._owned_end = max(self._owned_end, self._base + end)
            pos = end
            if typ == PacketType.REPLY:
                events.append(self._reply(payload, seq, t_raw, k))
                continue
            if self._last_seq is not None:
                gap = (seq - self._last_seq - 1) % _WRAP
                if gap < _HALF:
                    lost = gap - self._invalid_since
                    if lost > 0:
                        self.dropped += lost
                        events.append(Gap(lost, seq))
                else:
                    self.restarts += 1
            self._last_seq = seq
            self._invalid_since = 0
            self._shapes[typ] = (rows, cols)
            if typ == PacketType.PSM:
                data = np.frombuffer(payload, dtype="<u2").astype(np.uint16).reshape(rows, cols)
                kind = "psm"
            else:
                data = np.frombuffer(payload, dtype="<f4").astype(np.float32).reshape(rows, cols)
                kind = "imu"
            self.frames += 1
            events.append(Frame(kind, data, True, seq, self._unwrap(t_raw, frame=True), self._base + k))
        self._pos = pos

    def _is_row(self, typ: int, rows: int, cols: int, k: int) -> bool:
        """Whether the bad-CRC packet at ``buf[k]`` is an invalid row (see the class docstring)."""
        if typ == PacketType.REPLY or self._base + k < self._owned_end:
            return False
        return self._shapes.get(typ, (rows, cols)) == (rows, cols)


def decode_v2(data: bytes | bytearray | memoryview, kind: Literal["psm", "imu"] = "psm") -> dict[str, Any]:
    """Decode a whole v2 recording of one frame shape into arrays.

    Parameters
    ----------
    data : bytes-like
        The stream.
    kind : {"psm", "imu"}
        Which frames to keep (the other kind, and replies, are ignored).

    Returns
    -------
    dict
        ``frames`` (N, R, C) uint16 counts or float32 degrees (0 / NaN in invalid rows),
        ``valid`` (N,) bool, ``seq`` (N,) int64 (-1 when invalid), ``t_us`` (N,) int64
        unwrapped device time in microseconds (-1 when invalid), and ``dropped`` (int, from
        the seq gaps). The shape is the first valid frame's (the first invalid row's when
        none is valid); an invalid row of another shape is left out, the shape of a packet
        that failed its CRC being untrusted. N = 0 gives shape (0, 0, 0).

    Raises
    ------
    ValueError
        Valid frames of that kind with different shapes.
    """
    if kind not in ("psm", "imu"):
        raise ValueError(f"kind must be 'psm' or 'imu', got {kind!r}")
    dec = V2Decoder()
    events = dec.feed(data)
    events += dec.finish()
    rows = [e for e in events if isinstance(e, Frame) and e.kind == kind]
    shape = next((e.data.shape for e in rows if e.valid), rows[0].data.shape if rows else (0, 0))
    if any(e.valid and e.data.shape != shape for e in rows):
        raise ValueError("the recording holds valid frames of different shapes")
    rows = [e for e in rows if e.data.shape == shape]
    dtype = np.uint16 if kind == "psm" else np.float32
    frames = np.empty((len(rows), *shape), dtype=dtype)
    valid = np.empty(len(rows), dtype=bool)
    seq = np.full(len(rows), -1, dtype=np.int64)
    t_us = np.full(len(rows), -1, dtype=np.int64)
    for i, e in enumerate(rows):
        frames[i] = e.data
        valid[i] = e.valid
        if e.valid:
            seq[i] = e.seq
            t_us[i] = e.t_us
    return {"frames": frames, "valid": valid, "seq": seq, "t_us": t_us, "dropped": dec.dropped}


def decode_v1(data: bytes | bytearray | memoryview,
              shape: tuple[int, int]) -> tuple[NDArray[np.uint16], NDArray[np.bool_]]:
    """Decode a v1 PSM byte stream (a recording, or what a port delivered).

    Parameters
    ----------
    data : bytes-like
        The stream; it may start and end mid-frame and contain garbage, v2 reply packets
        and corrupted frames.
    shape : (int, int)
        The mat's ``(R, C)`` (not on the wire).

    Returns
    -------
    frames : ndarray of uint16, shape (N, R, C)
        ADC counts, one row per frame found; the cells of invalid rows are 0.
    valid : ndarray of bool, shape (N,)
        False for a frame whose check failed (kept so that the time base is preserved).

    Notes
    -----
    The same algorithm as :class:`~psmat.protocol.V1Decoder` (which also keeps counters):
    a frame starts at ``0xFF 0xFF``; after a failed check the reader resyncs on the next
    marker. Frames whose marker was destroyed cannot be seen and are absent.
    """
    dec = V1Decoder(shape)
    events = dec.feed(data)
    events += dec.finish()
    return _stack(events, dec.shape, np.uint16)


def _stack(events: list[Any], shape: tuple[int, int], dtype: Any) -> tuple[NDArray[Any], NDArray[np.bool_]]:
    rows = [e for e in events if isinstance(e, Frame)]
    frames = np.empty((len(rows), *shape), dtype=dtype)
    valid = np.empty(len(rows), dtype=bool)
    for i, e in enumerate(rows):
        frames[i] = e.data
        valid[i] = e.valid
    return frames, valid


def decode_imu_v1(data: bytes | bytearray | memoryview) -> tuple[NDArray[np.float32], NDArray[np.bool_]]:
    """Decode a v1 spine-IMU stream.

    Returns
    -------
    angles : ndarray of float32, shape (N, 5, 3)
        Degrees; NaN in invalid rows.
    valid : ndarray of bool, shape (N,)
    """
    dec = ImuV1Decoder()
    events = dec.feed(data)
    events += dec.finish()
    return _stack(events, IMU_SHAPE, np.float32)

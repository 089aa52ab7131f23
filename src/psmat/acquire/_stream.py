"""One decoder interface over the three devices' wire formats.

:class:`StreamDecoder` wraps :class:`~psmat.protocol.V1Decoder`,
:class:`~psmat.protocol.ImuV1Decoder`, :class:`~psmat.protocol.V2Decoder`,
:class:`~psmat.protocol.CsvDecoder` (a do-it-yourself mat's text) or
:class:`~psmat.protocol.DaqLineDecoder` and turns their events into rows (frame, valid,
seq, device time), replies and v2 sequence gaps, with cumulative counters that survive a
protocol switch or a reconnection (each of which starts a fresh protocol decoder).
"""

from __future__ import annotations

import copy
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
from numpy.typing import NDArray

from ..protocol import (IMU_SHAPE, DAQ_SENSORS, CsvDecoder, DaqLineDecoder, DaqMalformed, DaqSample, Frame, Gap,
                        ImuV1Decoder, Opcode, Reply, Status, V1Decoder, V2Decoder)

__all__ = ["Kind", "Row", "StreamDecoder", "default_shape", "frame_dtype"]

Kind = Literal["psm", "daq", "imu"]

_KINDS = ("psm", "daq", "imu")
_REPLY_OVERHEAD = 16 + 2 + 2   # header + opcode/status + CRC: a reply is this + len(text) bytes


def default_shape(kind: str) -> tuple[int, ...]:
    """Frame shape of a device kind: (16, 16) PSM, (5, 3) IMU, (10,) material DAQ."""
    return {"psm": (16, 16), "imu": IMU_SHAPE, "daq": (DAQ_SENSORS,)}[kind]


def frame_dtype(kind: str) -> np.dtype:
    """Frame dtype: uint16 counts (PSM, DAQ) or float32 degrees (IMU)."""
    return np.dtype(np.float32 if kind == "imu" else np.uint16)


@dataclass(frozen=True, slots=True, eq=False)
class Row:
    """One decoded row of the time series (see :class:`~psmat.acquire.FrameBatch`)."""

    data: NDArray[Any]
    valid: bool
    seq: int
    device_time_us: int


_COUNTERS = ("bytes_in", "frames", "invalid", "skipped", "dropped", "replies", "restarts")


class StreamDecoder:
    """Decode a device's byte stream into rows, replies and gaps.

    Parameters
    ----------
    kind : {"psm", "daq", "imu"}
        The device.
    protocol : {1, 2, "csv"}
        Frame format (ignored for the text DAQ); ``"csv"`` (a PSM only): the text lines of a
        do-it-yourself mat (docs/protocol.md, "csv"), no commands, no replies.
    shape : tuple of int
        Expected frame shape; v2 frames of another shape or kind are discarded and counted
        in ``mismatched`` only (not in ``frames``/``invalid``).
    bits : int
        ADC resolution of a csv mat (1 ... 16): a count above ``2**bits - 1`` makes its frame
        invalid. Unused by the binary protocols.

    Attributes
    ----------
    counters : dict
        Cumulative ``bytes_in``, ``frames`` (valid), ``invalid``, ``skipped`` (garbage
        bytes), ``dropped`` (every v2 ``seq`` gap seen, also before anything was buffered;
        the :class:`~psmat.protocol.Gap` events say where), ``replies``, ``restarts`` (v2
        ``seq`` went backwards), ``mismatched``; see :attr:`counters`.
    """

    def __init__(self, kind: str, protocol: int | str, shape: tuple[int, ...], *, bits: int = 12) -> None:
        if kind not in _KINDS:
            raise ValueError(f"kind must be one of {_KINDS}, got {kind!r}")
        if protocol not in (1, 2, "csv") or isinstance(protocol, bool):
            raise ValueError(f"protocol must be 1, 2 or 'csv', got {protocol!r}")
        if protocol == "csv" and kind != "psm":
            raise ValueError(f"the csv protocol is a psm mat's, not a {kind}'s")
        self.kind = kind
        self.protocol: int | str = protocol
        self.shape = tuple(shape)
        self.bits = int(bits)
        self._base = dict.fromkeys(_COUNTERS, 0)
        self._base_reasons: dict[str, int] = {}
        self._mismatched_valid = 0
        self._mismatched_invalid = 0
        self._pending_protocol: int | None = None
        self._dec: Any = self._new_decoder()
        invalid = np.full(self.shape, np.nan, np.float32) if kind == "imu" else np.zeros(self.shape, np.uint16)
        invalid.setflags(write=False)
        self._invalid = invalid

    def _new_decoder(self) -> Any:
        if self.kind == "daq":
            return DaqLineDecoder(n_sensors=self.shape[0])
        if self.protocol == "csv":
            # each decoder reads a port from its opening: a first line or block cut by it is skipped bytes
            return CsvDecoder(self.shape, self.bits, opened=True)  # type: ignore[arg-type]
        if self.protocol == 2:
            return V2Decoder()
        return V1Decoder(self.shape) if self.kind == "psm" else ImuV1Decoder()

    # -- counters ------------------------------------------------------------------------
    @property
    def counters(self) -> dict[str, int]:
        """Cumulative counters (see the class docstring)."""
        cur = self._current()
        out = {k: self._base[k] + cur[k] for k in _COUNTERS}
        out["frames"] -= self._mismatched_valid
        out["invalid"] -= self._mismatched_invalid
        out["mismatched"] = self._mismatched_valid + self._mismatched_invalid
        return out

    @property
    def invalid_reasons(self) -> dict[str, int]:
        """Invalid rows by reason, cumulative (a csv mat's decoder: :data:`psmat.protocol.CSV_REASONS`;
        empty for the binary protocols, whose invalid rows all failed their checksum)."""
        out = dict(self._base_reasons)
        for k, n in getattr(self._dec, "reasons", {}).items():
            out[k] = out.get(k, 0) + n
        return {k: n for k, n in out.items() if n}

    def _current(self) -> dict[str, int]:
        d = self._dec
        if self.kind == "daq":
            return {"bytes_in": d.bytes_in, "frames": d.samples, "invalid": d.malformed, "skipped": 0,
                    "dropped": 0, "replies": 0, "restarts": 0}
        return d.stats

    def _retire(self) -> None:
        cur = self._current()
        for k in _COUNTERS:
            self._base[k] += cur[k]
        self._base_reasons = self.invalid_reasons

    # -- decoding ------------------------------------------------------------------------
    def expect_protocol_switch(self, protocol: int) -> None:
        """A SET_PROTOCOL command was sent: switch decoders when its OK reply is seen."""
        self._pending_protocol = protocol

    def cancel_protocol_switch(self) -> None:
        """Forget a pending switch (its command failed)."""
        self._pending_protocol = None

    def reset(self) -> list[Row | Reply | Gap]:
        """End of one connection: judge held bytes, then start a fresh decoder (counters kept), also when
        judging them raised: the next connection never continues this one's state (its clock, its sequence)."""
        try:
            return self._convert(self._dec.finish())
        finally:
            self._retire()
            self._dec = self._new_decoder()

    def feed(self, chunk: bytes) -> list[Row | Reply | Gap]:
        """Decode a chunk; return its rows, replies and gaps (v2 frames lost just before the next row), in order."""
        if self._pending_protocol is not None and self.kind != "daq":
            return self._feed_switching(chunk)
        return self._convert(self._dec.feed(chunk))

    def _feed_switching(self, chunk: bytes) -> list[Row | Reply | Gap]:
        """Feed while a SET_PROTOCOL reply is awaited: bytes after it go to a new decoder.

        A trial copy of the decoder finds where the reply ends; the real decoder is then fed
        exactly up to there (so its counters do not include the new format's bytes).
        """
        start = self._dec.bytes_in
        trial = copy.deepcopy(self._dec)
        events = trial.feed(chunk)
        end = None
        for ev in events:
            if isinstance(ev, Reply) and ev.opcode == Opcode.SET_PROTOCOL:
                if ev.status == Status.OK:
                    end = ev.offset + _REPLY_OVERHEAD + len(ev.text) - start
                else:
                    self._pending_protocol = None
                break
        if end is None or not 0 <= end <= len(chunk):
            self._dec = trial
            return self._convert(events)
        out = self._convert(self._dec.feed(chunk[:end]))
        if not any(isinstance(e, Reply) and e.opcode == Opcode.SET_PROTOCOL for e in out):
            out += self._convert(self._dec.finish())   # a candidate held the reply back
        self._retire()
        self.protocol, self._pending_protocol = self._pending_protocol, None  # type: ignore[assignment]
        self._dec = self._new_decoder()
        return out + self._convert(self._dec.feed(chunk[end:]))

    def _convert(self, events: list[Any]) -> list[Row | Reply | Gap]:
        out: list[Row | Reply | Gap] = []
        for ev in events:
            if isinstance(ev, Frame):
                if ev.kind != self.kind or ev.data.shape != self.shape:
                    if ev.valid:
                        self._mismatched_valid += 1
                    else:
                        self._mismatched_invalid += 1
                    continue
                if ev.valid:
                    seq = -1 if ev.seq is None else int(ev.seq)
                    t = -1 if ev.t_us is None else int(ev.t_us)
                    out.append(Row(ev.data, True, seq, t))
                else:
                    out.append(Row(self._invalid, False, -1, -1))
            elif isinstance(ev, (Reply, Gap)):
                out.append(ev)
            elif isinstance(ev, DaqSample):
                out.append(Row(ev.counts.astype(np.uint16), True, -1, -1))
            elif isinstance(ev, DaqMalformed):
                out.append(Row(self._invalid, False, -1, -1))
        return out

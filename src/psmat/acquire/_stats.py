"""Counters of a :class:`~psmat.acquire.Device`: what arrived, what was lost and where."""

from __future__ import annotations

from dataclasses import dataclass, field

__all__ = ["DeviceStats"]


@dataclass(frozen=True)
class DeviceStats:
    """Counters of a :class:`Device` (a snapshot; all cumulative since opening).

    Attributes
    ----------
    frames : int
        Valid frames decoded.
    invalid : int
        Rows that failed their checksum/CRC (or malformed DAQ lines); kept as invalid rows.
    dropped_wire : int
        Frames the device sent that never arrived: v2 ``seq`` gaps between two buffered
        rows (a gap before the first frame buffered after :meth:`Device.start`, e.g. frames
        a device streaming from power-up dropped while nobody read it, is not a loss of what
        was received); 0 for v1 and the DAQ, which cannot tell.
    dropped_buffer : int
        Frames overwritten in the ring buffer because nobody read them in time.
    skipped_bytes : int
        Garbage bytes skipped while resynchronising.
    replies : int
        Command replies received.
    reconnects : int
        Successful re-openings of the port after it vanished.
    ignored : int
        Frames decoded while not started (not buffered).
    mismatched : int
        v2 frames of another shape or kind than the device's (discarded).
    bytes_in : int
        Bytes read from the port.
    buffered : int
        Frames waiting in the ring buffer now.
    connected : bool
        Whether the port is open and readable now.
    last_error : str or None
        The last link or recording problem, as text.
    invalid_reasons : dict of str to int
        ``invalid`` by reason, for a csv mat (:data:`psmat.protocol.CSV_REASONS`: ``range``, a count
        above what its bits hold; ``count``, another number of counts than the shape's; ...); empty
        otherwise.
    lost_at : float or None
        While the port is lost (a device that reconnects): when it was lost (s since 1970, on the
        device's host clock, that of its frames' ``host_time_s``); None while connected.
    last_gap : tuple of float or None
        The last time the port was lost and found again: (when it was lost, s since 1970 on the same
        clock; how long it stayed away, s); None if it never came back after being lost.
    """

    frames: int
    invalid: int
    dropped_wire: int
    dropped_buffer: int
    skipped_bytes: int
    replies: int
    reconnects: int
    ignored: int
    mismatched: int
    bytes_in: int
    buffered: int
    connected: bool
    last_error: str | None
    invalid_reasons: dict[str, int] = field(default_factory=dict)
    lost_at: float | None = None
    last_gap: tuple[float, float] | None = None

"""What a serial device's counters say went wrong, in one line each, with what to check: the csv
decoder's invalid rows by reason, a device that gave no frame at all, and a port lost and found again.
Said by ``psmat record`` after a recording and shown by the lab app while the device runs."""

from __future__ import annotations

import time
from typing import Any

__all__ = ["invalid_line", "silence_line", "link_line"]


#: invalid rows below this share of all rows are a line's noise, not a setting to check
NOISE_SHARE = 0.01


def invalid_line(reasons: dict[str, int], dev: Any, rows: int | None = None, losses: int = 0) -> str | None:
    """``invalid rows by reason, since the port opened: range 2990: ...; count 3: ...``: a csv mat's invalid
    rows by reason, most first, the usual slips said (a board whose ADC is wider than the profile's bits,
    another shape, another baud rate); None without any, and, given ``rows`` (valid and invalid since the
    port opened), for at most one per loss of the port (``losses``: the line being sent when the port
    vanished is cut; the line cut by an opening is no row, :class:`psmat.protocol.CsvDecoder`'s
    ``opened``) or fewer than :data:`NOISE_SHARE` of them."""
    invalid = sum(reasons.values())
    if not invalid or (rows is not None and (invalid <= losses or invalid < NOISE_SHARE * rows)):
        return None
    bits, (n_rows, n_cols) = int(getattr(dev, "bits", 0) or 0), dev.shape[:2]
    said = {"range": f"counts above {2 ** bits - 1}, the most {bits} bits hold: is the board's ADC wider (the "
                     "profile's bits, --bits)?",
            "count": f"lines of another number of counts than {n_rows}x{n_cols}: is the shape right (--shape)?",
            "token": "a field that is not a count (text among the counts, or a board at another baud rate)"}
    return "invalid rows by reason, since the port opened: " + "; ".join(
        f"{k} {n}" + (f": {said[k]}" if k in said else "")
        for k, n in sorted(reasons.items(), key=lambda kv: -kv[1]) if n)


def silence_line(bytes_in: int, dev: Any) -> str | None:
    """Why a serial device gave no frame at all, valid or not, with what to check (None for an LSL stream,
    which has no port of its own)."""
    if not hasattr(dev, "baudrate"):
        return None
    port = dev.port
    if bytes_in == 0:
        return (f"no byte came from {port}: is the board running and sending (a do-it-yourself mat: its sketch "
                "uploaded, Serial.begin called), and is this its port?")
    proto = dev.protocol if dev.protocol == "csv" else f"v{dev.protocol}"
    return (f"{bytes_in} bytes came from {port} and none formed a frame of the {proto} protocol: does the board send "
            f"at {dev.baudrate} baud (its Serial.begin rate; a profile's baudrate), and speak --protocol {proto}?")


def link_line(stats: Any, dev: Any, now: float | None = None) -> str | None:
    """A reconnecting device's lost port, while it is lost (since when, that it is being re-opened, what to
    check) or after it came back (when and for how long it was away: what a recording running then lacks);
    None for a device that never lost its port or does not reconnect. ``now``: s since 1970 on the clock of
    ``stats.lost_at`` (default: the device's clock now)."""
    if not getattr(dev, "reconnect", False):
        return None
    port, lost_at, gap = dev.port, getattr(stats, "lost_at", None), getattr(stats, "last_gap", None)
    if lost_at is not None:
        if now is None:
            clock = getattr(dev, "clock", None)
            now = clock.now() if clock is not None else time.time()
        away = max(0.0, now - lost_at)
        return (f"{port} is lost since {_clock(lost_at)} ({away:.0f} s): psmat re-opens it every "
                f"{getattr(dev, 'reconnect_max_delay_s', 2.0):g} s at most - is the board's USB cable plugged in and "
                "the board powered? Frames resume when it is back (a recording running now keeps its file)")
    if gap is not None:
        n = int(getattr(stats, "reconnects", 1))
        return (f"{port} was lost and found again {n} time{'s' if n != 1 else ''} since it opened, the last at "
                f"{_clock(gap[0])} for {gap[1]:.1f} s: a recording running then has no frames for that time")
    return None


def _clock(t: float) -> str:
    """``t`` (s since 1970) as this computer's time of day."""
    return time.strftime("%H:%M:%S", time.localtime(t))

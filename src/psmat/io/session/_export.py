"""A session for people and other programs: a CSV export and a text summary."""

from __future__ import annotations

import csv
import math
import os
import time
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from .._frame_times import clock_restarts, host_gaps
from ._counts import row_counts
from ._layout import COUNTER_NAMES, Session
from ._reader import load_session

_IMU_ANGLES = ("heading", "roll", "pitch")


def _cell_names(kind: str, shape: tuple[int, ...]) -> list[str]:
    if kind == "imu":
        return [f"s{k}_{a}_deg" for k in range(shape[0]) for a in _IMU_ANGLES[: shape[1]]]
    if kind == "daq":
        return [f"s{k}_count" for k in range(shape[0])]
    if kind == "lsl":
        return [f"ch{k}" for k in range(shape[0])]
    r, c = shape
    if kind == "pressure":  # imported frames in kPa, not counts
        return [f"c_{i}_{p}_kpa" for i in range(r) for p in range(c)]
    return [f"c_{i}_{p}" for i in range(r) for p in range(c)]


def stream_csv_path(path: str | os.PathLike[str], name: str) -> Path:
    """Where :func:`export_csv` writes stream ``name`` of a session exported to ``path``: ``STEM.NAME.SUFFIX``."""
    p = Path(path)
    return p.with_name(f"{p.stem}.{name}{p.suffix}")


def export_csv(session: Session | str | os.PathLike[str], path: str | os.PathLike[str], *,
               missing: str | None = None) -> Path:
    """Write one CSV row per frame: ``time_s, valid, seq``, then the frame values; return ``path``.

    Cell columns are ``c_{i}_{p}`` (row-major) for a mat, ``s{k}_{heading|roll|pitch}_deg``
    for the IMUs, ``s{k}_count`` for the material DAQ, ``ch{k}`` for an LSL stream. ``valid`` is 1/0; ``seq`` is empty
    when unknown. Values are written exactly (integers; shortest round-trip floats).
    ``missing``: if given (e.g. ``""``), the cells of invalid frames are written as this
    string instead of the stored placeholder values. Each stream of a multi-device session
    goes to a CSV of its own, :func:`stream_csv_path` (``s.csv`` → ``s.imu.csv``), its
    ``time_s`` on the same host clock.
    """
    s = session if isinstance(session, Session) else load_session(session)
    out = Path(path)
    _write_csv(s, out, missing)
    for name, st in s.streams.items():
        _write_csv(st, stream_csv_path(out, name), missing)
    return out


def _write_csv(s: Session, out: Path, missing: str | None) -> None:
    flat = s.counts.reshape(s.n_frames, -1)
    is_float = flat.dtype.kind == "f"
    seq = s.seq
    with open(out, "w", newline="", encoding="utf-8") as fh:
        w = csv.writer(fh, lineterminator="\n")
        w.writerow(["time_s", "valid", "seq", *_cell_names(s.kind, s.frame_shape)])
        ncol = flat.shape[1]
        for k in range(s.n_frames):
            head = [repr(float(s.host_time_s[k])), int(s.valid[k]),
                    "" if seq is None or seq[k] < 0 else int(seq[k])]
            if missing is not None and not s.valid[k]:
                w.writerow(head + [missing] * ncol)
            elif is_float:
                w.writerow(head + [np.format_float_positional(x, unique=True, trim="-") for x in flat[k]])
            else:
                w.writerow(head + flat[k].tolist())


def _kv(d: Mapping[str, Any]) -> str:
    return ", ".join(f"{k}={v}" for k, v in d.items()) if d else "(none)"


def _frame_lines(s: Session, pad: str) -> list[str]:
    """Frames, rate, validity, counters, sequence and device clock of one device."""
    n = s.n_frames
    rate = s.rate_hz
    lines = [
        f"{pad}frames        {n}, duration {s.duration_s:.3f} s, rate "
        + (f"{rate:.2f} Hz (from host times)" if math.isfinite(rate) else "n/a")
    ]
    rc = row_counts(s)  # the one definition, shared with psmat record's summary (._counts)
    pct = 100.0 * rc.invalid / n if n else 0.0
    lines.append(f"{pad}invalid       {rc.invalid} frames ({pct:.2f} %)")
    lines.append(f"{pad}lost          " + ("unknown (no sequence numbers)" if rc.lost is None else
                                           f"{rc.lost} frames (sequence numbers with no row)"))
    c = s.counters
    counters = ", ".join(f"{k} {c.get(k, 0)}" for k in COUNTER_NAMES) if c else "unknown (damaged)"
    lines.append(f"{pad}counters      {counters} (as the reader counted while recording)")
    if rc.first_seq is not None:
        lines.append(f"{pad}seq           {rc.first_seq}..{rc.last_seq}"
                     + (f", {rc.restarts} restart(s) of the device's numbering" if rc.restarts else ""))
    v1 = _v1_limit(s)
    if v1:
        lines.append(f"{pad}check         {v1}")
    if s.device_time_us is not None:
        dev = s.device_time_us
        if (dev >= 0).sum() > 1:  # a box that restarted starts its clock again: a span per segment, summed
            segments = [g[g >= 0] for g in np.split(dev, clock_restarts(dev))]
            span = sum(int(g[-1] - g[0]) for g in segments) / 1e6
            lines.append(f"{pad}device clock  {span:.3f} s span"
                         + (f" in {len(segments)} segments (it started again {len(segments) - 1} time(s))"
                            if len(segments) > 1 else ""))
    if s.device_time_us is None or not (np.asarray(s.device_time_us) >= 0).any():
        host = np.asarray(s.host_time_s, np.float64)
        gaps = host_gaps(host)   # on the host clock: stretches without frames (docs/spec.md §5)
        if gaps.size:
            known = np.flatnonzero(np.isfinite(host))
            before = known[np.searchsorted(known, gaps) - 1]   # the stamped frame before each gap
            said = ", ".join(f"{float(host[g] - host[b]):.2f} s up to {_time_of_day(float(host[g]), s.utc_offset_s)}"
                             for g, b in zip(gaps, before))
            lines.append(f"{pad}gaps          {gaps.size} stretch{'es' if gaps.size > 1 else ''} of the host clock "
                         f"without frames: {said} (the processing cuts the clock there; the rate above counts "
                         f"{'them' if gaps.size > 1 else 'it'})")
    lines.append(f"{pad}device        {_kv(s.device)}")
    return lines


def _time_of_day(t: float, utc_offset_s: int | None) -> str:
    """``t`` (s since 1970) as the recording computer's time of day, or UTC's (said) without its offset."""
    if utc_offset_s is None:
        return time.strftime("%H:%M:%S UTC", time.gmtime(t))
    return time.strftime("%H:%M:%S", time.gmtime(t + utc_offset_s))


def _v1_limit(s: Session) -> str:
    """What the v1 framing's check cannot see (docs/protocol.md), for a session recorded with it; else ''."""
    proto = s.device.get("proto", s.device.get("protocol"))
    if str(proto).lower() == "csv":
        return ("protocol csv: text lines without a checksum; a line is checked only for its count of numbers and "
                "their range (0 ... 2**bits - 1), so a digit changed on the wire is in the file marked valid "
                "(docs/protocol.md)")
    v1 = str(proto).lower() in ("1", "v1") or (s.kind in ("psm", "imu") and s.seq is None and s.n_frames > 0)
    if not v1 or s.kind not in ("psm", "imu"):
        return ""
    what = ("two cells swapped, or errors that cancel in the sum (the same bit set in one cell and cleared in "
            "another)" if s.kind == "psm" else "an error in bits 12-15 of a payload word, or errors that cancel "
            "in the sum")
    return (f"protocol v1: each frame's only check is the sum of its 16-bit words mod 4096, which cannot see "
            f"{what}; a frame so damaged on the wire is in the file marked valid (docs/protocol.md)")


def info(session: Session | str | os.PathLike[str]) -> str:
    """A human-readable summary of a session (or of the session file at a path), its streams listed after it."""
    s = session if isinstance(session, Session) else load_session(session)
    lines = [f"psmat session: {s.path if s.path is not None else '(in memory)'}"]
    state = "complete" if s.complete else "INTERRUPTED recording"
    if s.recovered:
        state += ", frames recovered from the journal"
    lines.append(f"  kind          {s.kind}, frame shape {s.frame_shape}, format v{s.format_version} ({state})")
    if s.created_utc:
        off = s.utc_offset_s
        lines.append(f"  created       {s.created_utc}" + ("" if off is None else
                     f" (the recording computer at UTC{'+' if off >= 0 else '-'}{abs(off) // 3600:02d}:"
                     f"{abs(off) % 3600 // 60:02d})"))
    lines += _frame_lines(s, "  ")
    if s.calibration is None:
        lines.append("  calibration   (none)")
    else:
        cal = {k: v for k, v in s.calibration.items() if not isinstance(v, (list, dict))}
        lines.append(f"  calibration   {_kv(cal)}")
    lines.append(f"  metadata      {_kv(s.metadata)}")
    if s.profile is not None:
        lines.append(f"  profile       {s.profile.get('name', '(unnamed)')} "
                     f"({_kv({k: v for k, v in s.profile.items() if k != 'name' and not isinstance(v, (list, dict))})})")
    if s.events:
        lines.append(f"  events        {len(s.events)}, host time {s.events[0][0]:.3f}..{s.events[-1][0]:.3f} s, "
                     f"first {s.events[0][1]!r}")
    if s.products:
        lines.append("  products")
        for name, p in sorted(s.products.items()):
            lines.append(f"    {name:<12}{p.data.shape} {p.data.dtype} [{p.unit}] params: {_kv(p.params)}")
    else:
        lines.append("  products      (none)")
    if s.streams:
        lines.append(f"  streams       {len(s.streams)} more device(s) on the same host clock")
        for name, st in s.streams.items():
            lines.append(f"  stream {name}: kind {st.kind}, frame shape {st.frame_shape}")
            lines += _frame_lines(st, "    ")
    for note in s.notes:
        lines.append(f"  note          {note}")
    return "\n".join(lines)

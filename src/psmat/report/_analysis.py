"""The numbers of one session's report: what was recorded, pressure, CoP, metrics, regions, conditions.

Every CoP trace goes through one preprocessing before its sway metrics (``params["preset"]``,
:func:`psmat.balance.preprocess`: SWARII to 25 Hz, 4th-order 10 Hz Butterworth forward and
backward), the mat's and the platform's alike; the 72 descriptors apply the same preset
themselves (:func:`psmat.balance.descriptors`). Missing frames (NaN CoP) are filled by linear
interpolation in time first.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..balance import Condition, conditions, cop, descriptors, ispgr, preprocess, romberg, romberg_role, sway
from ..io import load_session
from ..process import PressureRecord, session_pressure
from ..profile import session_profile
from ..regions import foot_masks, region_table, seat_masks
from ._item import ReportItem
from ._platform import PlatformResult, compare_platform

__all__ = ["SessionAnalysis", "ConditionRow", "analyse", "preprocessing_line", "filled", "sway_after"]


@dataclass
class ConditionRow:
    """One condition of a session cut by its markers (:func:`psmat.balance.conditions`)."""

    label: str
    role: str  # "EO", "EC" or "" (romberg_role)
    start_s: float  # from the session's first frame, s
    duration_s: float
    frames: int
    ispgr: str
    metrics: dict[str, float] = field(default_factory=dict)
    note: str = ""


@dataclass
class SessionAnalysis:
    """Everything the report shows for one session (:func:`analyse`)."""

    label: str
    path: Path
    recorded: list[tuple[str, str]]
    simulated: bool
    record: PressureRecord
    cop_cm: NDArray[np.float64]  # (T, 2) the mat's CoP, NaN on missing frames, cm
    mean_kpa: NDArray[np.float64]
    peak_kpa: NDArray[np.float64]
    duration_s: float
    rate_hz: float
    ispgr: str
    sway: dict[str, float]
    descriptors: dict[str, float]
    descriptors_note: str
    regions: Any  # psmat.regions.RegionResults or None
    regions_kind: str
    regions_note: str
    conditions: list[ConditionRow]
    conditions_note: str
    romberg: dict[str, float]
    romberg_note: str
    platform: PlatformResult | None
    platform_note: str
    starts_s: list[float] = field(default_factory=list)  # condition starts from the first frame, s (figure)


def preprocessing_line(preset: str | None) -> str:
    """One sentence: the preprocessing every CoP trace of the report went through."""
    if preset is None:
        return "none: metrics on the traces as recorded (missing frames interpolated linearly)"
    return (f"{preset}: missing frames interpolated linearly, then SWARII resampling to 25 Hz (window 1/25 s) "
            "and a 4th-order Butterworth low-pass at 10 Hz run forward and backward (zero phase); the same for "
            "the mat and the platform (psmat.balance.preprocess)")


def filled(t_s: NDArray[np.float64], c: NDArray[np.float64]) -> NDArray[np.float64]:
    """A (T, 2) trace with its NaN samples linearly interpolated in time (at least 2 finite samples)."""
    ok = np.all(np.isfinite(c), axis=1)
    if ok.sum() < 2:
        raise ValueError(f"{int(ok.sum())} frame(s) with a centre of pressure; at least 2 are needed")
    return np.column_stack([np.interp(t_s, t_s[ok], c[ok, k]) for k in range(2)])


def sway_after(t_s: NDArray[np.float64], c: NDArray[np.float64], preset: str | None) -> dict[str, float]:
    """The sway metrics (:func:`psmat.balance.sway`) of a filled trace after ``preset``'s preprocessing."""
    t, ml, ap = preprocess(t_s, c[:, 0], c[:, 1], preset=preset)
    fs = (t.size - 1) / (t[-1] - t[0])
    return sway(np.column_stack([ml, ap]), fs).as_dict()


def _recorded(s: Any, rec: PressureRecord, duration_s: float, rate_hz: float, missing: int) -> list[tuple[str, str]]:
    dev = s.device or {}
    meta = s.metadata or {}
    try:
        prof = session_profile(s)
        profile = f"{prof.name} ({prof.source})"
    except (ValueError, KeyError) as exc:
        profile = f"unknown ({exc})"
    R, C = s.frame_shape
    device = ", ".join(f"{k} {dev[k]}" for k in ("device", "serial", "fw", "protocol", "proto") if k in dev)
    rows = [("file", str(s.path)), ("kind", s.kind), ("device", device or "not recorded"), ("profile", profile),
            ("cells", f"{R} × {C}, pitch {rec.geometry.pitch_cm:g} cm"), ("recorded (UTC)", str(s.created_utc)),
            ("duration", f"{duration_s:.2f} s"), ("frames", str(s.n_frames)), ("frame rate", f"{rate_hz:.2f} Hz"),
            ("frames missing", f"{missing} ({100.0 * missing / max(s.n_frames, 1):.1f} %)"),
            ("pressure", rec.source)]
    rows += [(f"metadata: {k}", str(v)) for k, v in meta.items()]
    return rows


def _simulated(meta: dict[str, Any]) -> bool:
    """Whether the session's metadata says a simulator wrote it."""
    return bool(meta.get("simulated")) or "simulator" in meta or str(meta.get("operator", "")).startswith("psmat.synth")


def _seated(meta: dict[str, Any]) -> bool:
    """A sitting trial (seat regions) rather than a standing one (feet): the metadata say so."""
    words = {str(meta.get(k, "")).strip().lower() for k in ("study", "trial", "position", "posture")}
    return bool(words & {"posture", "seated", "sitting"})


def _regions(rec: PressureRecord, meta: dict[str, Any], threshold_kpa: float) -> tuple[Any, str, str]:
    seated = _seated(meta)
    kind = "seat (a seated trial: metadata)" if seated else "feet (a standing trial)"
    try:
        masks = (seat_masks if seated else foot_masks)(rec.pressure_kpa, rec.geometry, threshold_kpa=threshold_kpa)
        table = region_table(rec.pressure_kpa, masks, rec.geometry, t_s=rec.t_s, threshold_kpa=threshold_kpa)
    except ValueError as exc:
        return None, kind, f"no regions: {exc}"
    return table, kind, ""


def _events(item: ReportItem, s: Any) -> tuple[list[tuple[float, str]], str]:
    """The markers on the session's host clock, and where they came from."""
    if item.events is None:
        return list(s.events), "the session's markers"
    host0 = float(s.host_time_s[0])
    shift = host0 if item.events_from_start else 0.0
    where = "seconds from the first frame" if item.events_from_start else "the session's host clock"
    return [(float(t) + shift, str(lab)) for t, lab in item.events], f"markers given with the report ({where})"


def _conditions(item: ReportItem, s: Any, rec: PressureRecord, c: NDArray[np.float64],
                p: dict[str, Any]) -> tuple[list[ConditionRow], str, dict[str, float], str]:
    events, where = _events(item, s)
    host = np.asarray(s.host_time_s, np.float64)
    if not events:
        return [], f"no markers ({where}: none): the whole session is one condition", {}, ""
    # a marker before the first frame still names the condition running at it (as the study's
    # condition_spans do): cut on the span of frames and markers, then keep the frames' part
    lo, hi = float(host[0]), float(host[-1])
    times = [float(t) for t, _ in events]
    found = [Condition(c.label, max(c.start_s, lo), min(c.stop_s, hi))
             for c in conditions(events, min(lo, *times), max(hi, *times))]
    found = [c for c in found if c.stop_s > c.start_s]
    rows = []
    for k, cond in enumerate(found):
        last = k == len(found) - 1
        idx = (host >= cond.start_s) & ((host <= cond.stop_s) if last else (host < cond.stop_s))
        row = ConditionRow(label=cond.label or "(unmarked)", role=romberg_role(cond.label) or "",
                           start_s=cond.start_s - float(host[0]), duration_s=cond.stop_s - cond.start_s,
                           frames=int(idx.sum()), ispgr="")
        if row.frames >= 2:
            t = rec.t_s[idx]
            rate = 1.0 / float(np.median(np.diff(t)))  # as the session's: the median frame period
            row.ispgr = ispgr(row.duration_s, rate, p["ispgr_min_duration_s"], p["ispgr_min_rate_hz"])
            try:
                row.metrics = sway_after(t, filled(t, c[idx]), p["preset"])
            except ValueError as exc:
                row.note = f"no metrics: {exc}"
        else:
            row.note = f"{row.frames} frame(s): no metrics"
        rows.append(row)
    eo = next((r for r in rows if r.role == "EO" and r.metrics), None)
    ec = next((r for r in rows if r.role == "EC" and r.metrics), None)
    if eo is None or ec is None:
        return rows, f"{len(rows)} condition(s) from {where}", {}, "no Romberg quotient: needs an eyes-open and an " \
                                                                  "eyes-closed condition with metrics"
    note = f"Romberg quotient = eyes closed ({ec.label!r}) / eyes open ({eo.label!r}), the first of each"
    return rows, f"{len(rows)} condition(s) from {where}", romberg(eo.metrics, ec.metrics), note


def analyse(item: ReportItem, p: dict[str, Any]) -> SessionAnalysis:
    """The report's numbers for one session (module docstring); ``p`` the merged report parameters.

    Raises
    ------
    ValueError
        A session the report cannot use (another kind, fewer than two usable frames, ...), or a bad
        platform file; the message is one line.
    psmat.io.SessionFormatError, OSError
        The file cannot be read.
    """
    path = Path(item.session)
    s = load_session(path)
    rec = session_pressure(s, calibration=p["calibration"], method=p["method"], progress=False)
    t = rec.t_s
    if t.size < 2 or not np.all(np.diff(t) > 0):
        raise ValueError(f"{path.name}: its frame times do not increase")
    step = float(np.median(np.diff(t)))
    rate = 1.0 / step
    duration = float(t[-1] - t[0]) + step  # N frames of one period each: the sway metrics' N / fs
    c_raw = cop(rec.pressure_kpa, geometry=rec.geometry)
    c = filled(t, c_raw)
    usable = rec.pressure_kpa[rec.usable]
    if usable.shape[0] == 0:
        raise ValueError(f"{path.name}: no usable frame")
    missing = int((~rec.usable).sum())
    meta = s.metadata or {}
    sw = sway_after(t, c, p["preset"])
    try:
        desc, desc_note = descriptors(t, c[:, 0], c[:, 1], preset=p["preset"]), ""
    except ValueError as exc:
        desc, desc_note = {}, f"no descriptors: {exc}"
    regions, regions_kind, regions_note = _regions(rec, meta, p["threshold_kpa"])
    rows, cond_note, rom, rom_note = _conditions(item, s, rec, c, p)
    plat, plat_note = None, "no force-platform file"
    if item.platform is not None:
        plat = compare_platform(Path(item.platform), t, c, p)
        plat_note = ""
    return SessionAnalysis(
        label=item.label or path.name, path=path, recorded=_recorded(s, rec, duration, rate, missing),
        simulated=_simulated(meta), record=rec, cop_cm=c_raw, mean_kpa=np.nanmean(usable, axis=0),
        peak_kpa=np.nanmax(usable, axis=0), duration_s=duration, rate_hz=rate,
        ispgr=ispgr(duration, rate, p["ispgr_min_duration_s"], p["ispgr_min_rate_hz"]), sway=sw, descriptors=desc,
        descriptors_note=desc_note, regions=regions, regions_kind=regions_kind, regions_note=regions_note,
        conditions=rows, conditions_note=cond_note, romberg=rom, romberg_note=rom_note, platform=plat,
        platform_note=plat_note, starts_s=[r.start_s for r in rows] if rows else [],
    )


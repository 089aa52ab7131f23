"""The numbers of one session's report: what was recorded, pressure, CoP, metrics, regions, conditions.

Every CoP trace goes through one preprocessing before its sway metrics (``params["preset"]``,
:func:`psmat.balance.preprocess`: SWARII to 25 Hz, 4th-order 10 Hz Butterworth forward and
backward), the mat's and the platform's alike; the 72 descriptors apply the same preset
themselves (:func:`psmat.balance.descriptors`). Missing frames (NaN CoP) are filled by linear
interpolation in time first.

The conditions the markers cut a session into are on its frame clock (``session_pressure(...).t_s``),
the markers brought there from the host clock by :func:`psmat.balance.frame_clock` and cut by
:func:`psmat.balance.condition_spans`, as in a study: the same frames, the same durations.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..balance import (ISPGR_MIN_HZ, ISPGR_MIN_S, NEAR_S, POOR_ALIGNMENT_R, condition_spans, cop, describe_preset,
                       descriptors, frame_clock, inside, ispgr, off_the_clock, preprocess, romberg, romberg_role,
                       spread_question, sway)
from ..io import load_session
from ..process import PressureRecord, session_pressure
from ..profile import session_profile
from ..regions import foot_masks, region_table, seat_masks
from ._item import ReportItem
from ._platform import PlatformResult, compare_platform

__all__ = ["SessionAnalysis", "ConditionRow", "analyse", "preprocessing_line", "filled", "sway_after"]


@dataclass
class ConditionRow:
    """One condition of a session cut by its markers (:func:`psmat.balance.condition_spans`), on the
    frame clock (``session_pressure(...).t_s``), as the study's."""

    label: str
    role: str  # "EO", "EC" or "" (romberg_role)
    start_s: float  # from the session's first frame, s, frame clock
    duration_s: float  # s, frame clock
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
    starts_s: list[float] = field(default_factory=list)  # condition starts from the first frame, s, frame clock (figure)
    ispgr_min_duration_s: float = ISPGR_MIN_S  # the ISPGR check's limits used (s, Hz)
    ispgr_min_rate_hz: float = ISPGR_MIN_HZ


def preprocessing_line(preset: str | None) -> str:
    """One sentence: the preprocessing every CoP trace of the report went through."""
    if preset is None:
        return f"{describe_preset(None)}, missing frames interpolated linearly"
    return (f"missing frames interpolated linearly, then {describe_preset(preset)}; the same for the mat and the "
            "platform (psmat.balance.preprocess)")


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
    """The conditions on the frame clock ``rec.t_s``: the markers brought there from the host clock
    (:func:`psmat.balance.frame_clock`), cut to the recording (:func:`psmat.balance.condition_spans`),
    their frames picked by :func:`psmat.balance.inside` — as the study does."""
    events, where = _events(item, s)
    if not events:
        return [], f"no markers ({where}: none): the whole session is one condition", {}, ""
    host = np.asarray(s.host_time_s, np.float64)
    host = host[np.isfinite(host)]
    if item.events is not None and host.size and off_the_clock([e[0] for e in events], host[0], host[-1]):
        return [], (f"markers not used ({where}: none within {NEAR_S / 3600:g} h of the recording, so on another "
                    "clock; seconds from the first frame are --events-from-start): the whole session is one "
                    "condition"), {}, ""
    t = rec.t_s
    on_frames = frame_clock([e[0] for e in events], s.host_time_s, t)
    found = condition_spans([(float(x), e[1]) for x, e in zip(on_frames, events)], float(t[0]), float(t[-1]))
    if not found:
        return [], f"no condition inside the recording ({where}): the whole session is one condition", {}, ""
    rows = []
    for cond in found:
        idx = inside(t, cond, float(t[-1]))
        row = ConditionRow(label=cond.label, role=romberg_role(cond.label) or "", start_s=cond.start_s - float(t[0]),
                           duration_s=cond.duration_s, frames=int(idx.sum()), ispgr="")
        if row.frames >= 2:
            tc = t[idx]
            rate = 1.0 / float(np.median(np.diff(tc)))  # as the session's: the median frame period
            row.ispgr = ispgr(row.duration_s, rate, p["ispgr_min_duration_s"], p["ispgr_min_rate_hz"])
            try:
                row.metrics = sway_after(tc, filled(tc, c[idx]), p["preset"])
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
        plat_note = "" if not plat.poor else (
            f"Poor alignment: the correlation at the best lag is {plat.r:.2f}, below {POOR_ALIGNMENT_R:g}: the traces "
            + (f"share no sway. Is {plat.path.name} this session's platform file?" if plat.other_axes is None else
               f"align at {plat.other_axes[1]:.2f} with the platform's axes {plat.other_axes[0]}: they lie otherwise "
               f"than the mat's (psmat report --platform-axes={plat.other_axes[0]}).")
            + " The lag, Eu and the platform's numbers below are not comparable with the mat's.")
        if not plat.poor and plat.spread is not None and plat.spread.off:
            plat_note = (f"The platform's CoP spreads {plat.spread.ratio:.3g} times the mat's (about 1 expected): "
                         f"{spread_question(plat.path.name, plat.spread, plat.cop_from)} Eu and the platform's numbers "
                         "below are not comparable with the mat's.")
    return SessionAnalysis(
        label=item.label or path.name, path=path, recorded=_recorded(s, rec, duration, rate, missing),
        simulated=_simulated(meta), record=rec, cop_cm=c_raw, mean_kpa=np.nanmean(usable, axis=0),
        peak_kpa=np.nanmax(usable, axis=0), duration_s=duration, rate_hz=rate,
        ispgr=ispgr(duration, rate, p["ispgr_min_duration_s"], p["ispgr_min_rate_hz"]), sway=sw, descriptors=desc,
        descriptors_note=desc_note, regions=regions, regions_kind=regions_kind, regions_note=regions_note,
        conditions=rows, conditions_note=cond_note, romberg=rom, romberg_note=rom_note, platform=plat,
        platform_note=plat_note, starts_s=[r.start_s for r in rows] if rows else [],
        ispgr_min_duration_s=p["ispgr_min_duration_s"], ispgr_min_rate_hz=p["ispgr_min_rate_hz"],
    )


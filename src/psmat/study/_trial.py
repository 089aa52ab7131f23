"""One session of a balance study (thesis §3.2, docs/spec.md §7, §9): the mat through the one chain
(:func:`psmat.process.process_loaded`: its device clock, each frame stepped with its own period,
its stored circuit), every variant, aligned with the force platform, sway metrics and Eu per variant; the sway metrics of every row
after one preprocessing (``params["preprocess"]``), the 72 descriptors on request
(``params["descriptors"]``) and the ISPGR acquisition check (:mod:`psmat.study` (``_row_metrics.py``)).

:func:`process_trial` takes plain arguments and returns plain rows (and, with ``traces=True``,
the aligned CoP traces for the figures), so a worker process or a Dask worker runs it as is; it
never raises for a bad session — the rows carry a ``status``.
"""

from __future__ import annotations

import os
import warnings
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ..balance import (POOR_ALIGNMENT_R, SPREAD_MISMATCH, VARIANTS, align, check_spread, condition_spans, eu,
                       find_platform_axes, frame_clock, inside, ispgr, orient_platform, spread_question,
                       variant_traces)
from ._conditions import MIN_SAMPLES
from ..sensor import MPICreep
from ..units import n_from_kg
from ._row_metrics import columns, descriptor_values, sway_metrics

__all__ = ["METRICS", "COLUMNS", "process_trial", "DEFAULT_PARAMS", "Rows", "Traces"]

METRICS = ("sd_ml_cm", "sd_ap_cm", "range_ml_cm", "range_ap_cm", "path_cm", "velocity_cm_s", "area95_cm2",
           "mean_freq_hz")
#: ``condition``: "" for the whole trial, else the label of one condition of it (docs/spec.md §7 "Events,
#: conditions, Romberg"; an unmarked stretch before the first marker is "unmarked")
COLUMNS = ("subject", "trial", "variant", "condition") + METRICS + ("eu_cm", "eu_ml_cm", "eu_ap_cm", "lag_s", "r_align",
                                                        "factor", "frames", "frames_missing", "frames_unconverged",
                                                        "duration_s", "rate_hz", "ispgr", "status")
DEFAULT_PARAMS: dict[str, Any] = {
    "variants": list(VARIANTS),
    "method": "newton",  # IECM
    "pitch_cm": None,  # cm; None: the geometry of the session's profile (psmat.profile.session_profile)
    "cell_area_cm2": None,  # cm²; None: the cell area of that geometry (pitch²)
    "window_s": None,  # None: the whole overlap of mat and platform
    "max_lag_s": None,
    # how the platform's axes lie on the mat's (psmat.balance.PLATFORM_AXES): "x,y" as its file is loaded
    "platform_axes": "x,y",
    "align_on": "PROP",
    "sensor": None,  # MPICreep parameters (dict); None: the thesis' Table 2.11
    # the sway metrics of every row (FP and variants) after psmat.balance.preprocess with this preset
    # (SWARII to 25 Hz, 4th-order 10 Hz Butterworth forward-backward); None: on the raw traces
    "preprocess": "quijoux2021",
    "descriptors": None,  # "quijoux2021": the 72 descriptors (psmat.balance.descriptors) as extra columns
}


#: the status of every row of a trial whose platform file aligns with the mat at a correlation below
#: psmat.balance.POOR_ALIGNMENT_R: the file is another recording's, or the mat did not see the sway
POOR_ALIGNMENT = "poor alignment"
#: the status of every row of a trial whose platform CoP spreads beyond psmat.balance.SPREAD_MISMATCH
#: times the mat's either way (psmat.balance.check_spread): its file read in another unit, or not this trial's
PLATFORM_SPREAD = "platform spread"
#: the statuses that keep a trial's rows out of the summary while they keep their numbers, each a problem of the run
SUSPECT = (POOR_ALIGNMENT, PLATFORM_SPREAD)

_AXES_HINT = "study run --platform-axes="


def suggested_axes(status: str) -> str | None:
    """The platform axes a poor alignment's status names (those under which its trial aligns), or None."""
    k = status.find(_AXES_HINT) if POOR_ALIGNMENT in status else -1
    return None if k < 0 else status[k + len(_AXES_HINT):].split(")", 1)[0]


Rows = list[dict[str, Any]]
#: {"t_s": (N,) platform-clock times (s), "FP": (N, 2) cm, "<variant>": (N, 2) cm}, M-L then A-P
Traces = dict[str, np.ndarray]


def _row(p: dict[str, Any], subject: str, trial: str, variant: str, status: str, **values: Any) -> dict[str, Any]:
    row: dict[str, Any] = {c: np.nan for c in columns(COLUMNS, p)}
    row.update(subject=subject, trial=trial, variant=variant, condition="", status=status, ispgr="")
    row.update(values)
    return row


def _fill(t: np.ndarray, c: np.ndarray) -> np.ndarray:
    """Missing CoP samples (NaN) linearly interpolated in time from their neighbours."""
    ok = np.all(np.isfinite(c), axis=1)
    return np.column_stack([np.interp(t, t[ok], c[ok, k]) for k in range(2)])


def _metrics(t: np.ndarray, c: np.ndarray, fs: float, t_ref: np.ndarray | None, c_ref: np.ndarray | None,
             p: dict[str, Any]) -> dict[str, float]:
    """Sway metrics of c (after ``p["preprocess"]``), its descriptors when ``p["descriptors"]`` asks,
    and Eu against c_ref at the same times (both mean-removed, unfiltered: thesis eq. 3.1)."""
    out = sway_metrics(t, c, fs, p["preprocess"])
    if p["descriptors"] is not None:
        out.update(descriptor_values(t, c, p["descriptors"]))
    if t_ref is not None and c_ref is not None:
        ref = np.column_stack([np.interp(t, t_ref, c_ref[:, k]) for k in range(2)])
        a, b = c - c.mean(axis=0), ref - ref.mean(axis=0)
        out.update(eu_cm=eu(a, b), eu_ml_cm=eu(a[:, 0], b[:, 0]), eu_ap_cm=eu(a[:, 1], b[:, 1]))
    return out


def process_trial(session: str | os.PathLike[str], forceplate: str | os.PathLike[str] | None, subject: str,
                  trial: str, weight_kg: float | None, params: dict[str, Any] | None = None, *,
                  calibration: str | os.PathLike[str] | None = None,
                  traces: bool = False,
                  events: Sequence[tuple[float, str]] | None = None) -> Rows | tuple[Rows, Traces]:
    """Rows (one for FP and one per variant) of a session; ``status`` says what went wrong, if anything.

    Parameters
    ----------
    session, forceplate : path
        The mat session (``.h5``) and its force-platform CSV (None: no platform file).
    subject, trial : str
        Written into every row.
    weight_kg : float or None
        Body weight (kg) for SCHC's eq. 3.3; None: the SCHC variants get a status instead.
    params : dict, optional
        Overrides of :data:`DEFAULT_PARAMS`.
    calibration : path, optional
        A calibration file (``psmat calibrate``, JSON) of the box the session was recorded with,
        whose ``r_adc`` and ``r_mux`` replace those of the circuit stored in the session
        (:meth:`psmat.Circuit.calibrated`: its ``r_o``, ``v_ref`` and ``bits`` must agree);
        its serial must match the session's ``device["serial"]`` when both name one.
    traces : bool
        Also return the aligned traces: ``t_s`` the mat's frames inside the aligned window on
        the platform's clock (s), ``FP`` the platform's CoP interpolated at those times, and each
        computed variant's CoP there (the first of the four choices for the 8×8 ones), cm,
        absolute (not mean-removed). Empty when there is no platform file or the session failed.
    events : sequence of (float, str), optional
        Markers (host time of ``Session.host_time_s`` in s, label) that cut the trial into
        conditions (:func:`psmat.balance.conditions`), e.g. from an experimenter's log
        (:func:`psmat.balance.load_events_csv`); None: the session's own markers. They are
        brought to the frame clock (interpolated over the frames' host times) and then to the
        platform's with the alignment lag.

    Returns
    -------
    rows : list of dict
        Keys :data:`COLUMNS` (then the descriptors' names when ``params["descriptors"]`` names a
        preset); NaN where a value could not be computed. The sway metrics are those of the trace
        after ``params["preprocess"]`` (the platform's and every variant's alike), the descriptors
        (8×8 variants: the mean over the four choices, like the other metrics) those of the
        same aligned window, Eu on the unfiltered traces at the mat's frame times.
        ``duration_s`` is the analysed window (s), ``rate_hz`` the source's sample rate (the
        platform's for FP, the mat's frame rate for a variant), ``ispgr`` ``"ok"`` or why the
        recording misses the ISPGR recommendation (at least 25 s at 50 Hz; "" on a row
        without numbers). ``condition`` is "" on the whole trial's rows (``FP`` then the
        variants, first); then each condition of the aligned window (in time order) has the same
        rows, labelled, with the same metrics on its part of the window (``duration_s`` and
        ``ispgr`` its own); a condition of fewer than 8 samples, or too short for the
        preprocessing, has a status saying so instead of numbers.
    traces : dict
        Only with ``traces=True`` (see above).
    """
    p = {**DEFAULT_PARAMS, **(params or {})}
    names = tuple(p["variants"])
    found: Traces = {}
    try:
        rows = _process(Path(session), None if forceplate is None else Path(forceplate), subject, trial, weight_kg,
                        p, names, None if calibration is None else Path(calibration), found,
                        None if events is None else list(events))
    except Exception as exc:  # noqa: BLE001 - one bad session must not stop a study
        status = f"error: {type(exc).__name__}: {exc}".replace("\n", " ")
        rows, found = [_row(p, subject, trial, v, status) for v in ("FP",) + names], {}
    return (rows, found) if traces else rows


def _process(session: Path, forceplate: Path | None, subject: str, trial: str, weight_kg: float | None,
             p: dict[str, Any], names: tuple[str, ...], calibration: Path | None, found: Traces,
             events: list[tuple[float, str]] | None) -> Rows:
    from ..io import load_forceplate_csv, load_session
    from ..process import adc_line, process_loaded
    from ..profile import session_profile

    s = load_session(session)
    if s.kind != "psm":
        raise ValueError(f"a {s.kind!r} session, not a mat (psm) session")
    if s.n_frames < 8:
        raise ValueError(f"{s.n_frames} frames: too short")
    if narrow := adc_line(s, calibration):  # processed so, every empty cell would read as a loaded one
        raise ValueError(narrow)
    sensor = MPICreep(**p["sensor"]) if p["sensor"] else MPICreep.thesis()
    with warnings.catch_warnings():  # counted in the rows, not warned once per session per worker
        warnings.filterwarnings("ignore", message=r"IECM \(", category=RuntimeWarning)
        out = process_loaded(s, calibration=calibration, sensor=sensor, pitch_cm=p["pitch_cm"], method=p["method"],
                             threads=1, progress=False, pressure=False)  # the variants run their own recipes on g
    assert out.clock is not None
    # the device clock when the box stamps its frames (v2): a lost frame's -1 is a gap in it, not a
    # reason to fall back to the host clock; the same periods stepped the sensor model
    t, periods = out.clock.t_s, out.clock.periods_s
    fs = 1.0 / out.clock.step_s
    missing = int((~out.usable).sum())
    unconverged = 0 if out.solve_info is None else int(np.sum(~np.asarray(out.solve_info.converged)))
    weight_n = None if weight_kg is None else n_from_kg(float(weight_kg))
    traces = variant_traces(out.G, out.g, periods, weight_n=weight_n, sensor=sensor,
                            pitch_cm=p["pitch_cm"], cell_area_cm2=p["cell_area_cm2"],
                            geometry=None if p["pitch_cm"] is not None else session_profile(s).geometry,
                            names=tuple(n for n in names if weight_n is not None or not n.startswith("SCHC")))
    base = {"frames": s.n_frames, "frames_missing": missing, "frames_unconverged": unconverged}
    marks = list(s.events) if events is None else events
    on_frames = frame_clock([m[0] for m in marks], s.host_time_s, t) if marks else np.empty(0)
    if forceplate is None:
        mat_window = {"duration_s": float(t[-1] - t[0]), "rate_hz": fs, "ispgr": ispgr(float(t[-1] - t[0]), fs)}
        rows = [_row(p, subject, trial, "FP", "no force-platform file", **base)]
        filled: dict[str, list[np.ndarray]] = {}
        for v in names:
            if v not in traces:
                rows.append(_row(p, subject, trial, v, "no body weight", **base, **mat_window))
                continue
            filled[v] = [_fill(t, c) for c in traces[v].cop_cm]
            rows.append(_row(p, subject, trial, v, "no force-platform file: no Eu, no lag", **base, **mat_window,
                             **_mean([_metrics(t, c, fs, None, None, p) for c in filled[v]])))
        spans = condition_spans([(x, m[1]) for x, m in zip(on_frames, marks)], float(t[0]), float(t[-1]))
        for span in spans:
            sel = inside(t, span, float(t[-1]))
            cond = {**base, "condition": span.label, "duration_s": span.duration_s, "rate_hz": fs,
                    "ispgr": ispgr(span.duration_s, fs)}
            rows.append(_row(p, subject, trial, "FP", "no force-platform file", **base, condition=span.label))
            for v in names:
                if v not in filled:
                    rows.append(_row(p, subject, trial, v, "no body weight", **cond))
                    continue
                status, values = _guarded(int(sel.sum()), lambda v=v: _mean(
                    [_metrics(t[sel], c[sel], fs, None, None, p) for c in filled[v]]))
                rows.append(_row(p, subject, trial, v, "no force-platform file: no Eu, no lag" if status == "ok"
                                 else status, **cond, **values))
        return rows
    # the samples with a time and a CoP (ForcePlateRecording.samples: the others are lost samples)
    plate = load_forceplate_csv(forceplate)
    t_fp, c_loaded = plate.samples()
    c_fp = orient_platform(c_loaded, p["platform_axes"])
    fs_fp = 1.0 / float(np.median(np.diff(t_fp)))
    ref = traces[p["align_on"]].cop_cm[0]
    ok = np.all(np.isfinite(ref), axis=1)
    a = align(t_fp, c_fp, t[ok], ref[ok], max_lag_s=p["max_lag_s"])
    lo, hi = max(t[0] + a.lag_s, t_fp[0]), min(t[-1] + a.lag_s, t_fp[-1])
    if p["window_s"] is not None and hi - lo > p["window_s"]:
        mid = 0.5 * (lo + hi)
        lo, hi = mid - 0.5 * p["window_s"], mid + 0.5 * p["window_s"]
    in_mat = (t + a.lag_s >= lo) & (t + a.lag_s <= hi)
    in_fp = (t_fp >= lo) & (t_fp <= hi)
    if in_mat.sum() < 8 or in_fp.sum() < 8:
        raise ValueError("mat and platform overlap by fewer than 8 samples after alignment")
    common = {**base, "lag_s": a.lag_s, "r_align": a.r, "duration_s": float(hi - lo)}
    rows = [_row(p, subject, trial, "FP", "ok", **common, rate_hz=fs_fp, ispgr=ispgr(hi - lo, fs_fp),
                 **_metrics(t_fp[in_fp], c_fp[in_fp], fs_fp, None, None, p), eu_cm=0.0, eu_ml_cm=0.0, eu_ap_cm=0.0)]
    mat_window = {"rate_hz": fs, "ispgr": ispgr(hi - lo, fs)}
    tm = t[in_mat] + a.lag_s
    filled_by: dict[str, list[np.ndarray]] = {}
    aligned: Traces = {"t_s": tm, "FP": np.column_stack([np.interp(tm, t_fp, c_fp[:, k]) for k in range(2)])}
    for v in names:
        if v not in traces:
            rows.append(_row(p, subject, trial, v, "no body weight: subject missing from subjects.csv", **common,
                             **mat_window))
            continue
        filled = filled_by[v] = [_fill(tm, c[in_mat]) for c in traces[v].cop_cm]
        mean = _mean([_metrics(tm, c, fs, t_fp, c_fp, p) for c in filled])
        f = traces[v].factor
        rows.append(_row(p, subject, trial, v, "ok", **common, **mat_window, **mean,
                         factor=float(np.mean(f)) if f is not None else np.nan))
        aligned[v] = filled[0]
    found.update(aligned)
    spans = condition_spans([(x + a.lag_s, m[1]) for x, m in zip(on_frames, marks)], lo, hi)
    for span in spans:
        sel_fp, sel = in_fp & inside(t_fp, span, hi), inside(tm, span, hi)
        cond = {**common, "condition": span.label, "duration_s": span.duration_s}
        status, values = _guarded(int(sel_fp.sum()), lambda: _metrics(t_fp[sel_fp], c_fp[sel_fp], fs_fp, None, None,
                                                                     p))
        zero = {"eu_cm": 0.0, "eu_ml_cm": 0.0, "eu_ap_cm": 0.0} if status == "ok" else {}
        rows.append(_row(p, subject, trial, "FP", status, **cond, rate_hz=fs_fp, ispgr=ispgr(span.duration_s, fs_fp),
                         **values, **zero))
        for v in names:
            window = {**cond, "rate_hz": fs, "ispgr": ispgr(span.duration_s, fs)}
            if v not in traces:
                rows.append(_row(p, subject, trial, v, "no body weight: subject missing from subjects.csv", **window))
                continue
            status, values = _guarded(int(sel.sum()), lambda v=v: _mean(
                [_metrics(tm[sel], c[sel], fs, t_fp, c_fp, p) for c in filled_by[v]]))
            f = traces[v].factor
            rows.append(_row(p, subject, trial, v, status, **window, **values,
                             factor=float(np.mean(f)) if f is not None else np.nan))
    spread = check_spread(c_fp[in_fp], ref[ok & in_mat], plate.meta["unit"])
    if spread.off and not a.poor:  # the rows keep their numbers; their status keeps them out of the summary
        name = Path(forceplate).name
        why = f"{PLATFORM_SPREAD}: its CoP spreads {spread.ratio:.3g} times the mat's ({p['align_on']}; about 1 " \
              f"expected, flagged beyond {SPREAD_MISMATCH:g} either way): {spread_question(name, spread, plate.meta['cop_from'])}"
        rows = [{**r, "status": why if r["status"] == "ok" else f"{r['status']}; {why}"} for r in rows]
    if a.poor:  # the rows keep their numbers; their status keeps them out of the summary
        other = find_platform_axes(t_fp, c_loaded, t[ok], ref[ok], besides=p["platform_axes"], max_lag_s=p["max_lag_s"])
        why = f"{POOR_ALIGNMENT}: r {a.r:.2f} < {POOR_ALIGNMENT_R:g} at the best lag" + (
            f": is {Path(forceplate).name} this session's platform file?" if other is None else
            f", {other[1].r:.2f} with the platform's axes {other[0]}: they lie otherwise than the mat's "
            f"({_AXES_HINT}{other[0]})")
        rows = [{**r, "status": why if r["status"] == "ok" else f"{r['status']}; {why}"} for r in rows]
    return rows


def _mean(per_choice: list[dict[str, float]]) -> dict[str, float]:
    """The mean of each value over the choices of a variant (one choice: its values)."""
    return {k: float(np.mean([d[k] for d in per_choice])) for k in per_choice[0]}


def _guarded(n: int, compute: Callable[[], dict[str, float]]) -> tuple[str, dict[str, float]]:
    """(status, values) of a condition of ``n`` samples: its values, or a status saying it is too short."""
    if n < MIN_SAMPLES:
        return f"condition too short: {n} samples < {MIN_SAMPLES}", {}
    try:
        return "ok", compute()
    except ValueError as exc:
        return f"condition too short for the preprocessing ({' '.join(str(exc).split())})", {}

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
from pathlib import Path
from typing import Any

import numpy as np

from ..balance import VARIANTS, align, eu, variant_traces
from ..sensor import MPICreep
from ..units import n_from_kg
from ._row_metrics import columns, descriptor_values, ispgr, sway_metrics

__all__ = ["METRICS", "COLUMNS", "process_trial", "DEFAULT_PARAMS", "Rows", "Traces"]

METRICS = ("sd_ml_cm", "sd_ap_cm", "range_ml_cm", "range_ap_cm", "path_cm", "velocity_cm_s", "area95_cm2",
           "mean_freq_hz")
COLUMNS = ("subject", "trial", "variant") + METRICS + ("eu_cm", "eu_ml_cm", "eu_ap_cm", "lag_s", "r_align",
                                                        "factor", "frames", "frames_missing", "frames_unconverged",
                                                        "duration_s", "rate_hz", "ispgr", "status")
DEFAULT_PARAMS: dict[str, Any] = {
    "variants": list(VARIANTS),
    "method": "newton",  # IECM
    "pitch_cm": None,  # cm; None: the geometry of the session's profile (psmat.profile.session_profile)
    "cell_area_cm2": None,  # cm²; None: the cell area of that geometry (pitch²)
    "window_s": None,  # None: the whole overlap of mat and platform
    "max_lag_s": None,
    "align_on": "PROP",
    "sensor": None,  # MPICreep parameters (dict); None: the thesis' Table 2.11
    # the sway metrics of every row (FP and variants) after psmat.balance.preprocess with this preset
    # (SWARII to 25 Hz, 4th-order 10 Hz Butterworth forward-backward); None: on the raw traces
    "preprocess": "quijoux2021",
    "descriptors": None,  # "quijoux2021": the 72 descriptors (psmat.balance.descriptors) as extra columns
}


Rows = list[dict[str, Any]]
#: {"t_s": (N,) platform-clock times (s), "FP": (N, 2) cm, "<variant>": (N, 2) cm}, M-L then A-P
Traces = dict[str, np.ndarray]


def _row(p: dict[str, Any], subject: str, trial: str, variant: str, status: str, **values: Any) -> dict[str, Any]:
    row: dict[str, Any] = {c: np.nan for c in columns(COLUMNS, p)}
    row.update(subject=subject, trial=trial, variant=variant, status=status, ispgr="")
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


def _forceplate(path: Path, load: Any) -> Any:
    """The force-platform file through ``load``; a file that is not UTF-8 text, has fewer than two
    samples or whose times do not advance is a ValueError saying so."""
    try:
        fp = load(path)
    except UnicodeDecodeError as exc:
        raise ValueError(f"force-platform file {path.name} is not text (byte 0x{exc.object[exc.start]:02x} at offset "
                         f"{exc.start} is not UTF-8)") from None
    if fp.t.size < 2:
        raise ValueError(f"force-platform file {path.name} has {fp.t.size} sample(s); it needs at least 2")
    step = float(np.median(np.diff(fp.t)))
    if not step > 0:
        raise ValueError(f"force-platform file {path.name}: its times do not advance (median step {step:g} s "
                         "between samples)")
    return fp


def process_trial(session: str | os.PathLike[str], forceplate: str | os.PathLike[str] | None, subject: str,
                  trial: str, weight_kg: float | None, params: dict[str, Any] | None = None, *,
                  calibration: str | os.PathLike[str] | None = None,
                  traces: bool = False) -> Rows | tuple[Rows, Traces]:
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
        without numbers).
    traces : dict
        Only with ``traces=True`` (see above).
    """
    p = {**DEFAULT_PARAMS, **(params or {})}
    names = tuple(p["variants"])
    found: Traces = {}
    try:
        rows = _process(Path(session), None if forceplate is None else Path(forceplate), subject, trial, weight_kg,
                        p, names, None if calibration is None else Path(calibration), found)
    except Exception as exc:  # noqa: BLE001 - one bad session must not stop a study
        status = f"error: {type(exc).__name__}: {exc}".replace("\n", " ")
        rows, found = [_row(p, subject, trial, v, status) for v in ("FP",) + names], {}
    return (rows, found) if traces else rows


def _process(session: Path, forceplate: Path | None, subject: str, trial: str, weight_kg: float | None,
             p: dict[str, Any], names: tuple[str, ...], calibration: Path | None, found: Traces) -> Rows:
    from ..io import load_forceplate_csv, load_session
    from ..process import process_loaded
    from ..profile import session_profile

    s = load_session(session)
    if s.kind != "psm":
        raise ValueError(f"a {s.kind!r} session, not a mat (psm) session")
    if s.n_frames < 8:
        raise ValueError(f"{s.n_frames} frames: too short")
    sensor = MPICreep(**p["sensor"]) if p["sensor"] else MPICreep.thesis()
    with warnings.catch_warnings():  # counted in the rows, not warned once per session per worker
        warnings.filterwarnings("ignore", message=r"IECM \(", category=RuntimeWarning)
        out = process_loaded(s, calibration=calibration, sensor=sensor, pitch_cm=p["pitch_cm"], method=p["method"],
                             threads=1, progress=False)
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
    if forceplate is None:
        mat_window = {"duration_s": float(t[-1] - t[0]), "rate_hz": fs, "ispgr": ispgr(float(t[-1] - t[0]), fs)}
        rows = [_row(p, subject, trial, "FP", "no force-platform file", **base)]
        for v in names:
            if v not in traces:
                rows.append(_row(p, subject, trial, v, "no body weight", **base, **mat_window))
                continue
            per_choice = [_metrics(t, _fill(t, c), fs, None, None, p) for c in traces[v].cop_cm]
            mean = {k: float(np.mean([d[k] for d in per_choice])) for k in per_choice[0]}
            rows.append(_row(p, subject, trial, v, "no force-platform file: no Eu, no lag", **base, **mat_window,
                             **mean))
        return rows
    fp = _forceplate(forceplate, load_forceplate_csv)
    t_fp, c_fp = fp.t, fp.cop_cm
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
    aligned: Traces = {"t_s": tm, "FP": np.column_stack([np.interp(tm, t_fp, c_fp[:, k]) for k in range(2)])}
    for v in names:
        if v not in traces:
            rows.append(_row(p, subject, trial, v, "no body weight: subject missing from subjects.csv", **common,
                             **mat_window))
            continue
        filled = [_fill(tm, c[in_mat]) for c in traces[v].cop_cm]
        per_choice = [_metrics(tm, c, fs, t_fp, c_fp, p) for c in filled]
        mean = {k: float(np.mean([d[k] for d in per_choice])) for k in per_choice[0]}
        f = traces[v].factor
        rows.append(_row(p, subject, trial, v, "ok", **common, **mat_window, **mean,
                         factor=float(np.mean(f)) if f is not None else np.nan))
        aligned[v] = filled[0]
    found.update(aligned)
    return rows

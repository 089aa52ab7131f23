"""A posture study folder → one :class:`~psmat.posture.data.Recording` per session (docs/spec.md §6, §8).

Thesis §4.3: "Conductance measured by the PSM has been processed to remove crosstalk ... and
subsampled to the sampling frequency of the spine measurement device". Per session:

1. the mat's counts go through the one processing chain (:func:`psmat.process.process_loaded`, IECM
   ``newton``) with the session's circuit, and the box's calibration file
   ``DIR/calibration/<serial>.json`` when there is one (:func:`psmat.process.session_circuit`) → g (S);
2. the IMU angles come from the session's ``imu`` stream (recorded together, one host clock), or,
   for a mat recorded apart from its IMUs, from the thesis-style text log ``DIR/imu/<stem>.txt``
   aligned to the mat by the cross-correlation of the summed mat signal and the summed angles
   (Fig. 4.11, :func:`psmat.posture.data.align_mat_imu`, lag reported in ``meta``);
3. g is averaged over each IMU sample's interval (the mat frames whose host time falls within
   half an IMU period of the sample); pitch (the third Euler angle) in rad is the target.

Samples where the IMU frame failed its check or no usable mat frame fell in the interval are
filled by linear interpolation between their neighbours when inside the recording (counted in
``meta["samples_interpolated"]``) and cut when at its ends.

The products are cached per session in ``DIR/results/posture/inputs/<stem>.npz``, keyed by the
bytes of the inputs, the parameters and the psmat version (as :mod:`psmat.study` (``_cache.py``)), so a
second run reads them back and a changed session recomputes only itself. A cached file is
used only when its digest proves it (:func:`psmat.posture.data.read_cached`); one that fails is
recomputed and named among the problems.
"""

from __future__ import annotations

import os
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..._folders import companion, data_files, hidden, nested
from ._input_cache import read_cached, write_cached
from ._recording import Recording
from ._resample import mean_over_samples

__all__ = ["DEFAULT_PARAMS", "NO_IMU", "session_recording", "load_posture_study", "PostureStudy"]

#: Parameters of the inputs (part of the cache key).
DEFAULT_PARAMS: dict[str, Any] = {
    "method": "newton",  # IECM method (psmat.iecm.solve)
    "pitch_column": 2,  # Euler angle of the sagittal tilt: (heading, roll, pitch), docs/spec.md §5
    "max_lag_s": 30.0,  # alignment search range for recordings made apart, s
}
# 3: samples of one serial chunk spread (_arrivals_spread); 4: the chain's IECM to a residual of 1e-6
# (psmat.process.IECM_RTOL)
_INPUTS_SCHEMA = "psmat-posture-inputs/4"
#: why a session without the spine IMUs is left out (a balance study's sessions, for instance)
NO_IMU = "no 'imu' stream and no IMU log"


@dataclass
class PostureStudy:
    """What :func:`load_posture_study` found: the recordings, the problems (sessions left out,
    one line each) and the notes (cached inputs that failed their check and were recomputed)."""

    recordings: list[Recording]
    problems: list[str]
    computed: int  # sessions computed in this call (the rest were read from the cache)
    notes: list[str] = field(default_factory=list)


def _mat_g(session: Any, calibration: Path | None, method: str) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Host times (s) and crosstalk-free g (S, NaN on missing frames) of a mat session, through the
    one path of a recorded session (:func:`psmat.process.process_loaded`); the host times are the
    clock the IMUs share."""
    from ...process import process_loaded

    t = _arrivals_spread(session.host_time_s, session.device_time_us)
    if np.isfinite(t).sum() < 2:
        raise ValueError("the mat session has fewer than two timed frames")
    return t, process_loaded(session, calibration=calibration, method=method, progress=False).g


def _imu_together(session: Any, column: int) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.bool_]]:
    imu = session.streams["imu"]
    pitch = np.deg2rad(np.asarray(imu.counts[:, :, column], np.float64))
    valid = imu.valid & np.all(np.isfinite(pitch), axis=1)
    t = _arrivals_spread(imu.host_time_s, imu.device_time_us)
    return t, pitch, valid & np.isfinite(t)


def _arrivals_spread(host_time_s: NDArray[np.float64], device_time_us: Any) -> NDArray[np.float64]:
    """Host times (s) with the samples of one serial chunk (one arrival time) spread back from it:
    by the device's clock, else by the period of the samples at their arrival (psmat.io.frame_times)."""
    from ...io import frame_times, run_end_period_s

    period = run_end_period_s(host_time_s)
    return frame_times(host_time_s, device_time_us, period_s=period if np.isfinite(period) else None)


def _imu_apart(log_path: Path, t_mat: NDArray[np.float64], g: NDArray[np.float64], column: int,
               max_lag_s: float, meta: dict[str, Any]
               ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.bool_]]:
    """The IMU log's samples on the mat's host clock, by the Fig. 4.11 alignment."""
    from ...io import load_imu_log
    from ._align import align_mat_imu

    log = load_imu_log(log_path)
    pitch = np.deg2rad(np.asarray(log.angles_deg[:, :, column], np.float64))
    valid = np.asarray(log.valid, bool) & np.all(np.isfinite(pitch), axis=1)
    a = align_mat_imu(t_mat, g, log.t_s[valid], pitch[valid], max_lag_s=max_lag_s)
    meta.update(aligned_by="cross-correlation of the summed mat signal and the summed angles (Fig. 4.11)",
                lag_s=float(a.lag_s), r_align=float(a.r))
    return np.asarray(log.t_s, np.float64) - a.lag_s, pitch, valid


def _fill(x: NDArray[np.float64], ok: NDArray[np.bool_], t: NDArray[np.float64]) -> NDArray[np.float64]:
    """Linear interpolation in time over the rows that are not ok (ok rows untouched)."""
    if ok.all():
        return x
    flat = x.reshape(len(x), -1).copy()
    for j in range(flat.shape[1]):
        flat[~ok, j] = np.interp(t[~ok], t[ok], flat[ok, j])
    return flat.reshape(x.shape)


def session_recording(path: str | os.PathLike[str], *, calibration: str | os.PathLike[str] | None = None,
                      imu_log: str | os.PathLike[str] | None = None,
                      params: dict[str, Any] | None = None) -> Recording:
    """The :class:`Recording` of one posture session (see the module docstring).

    Parameters
    ----------
    path : path
        The session file (``.h5``): the mat at the root, the IMUs in its ``imu`` stream unless
        ``imu_log`` is given.
    calibration : path, optional
        The box's calibration file (``psmat calibrate``).
    imu_log : path, optional
        The thesis-style IMU text log of a recording made apart from the mat; aligned by
        cross-correlation (Fig. 4.11).
    params : dict, optional
        Overrides of :data:`DEFAULT_PARAMS`.
    """
    from ...io import load_session
    from ...process import adc_line

    p = {**DEFAULT_PARAMS, **(params or {})}
    s = load_session(path)
    if s.kind != "psm":
        raise ValueError(f"{Path(path).name}: the session's root stream is {s.kind!r}, not the mat ('psm')")
    if narrow := adc_line(s, calibration):  # processed so, every empty cell would read as a loaded one
        raise ValueError(f"{Path(path).name}: {narrow}")
    meta: dict[str, Any] = {"session": Path(path).name, "simulated": s.metadata.get("simulated") is True}
    t_mat, g = _mat_g(s, None if calibration is None else Path(calibration), p["method"])
    if imu_log is not None:
        t_imu, pitch, ok = _imu_apart(Path(imu_log), t_mat, g, p["pitch_column"], p["max_lag_s"], meta)
    elif "imu" in s.streams:
        t_imu, pitch, ok = _imu_together(s, p["pitch_column"])
        meta["aligned_by"] = "one host clock (recorded together)"
    else:
        raise ValueError(f"{Path(path).name}: {NO_IMU}")
    order = np.flatnonzero(np.isfinite(t_imu))
    t_imu, pitch, ok = t_imu[order], pitch[order], ok[order]
    image, n = mean_over_samples(t_mat, g, t_imu)
    ok = ok & (n > 0)
    if ok.sum() < 2:
        raise ValueError(f"{Path(path).name}: the mat and the IMUs share fewer than two samples")
    first, last = np.flatnonzero(ok)[[0, -1]]
    sl = slice(first, last + 1)
    t, ok = t_imu[sl], ok[sl]
    meta.update(samples=int(ok.size), samples_interpolated=int((~ok).sum()),
                mat_frames_per_sample=float(np.mean(n[sl][ok])), imu_rate_hz=float((ok.size - 1) / (t[-1] - t[0])))
    subject = str(s.metadata.get("subject", ""))
    day = int(s.metadata.get("day", 0) or 0)
    return Recording(subject=subject, day=day, t_s=t, image=_fill(image[sl], ok, t).astype(np.float32),
                     angles_rad=_fill(pitch[sl], ok, t), meta=meta)


# ------------------------------------------------------------------ a whole study
@dataclass(frozen=True)
class _Task:
    stem: str
    session: Path
    calibration: Path | None
    imu_log: Path | None
    params: dict[str, Any]
    key: str


def _tasks(root: Path, params: dict[str, Any], problems: list[str]) -> list[_Task]:
    from ...study import file_sha256, result_key
    from ...io import journal_path, load_session, SessionFormatError
    from ...io.session import psmat_version
    from ...io.session import journal_only, not_closed_line, unfinished_reason

    # hidden files (a Mac's ._NAME beside every file it copies to a USB stick) are no data, a stem that
    # differs only in case is the one meant, files in subfolders are said: as in a balance study
    # (psmat.study.find_study; psmat._folders)
    sessions = sorted(p for p in (root / "sessions").glob("*.h5") if not hidden(p))
    unclosed = [p for p in journal_only(root / "sessions") if not hidden(p)]  # each a problem line
    problems += [f"{path.stem}: {not_closed_line(path)}" for path in unclosed]
    if not sessions:
        raise FileNotFoundError(f"{root}: no sessions/*.h5 (a posture study folder, docs/spec.md §6)"
                                + (f"; {not_closed_line(unclosed[0])}" if unclosed else ""))
    problems += nested(root, (("sessions", (".h5",)), ("imu", (".txt",))))
    cals = data_files(root / "calibration", (".json",))
    logs = data_files(root / "imu", (".txt",))
    tasks = []
    for path in sessions:
        stem = path.stem
        try:
            s = load_session(path)
        except (SessionFormatError, OSError) as exc:
            problems.append(f"{stem}: unreadable session: {exc}")
            continue
        why = unfinished_reason(path, s)
        if why:  # left out until psmat repair finishes it
            problems.append(f"{stem}: {why}")
            continue
        serial = str(s.device.get("serial"))
        cal, cal_problem = companion(serial, cals, "calibration", owner="box")
        if cal_problem:  # which one is right is not known: neither is used, and the run says so
            problems.append(f"{stem}: {cal_problem} (neither is used)")
        elif cal is None and cals and s.kind == "psm" and s.calibration is None:
            problems.append(f"{stem}: no calibration/{serial}.json for its box {serial!r}, and the session "
                            "stores none: the profile's nominal circuit is used")
        log, log_problem = companion(stem, logs, "IMU log")
        if log_problem:
            problems.append(f"{stem}: {log_problem}")
            continue
        if log is None and "imu" not in s.streams:  # known before any IECM is computed
            problems.append(f"{stem}: {NO_IMU} (imu/{stem}.txt)")
            continue
        jp = journal_path(path)
        inputs = {"product": _INPUTS_SCHEMA, "version": psmat_version(), "params": params, "stem": stem,
                  "session": file_sha256(path), "journal": file_sha256(jp) if jp.exists() else None,
                  "calibration": file_sha256(cal), "imu_log": file_sha256(log)}
        tasks.append(_Task(stem, path, cal, log, params, result_key(inputs)))
    return tasks


def _run(task: _Task) -> tuple[str, Recording | None, str | None]:
    try:
        rec = session_recording(task.session, calibration=task.calibration, imu_log=task.imu_log, params=task.params)
    except Exception as exc:  # noqa: BLE001 - one bad session must not stop a study
        return task.stem, None, f"{task.stem}: {type(exc).__name__}: {exc}".replace("\n", " ")
    return task.stem, rec, None


def _cache_path(root: Path, stem: str) -> Path:
    return root / "results" / "posture" / "inputs" / f"{stem}.npz"


def _execute(todo: Sequence[_Task], workers: int | None) -> Iterator[tuple[str, Recording | None, str | None]]:
    from ..._parallel import map_unordered  # workers that end with this process, even after kill -9

    yield from map_unordered(_run, todo, workers)


def load_posture_study(root: str | os.PathLike[str], *, workers: int | None = None,
                       params: dict[str, Any] | None = None, progress: bool = True) -> PostureStudy:
    """Every session of a posture study folder as a :class:`Recording`, in file order.

    Parameters
    ----------
    root : path
        The study folder (docs/spec.md §6: ``sessions/``, optional ``calibration/`` and ``imu/``).
    workers : int, optional
        Processes, one session each (default: every core; 1: in this process).
    params : dict, optional
        Overrides of :data:`DEFAULT_PARAMS`.
    progress : bool
        A progress bar over sessions.

    Returns
    -------
    PostureStudy
        The recordings, the problems (a session that failed is left out and named there), how
        many sessions were computed rather than read from the cache, and the notes (a cached
        file that failed its check, recomputed).
    """
    from psmat._progress import tqdm

    root = Path(root)
    p = {**DEFAULT_PARAMS, **(params or {})}
    unknown = set(p) - set(DEFAULT_PARAMS)
    if unknown:
        raise ValueError(f"unknown posture input parameter(s) {sorted(unknown)}; known: {sorted(DEFAULT_PARAMS)}")
    problems: list[str] = []
    tasks = _tasks(root, p, problems)
    found: dict[str, Recording] = {}
    notes: list[str] = []
    todo = []
    for t in tasks:
        rec, problem = read_cached(_cache_path(root, t.stem), t.key, root / "results")
        if problem is not None:  # on disk but not proven: recomputed, and said so
            notes.append(f"{t.stem}: {problem}")
        if rec is None:
            todo.append(t)
        else:
            found[t.stem] = rec
    by_stem = {t.stem: t for t in tasks}
    with tqdm(total=len(todo), unit="session", desc="posture inputs", disable=not progress or not todo) as bar:
        for stem, rec, problem in _execute(todo, workers):
            if rec is None:
                problems.append(str(problem))
            else:
                write_cached(_cache_path(root, stem), by_stem[stem].key, rec)
                found[stem] = rec
            bar.update(1)
    return PostureStudy([found[t.stem] for t in tasks if t.stem in found], problems, len(todo), notes)

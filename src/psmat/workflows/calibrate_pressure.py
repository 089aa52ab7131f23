"""The pressure steps of ``psmat calibrate`` (docs/spec.md §4 "Pressure calibration").

Each step reads recordings a lab made, computes its part of the mat's
:class:`psmat.pressure.PressureCalibration` and adds it, dated, to a calibration file
(:class:`psmat.Calibration`, key ``"pressure"``), replacing the file whole or not at all; the
file is created (with only a pressure part) when it does not exist yet.

* :func:`run_equilibrate` — session files of uniform loads of known level (``psmat record``
  while a bladder or masses on a plate load the whole mat) → per-cell gains. A scale from an
  earlier known load is dropped: it was made relative to the old gains.
* :func:`run_known_load` — a session file of a known load (masses, a person of known weight
  standing still) → the global scale, on top of the gains the file holds.
* :func:`run_pneumatic` — a material-DAQ log of pneumatic-platform samples and its
  applied-pressure schedule → a fitted sensor model (:func:`psmat.sensor.fit_cells`, one shared
  model over the samples' gains). Gains and scale made with the old model are dropped.

Recordings go through the mat's one chain (:func:`psmat.process.process_loaded`: the
calibration file's electronics part when it has one, IECM) to cell conductances.
"""

from __future__ import annotations

import dataclasses
import os
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..circuit import Calibration
from ..pressure import EquilibrationResult, PressureCalibration, equilibrate, known_load, utc_now
from ..units import STANDARD_GRAVITY_M_S2

__all__ = ["run_equilibrate", "run_known_load", "run_pneumatic", "session_conductances", "STANDARD_GRAVITY"]

#: m/s², to turn calibration masses (kg) into a load (N)
STANDARD_GRAVITY = STANDARD_GRAVITY_M_S2


def _existing(cal_path: Path) -> Calibration | None:
    return Calibration.load(cal_path) if cal_path.exists() else None


def session_conductances(path: str | os.PathLike[str], calibration: Path | None
                         ) -> tuple[NDArray[np.float64], NDArray[np.float64], Any]:
    """A session file's cell conductances (T, R, C) in S (NaN on missing frames), each frame's
    period (T,) in s, and the loaded session."""
    from ..io import load_session
    from ..process import process_loaded

    s = load_session(path)
    try:
        out = process_loaded(s, calibration=calibration, threads=1)
    except ValueError as exc:
        raise ValueError(f"{path}: {exc}") from None
    assert out.clock is not None
    return out.g, np.asarray(out.clock.periods_s, dtype=np.float64), s


def _save(cal_path: Path, existing: Calibration | None, part: PressureCalibration, session: Any) -> Calibration:
    """``existing`` (or a new pressure-only calibration for the session's box) with ``part``, written atomically."""
    if existing is not None:
        cal = dataclasses.replace(existing, mat_calibration=part.to_dict())
    else:
        from ..process import session_circuit

        cir = session_circuit(session)
        serial = str((session.device or {}).get("serial") or "") if session is not None else ""
        cal = Calibration(serial=serial, r_o=cir.r_o, v_ref=cir.v_ref, bits=cir.bits, mat_calibration=part.to_dict(),
                          notes="psmat calibrate: pressure part only")
    cal.save(cal_path, overwrite=True)
    return cal


def _pressure_of(existing: Calibration | None) -> PressureCalibration | None:
    if existing is None or existing.mat_calibration is None:
        return None
    return PressureCalibration.from_dict(existing.mat_calibration)


def run_equilibrate(paths: list[str], levels_kpa: list[float], cal_path: str | os.PathLike[str], *,
                    settle_s: float = 3.0) -> tuple[EquilibrationResult, PressureCalibration]:
    """Per-cell gains from uniform-load session files (one level in kPa each), added to ``cal_path``."""
    cal_file = Path(cal_path)
    existing = _existing(cal_file)
    if len(paths) != len(levels_kpa):
        raise ValueError(f"give one --level-kpa per recording: {len(paths)} file(s), {len(levels_kpa)} level(s)")
    base = _pressure_of(existing)
    electronics = cal_file if existing is not None and existing.has_electronics else None
    gs, periods, session = [], [], None
    for p in paths:
        g, per, session = session_conductances(p, electronics)
        gs.append(g)
        periods.append(per)
    sensor = base.sensor if base is not None else None
    result = equilibrate(gs, periods, levels_kpa, sensor, settle_s=settle_s)
    part = result.calibration(base)
    _save(cal_file, existing, part, session)
    return result, part


def run_known_load(path: str, load_n: float, cal_path: str | os.PathLike[str], *, settle_s: float = 3.0,
                   cell_area_cm2: float | None = None) -> PressureCalibration:
    """The global scale from a session file of a known load ``load_n`` (N), added to ``cal_path``.
    The cell area comes from the session's device profile unless given (cm²)."""
    from ..profile import session_profile

    cal_file = Path(cal_path)
    existing = _existing(cal_file)
    base = _pressure_of(existing) or PressureCalibration()
    electronics = cal_file if existing is not None and existing.has_electronics else None
    g, periods, session = session_conductances(path, electronics)
    area = cell_area_cm2 if cell_area_cm2 is not None else session_profile(session).cell_area_cm2
    if area is None:
        raise ValueError(f"{path}: its profile has no geometry: give the cell area")
    try:
        scale = known_load(g, periods, load_n, area, gains=base.gains, sensor=base.sensor, settle_s=settle_s)
    except ValueError as exc:
        raise ValueError(f"{path}: {exc}") from None
    part = dataclasses.replace(base, scale=scale, scale_utc=utc_now(), scale_load_n=float(load_n))
    _save(cal_file, existing, part, session)
    return part


def run_pneumatic(log: str, schedule: str, cal_path: str | os.PathLike[str], *,
                  offset_s: float = 0.0) -> PressureCalibration:
    """A sensor model fitted on a material-DAQ log (text, or a ``psmat record --device daq`` session
    file) and its schedule (CSV ``time_s,pressure_psi``), added to ``cal_path``."""
    from ..sensor import fit_cells, load_daq_log, load_daq_session

    cal_file = Path(cal_path)
    existing = _existing(cal_file)
    with open(log, "rb") as fh:
        hdf5 = fh.read(8) == b"\x89HDF\r\n\x1a\n"
    run = (load_daq_session if hdf5 else load_daq_log)(log, schedule, offset_s=offset_s)
    keep = np.isfinite(run.p) & np.all(np.isfinite(run.g), axis=1)
    if keep.sum() < 10:
        raise ValueError(f"{log}: {int(keep.sum())} samples on the schedule; too few to fit a sensor model")
    models = fit_cells(run.p[keep], run.g[keep], run.dt, mode="gain", progress=False)
    model = models.models[0]
    why = model.invertibility_problem()
    if why:
        raise ValueError(f"{log}: the fitted sensor model is not invertible ({why}); check the log and schedule")
    part = PressureCalibration(sensor=model, sensor_fitted_utc=utc_now(), sensor_source=Path(log).name)
    if existing is None:
        cal = Calibration(serial="", mat_calibration=part.to_dict(), notes="psmat calibrate: pressure part only")
        cal.save(cal_file, overwrite=True)
    else:
        _save(cal_file, existing, part, None)
    return part

"""A session's pressure images in kPa, whatever made them: :func:`session_pressure`.

* a mat (``psm``) session goes through the chain (:func:`process_loaded`: counts → G → g →
  kPa), on its own frame clock;
* a session of kind ``"pressure"`` (a file of another mat's software, imported by
  ``psmat import``) holds kPa already: they are taken as stored, on the host clock, and its
  geometry is its profile's.

The record says in one line how its kPa were made (``source``), so a report never presents an
uncalibrated or imported pressure as something else.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..profile import Geometry, geometry_for, session_profile
from ..sensor import MPICreep
from ._session import process_loaded

__all__ = ["PressureRecord", "session_pressure"]


@dataclass
class PressureRecord:
    """A session's pressure images and how they were made (:func:`session_pressure`).

    Attributes
    ----------
    t_s : ndarray, (T,)
        Frame times, s (a mat's frame clock: the device clock when the box stamps its frames; an
        imported session's host clock).
    pressure_kpa : ndarray, (T, R, C) float64
        Pressure, kPa; NaN on a frame that is not usable.
    usable : ndarray of bool, (T,)
        Frames with pressure.
    geometry : psmat.profile.Geometry
        Where the cells are (cm).
    source : str
        One line: how the kPa were made.
    params : dict
        The parameters that made them (the chain's ``params`` for a mat session).
    """

    t_s: NDArray[np.float64]
    pressure_kpa: NDArray[np.float64]
    usable: NDArray[np.bool_]
    geometry: Geometry
    source: str
    params: dict[str, Any] = field(default_factory=dict)


def _chain_source(params: dict[str, Any], method: str) -> str:
    calibration = str(params.get("pressure_calibration", "uncalibrated"))
    return (f"the psmat chain (counts → G → IECM {method} → sensor model → kPa); circuit from "
            f"{params.get('circuit_from', 'unknown')}; pressure calibration: {calibration}")


def _imported(session: Any) -> PressureRecord:
    if session.n_frames < 1:
        raise ValueError("the session holds no frame")
    frames = np.asarray(session.frames, dtype=np.float64)
    usable = np.asarray(session.valid, bool) & np.all(np.isfinite(frames), axis=(1, 2))
    frames[~usable] = np.nan
    prof = session_profile(session)
    if prof.geometry is None:
        raise ValueError(f"the session's profile {prof.name!r} has no mat geometry")
    geo = geometry_for(session.frame_shape, geometry=prof.geometry)
    meta = session.metadata or {}
    fmt = meta.get("source_format") or "an unknown format"
    params = {"source_format": meta.get("source_format"), "source_file": meta.get("source_file"),
              "geometry": geo.to_dict(), "geometry_from": f"the session's profile {prof.name!r} ({prof.source})",
              "frames_missing": int((~usable).sum()), "frame_clock": "host clock"}
    return PressureRecord(t_s=np.asarray(session.host_time_s, np.float64), pressure_kpa=frames, usable=usable,
                          geometry=geo, source=f"imported from {fmt} (metadata 'source_format')", params=params)


def session_pressure(session: Any, *, calibration: str | os.PathLike[str] | None = None,
                     sensor: MPICreep | None = None, method: str = "newton",
                     progress: bool = False) -> PressureRecord:
    """The pressure images (kPa) of a recorded session and how they were made.

    Parameters
    ----------
    session : psmat.io.Session or path
        A loaded session, or a session file (``.h5``). Kinds ``"psm"`` (a mat: through the chain)
        and ``"pressure"`` (kPa imported from another mat's file: as stored).
    calibration : path, optional
        A mat session's calibration file (:func:`process_loaded`); not for an imported session.
    sensor : MPICreep, optional
        A mat session's sensor model (default the pressure calibration's, else the thesis').
    method : str
        IECM method of the chain (:func:`psmat.iecm.solve`).
    progress : bool
        IECM progress bar.

    Returns
    -------
    PressureRecord

    Raises
    ------
    ValueError
        Another kind of session, too few frames, no geometry, a calibration for an imported session.
    """
    if isinstance(session, (str, os.PathLike)):
        from ..io import load_session

        session = load_session(session)
    if session.kind == "pressure":
        if calibration is not None or sensor is not None:
            raise ValueError("an imported pressure session holds kPa already: no calibration or sensor model applies")
        return _imported(session)
    if session.kind != "psm":
        raise ValueError(f"a {session.kind!r} session holds no pressure; a report needs a mat (psm) or an imported "
                         "pressure session")
    out = process_loaded(session, calibration=calibration, sensor=sensor, method=method, threads=1, progress=progress)
    assert out.clock is not None
    geo = Geometry.from_dict(out.params["geometry"])
    return PressureRecord(t_s=np.asarray(out.clock.t_s, np.float64), pressure_kpa=out.pressure_kpa,
                          usable=np.asarray(out.usable, bool), geometry=geo,
                          source=_chain_source(out.params, method), params=dict(out.params))

"""A recorded session through the chain: the one path of :func:`process_session`, the balance
study and the posture study (:func:`process_loaded`).

Which circuit turns a session's counts into conductances (docs/spec.md §2: "a calibration is
data ... applied when data are loaded"), in this order:

1. the calibration the session stores (``Session.calibration``: a ``psmat calibrate`` file's
   content or a ``Circuit.as_dict()``), when it has one;
2. else the ``circuit`` the caller passes; else the circuit of the session's device profile
   (:func:`psmat.profile.session_profile`: the stored profile, or one rebuilt from the device
   record of an older file: a 10-bit 5 V Arduino mat is read as one);
3. then a calibration *file* the caller passes (``calibration=``) replaces that circuit's R_adc
   and R_mux (:meth:`Circuit.calibrated`), after checking that it is the same box (serial).

So a stored calibration is never silently overridden by a ``circuit`` argument; a box
calibrated after the recording is applied with ``calibration=``. The products' parameters say
which circuit was used (``circuit_from``).

The mat's pressure calibration (:mod:`psmat.pressure`, the ``"pressure"`` part of a calibration
file) follows the same order: the ``calibration=`` file's when it has one (a calibration made
after the recording), else the one the session stores, else none (the nominal model's relative
kPa). ``params["pressure_calibration"]`` says which, ``pressure_calibration_from`` from where. A
file with only a pressure part leaves the circuit as it is.
"""

from __future__ import annotations

import os
from typing import Any

from ..circuit import Calibration, Circuit
from ..pressure import PressureCalibration
from ..profile import Geometry, geometry_for, session_profile
from ..sensor import MPICreep
from ._chain import Processed, Processor
from ._clock import session_clock

__all__ = ["process_loaded", "process_session", "session_circuit", "session_pressure_calibration"]

#: keys of a stored ``Circuit.as_dict()`` and the Circuit arguments they are
_CIRCUIT_KEYS = {"r_o_ohm": "r_o", "r_mux_ohm": "r_mux", "r_adc_ohm": "r_adc", "v_ref_volt": "v_ref", "bits": "bits",
                 "sensor_side": "sensor_side"}


def _stored_circuit(stored: dict[str, Any]) -> Circuit:
    """The circuit a session stores: a calibration file's content or a ``Circuit.as_dict()``."""
    if stored.get("format") == "psmat-calibration":
        cal = Calibration.from_dict(stored)
        nominal = Circuit(r_o=cal.r_o, v_ref=cal.v_ref, bits=cal.bits)
        return nominal.calibrated(cal) if cal.has_electronics else nominal
    return Circuit(**{arg: stored[k] for k, arg in _CIRCUIT_KEYS.items() if k in stored})


def _resolve(session: Any, circuit: Circuit | None,
             calibration: str | os.PathLike[str] | None) -> tuple[Circuit, str]:
    """The session's circuit (module docstring) and where it came from, in words."""
    if session.calibration:
        found, source = _stored_circuit(session.calibration), "the session's stored calibration"
    elif circuit is not None:
        found, source = circuit, "the circuit passed by the caller"
    else:
        prof = session_profile(session)
        found, source = prof.circuit(), f"the session's profile {prof.name!r} ({prof.source})"
    if calibration is None:
        return found, source
    cal = Calibration.load(calibration)
    serial = (session.device or {}).get("serial")
    if cal.serial and serial is not None and str(serial) != cal.serial:
        raise ValueError(f"{os.path.basename(calibration)} is box {cal.serial!r}; the session was recorded with "
                         f"box {serial!r}")
    if not cal.has_electronics:
        return found, source
    return found.calibrated(cal), f"{source}, R_adc and R_mux from {os.path.basename(calibration)}"


def session_pressure_calibration(session: Any, calibration: str | os.PathLike[str] | None = None
                                 ) -> tuple[PressureCalibration | None, str]:
    """The mat's pressure calibration for a session (module docstring) and where it came from, in words."""
    if calibration is not None:
        part = Calibration.load(calibration).mat_calibration
        if part is not None:
            return PressureCalibration.from_dict(part), os.path.basename(calibration)
    stored = session.calibration or {}
    if stored.get("format") == "psmat-calibration" and stored.get("pressure") is not None:
        return PressureCalibration.from_dict(stored["pressure"]), "the session's stored calibration"
    return None, "none"


def session_circuit(session: Any, *, circuit: Circuit | None = None,
                    calibration: str | os.PathLike[str] | None = None) -> Circuit:
    """The circuit that turns a recorded session's counts into conductances (module docstring).

    Parameters
    ----------
    session : psmat.io.Session
        A loaded session; its stored calibration (``calibration``) comes first.
    circuit : Circuit, optional
        Used only when the session stores no calibration; default ``Circuit()``.
    calibration : path, optional
        A calibration file (``psmat calibrate``, JSON) whose ``r_adc`` and ``r_mux`` replace
        the circuit's (:meth:`Circuit.calibrated`: its ``r_o``, ``v_ref`` and ``bits`` must
        agree); its serial must match the session's ``device["serial"]`` when both name one.
    """
    return _resolve(session, circuit, calibration)[0]


def _session_geometry(session: Any, pitch_cm: float | None,
                      geometry: Geometry | None) -> tuple[Geometry, dict[str, Any]]:
    """Where a session's cells are: the caller's ``geometry`` or ``pitch_cm``, else the session's
    profile's (:func:`psmat.profile.session_profile`); and what the products' params say of it."""
    shape = session.frame_shape
    if geometry is not None or pitch_cm is not None:
        given = "geometry" if geometry is not None else "pitch_cm"
        return geometry_for(shape, pitch_cm=pitch_cm, geometry=geometry), {"profile": None,
                                                                           "geometry_from": f"the caller's {given}"}
    prof = session_profile(session)
    if prof.geometry is None:
        raise ValueError(f"the session's profile {prof.name!r} is a {prof.kind} device's: no mat geometry")
    return (geometry_for(shape, geometry=prof.geometry),
            {"profile": prof.name, "geometry_from": f"the session's profile {prof.name!r} ({prof.source})"})


def process_loaded(session: Any, *, circuit: Circuit | None = None,
                   calibration: str | os.PathLike[str] | None = None, sensor: MPICreep | None = None,
                   g_rest: float = 0.0, pitch_cm: float | None = None, method: str | None = "newton",
                   threads: int | None = 1, progress: bool | None = None,
                   geometry: Geometry | None = None, pressure: bool = True) -> Processed:
    """Run the chain on a loaded mat session: counts → G → g → pressure (kPa) → CoP.

    Each frame is stepped with its own period (:func:`session_clock`: the device clock when the
    box stamps its frames), so a frame lost on the wire advances the sensor model by its real
    interval; frames that failed their check on the wire are missing (the package's policy).

    Parameters
    ----------
    session : psmat.io.Session
        A loaded mat (``psm``) session with at least two frames.
    circuit, calibration
        The session's circuit, in the order of :func:`session_circuit`: the stored
        calibration first, ``circuit`` only for a session without one, then a calibration
        file's R_adc and R_mux. The pressure calibration: the file's, else the stored one
        (:func:`session_pressure_calibration`).
    sensor : MPICreep, optional
        Sensor model for compensation; default the pressure calibration's, else the thesis' (Table 2.11).
    g_rest : float
        Conductance of an unloaded cell (S), subtracted before the sensor model.
    pitch_cm : float, optional
        Cell pitch for the CoP (cm), in the default orientation; not with ``geometry``.
    geometry : psmat.profile.Geometry, optional
        Where the cells are, for the CoP. Neither given: the geometry of the session's profile
        (:func:`psmat.profile.session_profile`: the stored one, else one built from the device
        record), as ``params["geometry"]``, ``["profile"]`` and ``["geometry_from"]`` record.
    method, threads
        As :class:`Processor`: ``threads=1`` (default) solves the frames in order, each
        warm-started from the previous one, in one ``iecm.solve(threads=1, rtol=IECM_RTOL)`` batch (the numbers
        of :class:`Processor`'s one-worker stream: the recording is one push).
    progress : bool, optional
        IECM progress bar (default: on for >= 2000 frames when writing to a terminal).
    pressure : bool
        True (default): the sensor model gives pressure and CoP. False: stop at g, skipping the
        sensor model; ``pressure_kpa`` and ``cop_cm`` are NaN (for a caller that runs its own
        recipes on G and g, as the balance study does with :func:`psmat.balance.variant_traces`).

    Returns
    -------
    Processed
        The products, with ``clock`` (each frame's time and period) and, in ``params``, the
        clock and the circuit used.

    Raises
    ------
    ValueError
        Not a mat session, fewer than two frames, a clock that does not advance, or a
        calibration file of another box.
    """
    if session.kind != "psm":
        raise ValueError(f"a {session.kind!r} session; the chain handles mat (psm) sessions")
    if session.n_frames < 2:
        raise ValueError(f"{session.n_frames} frame(s); at least 2 are needed for a frame period")
    clock = session_clock(session)
    cir, source = _resolve(session, circuit, calibration)
    mat_cal, pressure_from = session_pressure_calibration(session, calibration)
    geo, geo_params = _session_geometry(session, pitch_cm, geometry)
    with Processor(session.frame_shape, circuit=cir, sensor=sensor, g_rest=g_rest, geometry=geo, method=method,
                   threads=threads, mat_calibration=mat_cal, stream=False, pressure=pressure) as proc:
        out = proc.push(session.counts, clock.periods_s, valid=session.valid, progress=progress)
    del out.params["dt_s"]  # one per frame: the session's own time columns hold them
    restarted = (f"; the box's clock started again {clock.restarts} time(s), its segments placed by the host clock"
                 if clock.restarts else "")
    out.params.update(frame_clock=f"{clock.source}: each frame stepped with its own period{restarted}",
                      median_period_s=clock.step_s, circuit_from=source, pressure_calibration_from=pressure_from)
    out.params.update(geo_params)
    out.clock = clock
    return out


def process_session(path: str | os.PathLike[str], *, circuit: Circuit | None = None,
                    calibration: str | os.PathLike[str] | None = None, sensor: MPICreep | None = None,
                    g_rest: float = 0.0, pitch_cm: float | None = None, method: str | None = "newton",
                    threads: int | None = None, save: bool = True, progress: bool | None = None,
                    geometry: Geometry | None = None) -> Processed:
    """Process a recorded PSM session file (:func:`process_loaded`) and (``save``) store the products in it.

    The circuit is the session's stored calibration when it has one, else ``circuit`` (else
    ``Circuit()``); a ``calibration`` file then replaces its R_adc and R_mux (:func:`session_circuit`).
    Each frame is stepped with its own period from the device clock (v2), else the host clock.
    ``threads`` None (default) solves IECM on all cores; the other parameters are those of
    :func:`process_loaded`. G, g, pressure (kPa) and CoP (cm) are saved with the parameters that
    made them (:func:`psmat.io.save_products`).
    """
    from ..io import load_session, save_products

    s = load_session(path)
    try:
        out = process_loaded(s, circuit=circuit, calibration=calibration, sensor=sensor, g_rest=g_rest,
                             pitch_cm=pitch_cm, method=method, threads=threads, progress=progress, geometry=geometry)
    except ValueError as exc:
        raise ValueError(f"{path}: {exc}") from None
    if save:
        save_products(path, {"G": (out.G, out.params, "S"), "g": (out.g, out.params, "S"),
                             "pressure": (out.pressure_kpa, out.params, "kPa"), "cop": (out.cop_cm, out.params, "cm")})
    return out

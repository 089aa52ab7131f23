"""From ADC counts to pressure and centre of pressure: the mat's processing chain.

counts ─ :meth:`Circuit.conductance` (SPEC §2) → G ─ :func:`psmat.iecm.solve` (crosstalk
removed, SPEC §3) → g ─ :meth:`MPICreep.inverse` (hysteresis and creep compensated, SPEC §4)
→ pressure ─ :func:`psmat.balance.cop` (SPEC §7) → CoP.

Readings the chain cannot use are handled as stated, never turned into silent infinities:

* an **open** reading (at or above the open-circuit count: an unloaded cell whose resistance
  is beyond what the ADC resolves) becomes the smallest conductance the circuit can report
  (``Circuit`` at the largest non-open count) — a bias of at most one count on cells that
  carry no pressure;
* a **short** reading, or a frame that failed its check on the wire (``valid`` False),
  makes the whole frame missing: NaN in every product, the time base kept. The sensor
  model skips NaN samples, its state untouched.

:func:`process_session` runs the chain on a recorded session file and stores G, g,
pressure (kPa) and CoP beside the raw counts with the parameters that made them (SPEC §6).
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from . import iecm
from .balance import cop as _cop
from .circuit import OPEN, SHORT, Circuit
from .sensor import MPICreep
from .units import PSI_KPA

__all__ = ["Processed", "process_counts", "process_session", "open_floor", "PSI_KPA"]



@dataclass
class Processed:
    """Products of :func:`process_counts`, each (T, R, C) or (T, 2), NaN on missing frames."""

    G: NDArray[np.float64]  # equivalent conductances, S
    g: NDArray[np.float64]  # cell conductances after IECM, S
    pressure_kpa: NDArray[np.float64]  # compensated pressure, kPa
    cop_cm: NDArray[np.float64]  # (T, 2) centre of pressure (M-L, A-P), cm
    cop_raw_cm: NDArray[np.float64]  # (T, 2) CoP of the raw G (no IECM, no sensor model), cm
    usable: NDArray[np.bool_]  # (T,) frames that went through the chain
    params: dict[str, Any] = field(default_factory=dict)
    solve_info: Any = None


def open_floor(circuit: Circuit) -> float:
    """Smallest conductance (S) the circuit resolves: what an open reading is taken as for IECM."""
    G = circuit.conductance(np.arange(circuit.full_scale + 1))
    G = G[np.isfinite(G) & (G > 0)]
    if G.size == 0:
        raise ValueError("this circuit resolves no conductance at any count")
    return float(G.min())


def process_counts(counts: NDArray[Any], dt: float, *, valid: NDArray[np.bool_] | None = None,
                   circuit: Circuit | None = None, sensor: MPICreep | None = None, g_rest: float = 0.0,
                   pitch_cm: float = 2.0, method: str = "newton", threads: int | None = None,
                   progress: bool | None = None) -> Processed:
    """Run the chain (module docstring) on counts (T, R, C).

    Parameters
    ----------
    counts : array, (T, R, C)
        ADC counts.
    dt : float
        Frame period (s), for the sensor model's creep.
    valid : (T,) bool, optional
        Frames that passed their check on the wire; default all.
    circuit : Circuit, optional
        The box's measurement chain (with its calibration); default ``Circuit()``.
    sensor : MPICreep, optional
        Sensor model for compensation; default the thesis' (Table 2.11).
    g_rest : float
        Conductance of an unloaded cell (S), subtracted before the sensor model.
    pitch_cm : float
        Cell pitch for the CoP.
    method, threads, progress
        Passed to :func:`psmat.iecm.solve`.
    """
    c = np.asarray(counts)
    if c.ndim != 3:
        raise ValueError(f"counts must be (T, R, C), got shape {c.shape}")
    T = c.shape[0]
    valid = np.ones(T, bool) if valid is None else np.asarray(valid, bool)
    if valid.shape != (T,):
        raise ValueError(f"valid must be ({T},), got {valid.shape}")
    if not (np.isfinite(dt) and dt > 0):
        raise ValueError(f"dt must be a positive frame period in s, got {dt!r}")
    circuit = circuit or Circuit()
    sensor = sensor or MPICreep.thesis()
    G, flags = circuit.conductance(c, return_flags=True)
    G = np.where(flags == OPEN, open_floor(circuit), G)
    usable = valid & ~np.any(flags == SHORT, axis=(1, 2))
    G[~usable] = np.nan
    g = np.full_like(G, np.nan)
    info = None
    if usable.any():
        g[usable], info = iecm.solve(G[usable], method=method, threads=threads, progress=progress,
                                     return_info=True)
    u = np.maximum(g - g_rest, 0.0)  # NaN stays NaN: the sensor model skips those samples
    p_psi = sensor.inverse(u, dt)
    pressure = p_psi * PSI_KPA
    params = {"dt_s": float(dt), "circuit": circuit.as_dict(), "sensor": sensor.params, "g_rest_s": float(g_rest),
              "pitch_cm": float(pitch_cm), "iecm_method": method, "open_policy": "smallest resolvable G",
              "frames_missing": int((~usable).sum())}
    with np.errstate(invalid="ignore"):
        return Processed(G=G, g=g, pressure_kpa=pressure, cop_cm=_cop(np.nan_to_num(pressure), pitch_cm),
                         cop_raw_cm=_cop(np.nan_to_num(G), pitch_cm), usable=usable, params=params,
                         solve_info=info)


def _circuit_of(cal: dict | None) -> Circuit:
    """The circuit a session was recorded with: its calibration file (``psmat calibrate``),
    a stored ``Circuit.as_dict()``, or the default circuit."""
    from .calibration import Calibration

    if not cal:
        return Circuit()
    if cal.get("format") == "psmat-calibration":
        return Circuit.from_calibration(Calibration.from_dict(cal))
    keys = {"r_o_ohm": "r_o", "r_mux_ohm": "r_mux", "r_adc_ohm": "r_adc", "v_ref_volt": "v_ref", "bits": "bits",
            "sensor_side": "sensor_side"}
    return Circuit(**{arg: cal[k] for k, arg in keys.items() if k in cal})


def process_session(path: str | os.PathLike[str], *, circuit: Circuit | None = None,
                    sensor: MPICreep | None = None, g_rest: float = 0.0, pitch_cm: float = 2.0,
                    save: bool = True, progress: bool | None = None) -> Processed:
    """Process a recorded PSM session file and (``save``) store the products in it.

    The frame period is taken from the device clock (v2) or the host clock; the circuit
    from the session's calibration when it has one (``r_mux``, ``r_adc``), else ``circuit``.
    """
    from .io import load_session, save_product

    s = load_session(path)
    if s.kind != "psm":
        raise ValueError(f"{path}: a {s.kind!r} session; process_session handles mat (psm) sessions")
    if s.n_frames < 2:
        raise ValueError(f"{path}: {s.n_frames} frame(s); at least 2 are needed for a frame period")
    clock = s.device_time_us * 1e-6 if s.device_time_us is not None else s.host_time_s
    dt = float(np.median(np.diff(clock)))
    if circuit is None:
        circuit = _circuit_of(s.calibration)
    out = process_counts(s.counts, dt, valid=s.valid, circuit=circuit, sensor=sensor, g_rest=g_rest,
                         pitch_cm=pitch_cm, progress=progress)
    if save:
        save_product(path, "G", out.G, out.params, "S")
        save_product(path, "g", out.g, out.params, "S")
        save_product(path, "pressure", out.pressure_kpa, out.params, "kPa")
        save_product(path, "cop", out.cop_cm, out.params, "cm")
    return out

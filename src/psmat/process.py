"""From ADC counts to pressure and centre of pressure: the mat's one processing chain.

counts ─ :meth:`Circuit.conductance` (docs/spec.md §2) → G ─ :func:`psmat.iecm.solve` (crosstalk
removed, docs/spec.md §3) → g ─ :meth:`MPICreep.inverse` (hysteresis and creep compensated, docs/spec.md §4)
→ pressure ─ :func:`psmat.balance.cop` (docs/spec.md §7) → CoP.

:class:`Processor` is the chain on a stream: frames are pushed in chunks as they arrive and
the state carried between chunks (the IECM warm start and preconditioner, the sensor
model's operator state, the time since the last usable frame), so chunked pushes give the
numbers of one push. :func:`process_counts` is one push of a whole recording,
:func:`process_session` runs it on a recorded session file and stores G, g, pressure (kPa)
and CoP beside the raw counts with the parameters that made them (docs/spec.md §6); the live view
(:mod:`psmat.live`) pushes the frames it shows.

Readings the chain cannot use are handled one way everywhere, never turned into silent
infinities:

* an **open** reading (at or above the open-circuit count: an unloaded cell whose resistance
  is beyond what the ADC resolves) is the **open floor** in every product: the smallest
  conductance the circuit can report (:func:`open_floor`, ``Circuit`` at the largest
  non-open count). IECM needs a positive G there, and the same G gives the raw CoP, so the
  raw CoP is the CoP of the stored G; the bias is at most the floor (about 8e-8 S with the
  default circuit) per open cell, against about 1e-3 S on a loaded cell;
* a **short** reading, or a frame that failed its check on the wire (``valid`` False),
  makes the whole frame **missing**: NaN in every product, the time base kept. The sensor
  model does not see it; the next usable frame is stepped with the whole time since the
  previous usable one (its period plus the missing frames'), because the sensor creeps on
  while a frame is lost (eq. 2.23 with the pressure held).
"""

from __future__ import annotations

import os
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from . import _checks, iecm
from .balance import cop as _cop
from .circuit import OPEN, SHORT, Circuit
from .sensor import MPICreep
from .sensor.stepping import inverse_stepped, steps_over_gaps
from .units import PSI_KPA

__all__ = ["Processed", "Processor", "process_counts", "process_session", "session_circuit", "open_floor", "PSI_KPA"]

#: IECM positivity bound (S), iecm.solve's default, passed explicitly so the warnings quote it.
_G_FLOOR = 1e-12
#: frames queued in the one-worker IECM stream before a push takes results.
_PENDING = 256
#: SolveInfo fields that hold one value per frame.
_PER_FRAME = ("iterations", "factorizations", "krylov_iterations", "evaluations", "residual", "cost", "status",
              "converged", "used_fallback", "at_bound")


@dataclass
class Processed:
    """Products of a push (:meth:`Processor.push`, :func:`process_counts`).

    Each (T, R, C) or (T, 2), NaN on missing frames.
    """

    G: NDArray[np.float64]  # equivalent conductances, S
    g: NDArray[np.float64]  # cell conductances after IECM, S
    pressure_kpa: NDArray[np.float64]  # compensated pressure, kPa
    cop_cm: NDArray[np.float64]  # (T, 2) centre of pressure (M-L, A-P), cm
    cop_raw_cm: NDArray[np.float64]  # (T, 2) CoP of the raw G (no IECM, no sensor model), cm
    usable: NDArray[np.bool_]  # (T,) frames that went through the chain
    params: dict[str, Any] = field(default_factory=dict)
    solve_info: Any = None


def open_floor(circuit: Circuit) -> float:
    """Smallest conductance (S) the circuit resolves: what an open reading is taken as."""
    G = circuit.conductance(np.arange(circuit.full_scale + 1))
    G = G[np.isfinite(G) & (G > 0)]
    if G.size == 0:
        raise ValueError("this circuit resolves no conductance at any count")
    return float(G.min())


class Processor:
    """The chain counts → G → g → pressure → CoP on frames pushed in chunks, state carried between them.

    Parameters
    ----------
    shape : (int, int)
        Mat shape (R, C), R, C >= 2.
    circuit : Circuit, optional
        The box's measurement chain (with its calibration); default ``Circuit()``.
    sensor : MPICreep, optional
        Sensor model for compensation; default the thesis' (Table 2.11).
    g_rest : float
        Conductance of an unloaded cell (S), subtracted before the sensor model.
    pitch_cm : float
        Cell pitch for the CoP, cm.
    method : str or None
        IECM method (:func:`psmat.iecm.solve`); None computes G and the raw CoP only
        (g, pressure and CoP NaN).
    threads : int or None
        1 (default): IECM on one worker that solves the frames in order, each warm-started
        from the previous solution with its preconditioner kept, across pushes: chunked
        pushes give exactly the numbers of one push (those of ``iecm.solve(threads=1)``).
        More, or None for all cores: each push is one :func:`psmat.iecm.solve` batch split
        into contiguous runs solved in parallel, the first run warm-started from the previous
        push; faster on a long recording, the numbers then depend on the split (each frame
        within the solver's tolerance).

    Notes
    -----
    Open readings and missing frames follow the one policy of :mod:`psmat.process`.
    """

    def __init__(self, shape: tuple[int, int], *, circuit: Circuit | None = None, sensor: MPICreep | None = None,
                 g_rest: float = 0.0, pitch_cm: float = 2.0, method: str | None = "newton",
                 threads: int | None = 1) -> None:
        self.shape = _checks.shape2(shape)
        if min(self.shape) < 2:
            raise ValueError(f"shape must be (R, C) with R, C >= 2, got {shape}")
        if _checks.finite("g_rest", g_rest) < 0:
            raise ValueError(f"g_rest must be a conductance >= 0 S, got {g_rest!r}")
        if method is not None and method not in iecm.METHODS:
            raise ValueError(f"unknown method {method!r}; choose one of {iecm.METHODS} or None")
        self.threads = None if threads is None else _checks.positive_int("threads", threads)
        self.circuit = Circuit() if circuit is None else circuit
        self.sensor = MPICreep.thesis() if sensor is None else sensor
        self.g_rest = float(g_rest)
        self.pitch_cm = _checks.positive("pitch_cm", pitch_cm)
        self.method = method
        self.floor = open_floor(self.circuit)
        self._stream: iecm.Stream | None = None  # threads == 1: the worker keeps warm start and preconditioner
        self._g_last: NDArray[np.float64] | None = None  # threads != 1: the previous push's last solution
        self._state = self.sensor.rest_state(self.shape)
        self._since = 0.0  # time since the previous usable frame not yet stepped by the sensor model, s
        self._params = {"circuit": self.circuit.as_dict(), "sensor": self.sensor.params, "g_rest_s": self.g_rest,
                        "pitch_cm": self.pitch_cm, "iecm_method": method, "open_policy": "smallest resolvable G",
                        "missing_policy": "NaN; the sensor model steps over the gap"}

    def push(self, counts: ArrayLike, dt: float | ArrayLike, valid: ArrayLike | None = None, *,
             progress: bool | None = None) -> Processed:
        """Run the chain on the next frames.

        Parameters
        ----------
        counts : array, (T, R, C)
            ADC counts.
        dt : float or array (T,)
            Frame period, s: one for every frame, or each frame's time since the frame
            before it (for the first, since the previous push's last frame). The sensor
            model's creep steps with it.
        valid : (T,) bool, optional
            Frames that passed their check on the wire; default all.
        progress : bool, optional
            IECM progress bar (default: on for >= 2000 frames when writing to a terminal).

        Returns
        -------
        Processed
            The products of these T frames.
        """
        c = np.asarray(counts)
        if c.ndim != 3 or c.shape[1:] != self.shape:
            raise ValueError(f"counts must be (T, {self.shape[0]}, {self.shape[1]}), got shape {c.shape}")
        T = c.shape[0]
        valid = np.ones(T, bool) if valid is None else np.asarray(valid, bool)
        if valid.shape != (T,):
            raise ValueError(f"valid must be ({T},), got {valid.shape}")
        periods = _periods(dt, T)
        G, flags = self.circuit.conductance(c, return_flags=True)
        G = np.where(flags == OPEN, self.floor, G)
        usable = valid & ~np.any(flags == SHORT, axis=(1, 2))
        G[~usable] = np.nan
        steps, self._since = steps_over_gaps(periods, usable, self._since)
        g = np.full_like(G, np.nan)
        pressure = np.full_like(G, np.nan)
        info = None
        if self.method is not None and usable.any():
            g[usable], info = self._iecm(G[usable], progress)
            u = np.maximum(g[usable] - self.g_rest, 0.0)
            pressure[usable] = inverse_stepped(self.sensor, u, steps, self._state) * PSI_KPA
        params = {"dt_s": float(dt) if np.ndim(dt) == 0 else periods.tolist(), **self._params,
                  "frames_missing": int((~usable).sum())}
        return Processed(G=G, g=g, pressure_kpa=pressure, cop_cm=_cop(pressure, self.pitch_cm),
                         cop_raw_cm=_cop(G, self.pitch_cm), usable=usable, params=params, solve_info=info)

    def _iecm(self, G: NDArray[np.float64], progress: bool | None) -> tuple[NDArray[np.float64], iecm.SolveInfo]:
        """Crosstalk removal of the usable frames (S), warm-started across pushes."""
        if self.threads == 1:
            return self._solve_in_order(G, progress)
        g0 = None
        if self._g_last is not None:
            g0 = G.copy()  # iecm.solve starts the runs after the first from G, as without g0
            g0[0] = self._g_last
        g, info = iecm.solve(G, self.method, g0=g0, threads=self.threads, g_floor=_G_FLOOR, progress=progress,
                             return_info=True)
        self._g_last = g[-1].copy()
        return g, info

    def _solve_in_order(self, G: NDArray[np.float64], progress: bool | None) -> tuple[NDArray[np.float64],
                                                                                         iecm.SolveInfo]:
        """IECM on the carried one-worker stream, frame after frame."""
        from psmat._progress import tqdm

        if self._stream is None:
            self._stream = iecm.Stream(self.shape, str(self.method), threads=1, max_pending=_PENDING,
                                       g_floor=_G_FLOOR)
        s = self._stream
        g = np.empty_like(G)
        infos = []
        show = progress if progress is not None else len(G) >= 2000
        t0 = time.perf_counter()
        pushed = 0
        with tqdm(total=len(G), unit="frame", desc="IECM", disable=None if show else True, leave=False) as bar:
            for k in range(len(G)):
                while pushed < len(G) and s.pending < s.max_pending:  # this thread is also the consumer
                    s.push(G[pushed])
                    pushed += 1
                _, g[k], frame_info = s.pop(None)
                infos.append(frame_info)
                bar.update(1)
        info = iecm.SolveInfo(**{n: np.array([getattr(i, n) for i in infos]) for n in _PER_FRAME},
                              method=str(self.method), wall_time=time.perf_counter() - t0, threads=1)
        info.warn_unconverged(_G_FLOOR, stacklevel=5)  # as iecm.solve does, at the caller of push
        return g, info

    def close(self) -> None:
        """Stop the IECM worker (a later push starts a new one, cold)."""
        if self._stream is not None:
            self._stream.close()
            self._stream = None

    def __enter__(self) -> Processor:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def _periods(dt: float | ArrayLike, T: int) -> NDArray[np.float64]:
    """Each frame's period (T,), s, from one period or one per frame."""
    if np.ndim(dt) == 0:
        return np.full(T, _checks.positive("dt", dt))
    periods = _checks.vector("dt", dt)
    if periods.shape != (T,):
        raise ValueError(f"dt must be one frame period or one per frame ({T},), got shape {periods.shape}")
    if np.any(periods <= 0):
        k = int(np.flatnonzero(periods <= 0)[0])
        raise ValueError(f"dt must be > 0 s for every frame; frame {k} has {periods[k]!r}")
    return periods


def process_counts(counts: NDArray[Any], dt: float | ArrayLike, *, valid: NDArray[np.bool_] | None = None,
                   circuit: Circuit | None = None, sensor: MPICreep | None = None, g_rest: float = 0.0,
                   pitch_cm: float = 2.0, method: str | None = "newton", threads: int | None = None,
                   progress: bool | None = None) -> Processed:
    """Run the chain (:mod:`psmat.process`) on a recording: one push of all its frames.

    Parameters
    ----------
    counts : array, (T, R, C)
        ADC counts.
    dt : float or array (T,)
        Frame period (s), for the sensor model's creep; or each frame's period.
    valid : (T,) bool, optional
        Frames that passed their check on the wire; default all.
    circuit : Circuit, optional
        The box's measurement chain (with its calibration); default ``Circuit()``.
    sensor : MPICreep, optional
        Sensor model for compensation; default the thesis' (Table 2.11).
    g_rest : float
        Conductance of an unloaded cell (S), subtracted before the sensor model.
    pitch_cm : float
        Cell pitch for the CoP, cm.
    method, threads
        As :class:`Processor`; ``threads`` None (default) uses all cores.
    progress : bool, optional
        IECM progress bar (default: on for >= 2000 frames when writing to a terminal).
    """
    c = np.asarray(counts)
    if c.ndim != 3:
        raise ValueError(f"counts must be (T, R, C), got shape {c.shape}")
    with Processor(c.shape[1:], circuit=circuit, sensor=sensor, g_rest=g_rest, pitch_cm=pitch_cm, method=method,
                   threads=threads) as proc:
        return proc.push(c, dt, valid=valid, progress=progress)


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


def session_circuit(stored: dict | None, device: dict[str, Any],
                    calibration: str | os.PathLike[str] | None = None) -> Circuit:
    """The circuit of a recorded session, with a box calibration file's R_adc and R_mux if one is given.

    Parameters
    ----------
    stored : dict or None
        The session's stored calibration (``Session.calibration``).
    device : dict
        The session's device description; its ``serial`` must match the calibration file's.
    calibration : path, optional
        A calibration file (``psmat calibrate``, JSON) whose ``r_adc`` and ``r_mux`` replace the
        stored ones (:meth:`Circuit.calibrated`).
    """
    from .calibration import Calibration

    circuit = _circuit_of(stored)
    if calibration is None:
        return circuit
    cal = Calibration.load(calibration)
    serial = device.get("serial")
    if cal.serial and serial is not None and str(serial) != cal.serial:
        raise ValueError(f"{os.path.basename(calibration)} is box {cal.serial!r}; the session was recorded with "
                         f"box {serial!r}")
    return circuit.calibrated(cal)


def process_session(path: str | os.PathLike[str], *, circuit: Circuit | None = None,
                    sensor: MPICreep | None = None, g_rest: float = 0.0, pitch_cm: float = 2.0,
                    save: bool = True, progress: bool | None = None) -> Processed:
    """Process a recorded PSM session file and (``save``) store the products in it.

    The frame period is taken from the device clock (v2) or the host clock; the circuit
    from the session's calibration when it has one (``r_mux``, ``r_adc``), else ``circuit``.
    """
    from .io import load_session, save_products

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
        save_products(path, {"G": (out.G, out.params, "S"), "g": (out.g, out.params, "S"),
                             "pressure": (out.pressure_kpa, out.params, "kPa"), "cop": (out.cop_cm, out.params, "cm")})
    return out

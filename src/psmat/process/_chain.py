"""The chain counts → G → g → pressure → CoP on frames pushed in chunks (:class:`Processor`),
and on a whole recording in one push (:func:`process_counts`); the policy for open readings
and missing frames is the package's (:mod:`psmat.process`)."""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .. import _checks, iecm
from ..balance import cop
from ..circuit import OPEN, SHORT, Circuit
from ..pressure import PressureCalibration
from ..pressure import describe as describe_pressure
from ..profile import Geometry, geometry_for
from ..sensor import MPICreep, frame_periods, steps_over_gaps
from ..units import PSI_KPA
from ._clock import SessionClock

__all__ = ["Processed", "Processor", "process_counts", "open_floor"]

#: IECM positivity bound (S), iecm.solve's default, passed explicitly so the warnings quote it.
_G_FLOOR = 1e-12
#: IECM stopping rule of the chain: the frame's relative (complementarity) residual, dimensionless. The
#: accuracy bar of docs/spec.md §10's noisy targets, far below what a 12-bit reading resolves (one count
#: is at least 2.4e-4 of the reading); iecm.solve's own default is 1e-10 (docs/spec.md §3).
IECM_RTOL = 1e-6
#: frames queued in the one-worker IECM stream before a push takes results.
_PENDING = 256
#: SolveInfo fields that hold one value per frame.
_PER_FRAME = ("iterations", "factorizations", "krylov_iterations", "evaluations", "residual", "cost", "status",
              "converged", "used_fallback", "at_bound")


@dataclass
class Processed:
    """Products of the chain (:meth:`Processor.push`, :func:`process_counts`, :func:`process_loaded`).

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
    clock: SessionClock | None = None  # a recorded session's frame times and periods (process_loaded)


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
        Sensor model for compensation; default the pressure calibration's when it has one, else
        the thesis' (Table 2.11).
    g_rest : float
        Conductance of an unloaded cell (S), subtracted before the sensor model.
    mat_calibration : PressureCalibration, optional
        The mat's pressure calibration (:mod:`psmat.pressure`): the sensor model runs on
        ``max(g − g_rest, 0) · gains · scale``; ``params["pressure_calibration"]`` says which
        (``"uncalibrated: ..."`` without one).
    pitch_cm : float, optional
        Cell pitch for the CoP (cm) of a mat in the default orientation; not with ``geometry``.
    geometry : psmat.profile.Geometry, optional
        Where the cells are, for the CoP (a profile's ``geometry``); neither this nor
        ``pitch_cm``: the default profile's geometry (docs/spec.md §5 "Device profiles").
    method : str or None
        IECM method (:func:`psmat.iecm.solve`); None computes G and the raw CoP only
        (g, pressure and CoP NaN).
    threads : int or None
        1 (default): IECM on one worker that solves the frames in order, each warm-started
        from the previous solution with its preconditioner kept, across pushes: chunked
        pushes give exactly the numbers of one push (those of ``iecm.solve(threads=1, rtol=IECM_RTOL)``).
        More, or None for all cores: each push is one :func:`psmat.iecm.solve` batch split
        into contiguous runs solved in parallel, the first run warm-started from the previous
        push; faster on a long recording, the numbers then depend on the split (each frame
        within the solver's tolerance).
    stream : bool
        ``threads=1`` only. True (default): the one worker above, for frames that arrive in
        chunks (live). False: each push is one ``iecm.solve(threads=1, rtol=IECM_RTOL)`` batch in this thread,
        warm-started from the previous push's last solution (not its preconditioner): for a
        whole recording in one push (:func:`process_loaded`) the same numbers as the worker
        without its per-frame hand-off.
    pressure : bool
        True (default): the sensor model runs on g and gives pressure and CoP. False: the chain
        stops at g, ``pressure_kpa`` and ``cop_cm`` are NaN (for a caller that runs its own
        recipes on g, e.g. :func:`psmat.balance.variant_traces`); ``cop_raw_cm`` is computed.

    Notes
    -----
    Open readings and missing frames follow the one policy of :mod:`psmat.process`.
    """

    def __init__(self, shape: tuple[int, int], *, circuit: Circuit | None = None, sensor: MPICreep | None = None,
                 g_rest: float = 0.0, pitch_cm: float | None = None, method: str | None = "newton",
                 threads: int | None = 1, mat_calibration: PressureCalibration | None = None,
                 geometry: Geometry | None = None, stream: bool = True, pressure: bool = True) -> None:
        self.shape = _checks.shape2(shape)
        if min(self.shape) < 2:
            raise ValueError(f"shape must be (R, C) with R, C >= 2, got {shape}")
        if _checks.finite("g_rest", g_rest) < 0:
            raise ValueError(f"g_rest must be a conductance >= 0 S, got {g_rest!r}")
        if method is not None and method not in iecm.METHODS:
            raise ValueError(f"unknown method {method!r}; choose one of {iecm.METHODS} or None")
        self.threads = None if threads is None else _checks.positive_int("threads", threads)
        self.circuit = Circuit() if circuit is None else circuit
        if mat_calibration is not None and not isinstance(mat_calibration, PressureCalibration):
            raise TypeError(f"mat_calibration must be a PressureCalibration, got {type(mat_calibration).__name__}")
        if mat_calibration is not None and mat_calibration.sensor is not None and sensor is not None:
            raise ValueError("the pressure calibration has its own sensor model; pass no sensor")
        gains = None if mat_calibration is None else mat_calibration.gains
        if gains is not None and gains.shape != self.shape:
            raise ValueError(f"the pressure calibration is for a {gains.shape[0]}x{gains.shape[1]} mat, this one is "
                             f"{self.shape[0]}x{self.shape[1]}")
        self.mat_calibration = mat_calibration
        self.sensor = sensor or (mat_calibration.sensor if mat_calibration is not None else None) or MPICreep.thesis()
        self.g_rest = float(g_rest)
        self.geometry = geometry_for(self.shape, pitch_cm=pitch_cm, geometry=geometry)
        self.pitch_cm = self.geometry.pitch_cm
        self.method = method
        self.stream = bool(stream)
        self.pressure = bool(pressure)
        self.floor = open_floor(self.circuit)
        self._stream: iecm.Stream | None = None  # threads == 1: the worker keeps warm start and preconditioner
        self._g_last: NDArray[np.float64] | None = None  # batch pushes: the previous push's last solution
        self._state = self.sensor.rest_state(self.shape)
        self._since = 0.0  # time since the previous usable frame not yet stepped by the sensor model, s
        self._params = {"circuit": self.circuit.as_dict(), "sensor": self.sensor.params, "g_rest_s": self.g_rest,
                        "pitch_cm": self.pitch_cm, "geometry": self.geometry.to_dict(),
                        "iecm_method": method, "iecm_rtol": IECM_RTOL, "open_policy": "smallest resolvable G",
                        "missing_policy": "NaN; the sensor model steps over the gap",
                        "pressure_calibration": describe_pressure(mat_calibration)}
        if not self.pressure:
            self._params["pressure"] = "not computed: the chain stops at g"

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
        periods = frame_periods(dt, T)
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
        if self.method is not None and usable.any() and self.pressure:
            u = np.maximum(g[usable] - self.g_rest, 0.0)
            if self.mat_calibration is not None:
                u = self.mat_calibration.effective(u)
            pressure[usable] = self.sensor.inverse(u, steps, self._state) * PSI_KPA
        params = {"dt_s": float(dt) if np.ndim(dt) == 0 else periods.tolist(), **self._params,
                  "frames_missing": int((~usable).sum())}
        cop_p = cop(pressure, geometry=self.geometry) if self.pressure else np.full((T, 2), np.nan)
        return Processed(G=G, g=g, pressure_kpa=pressure, cop_cm=cop_p,
                         cop_raw_cm=cop(G, geometry=self.geometry), usable=usable, params=params, solve_info=info)

    def _iecm(self, G: NDArray[np.float64], progress: bool | None) -> tuple[NDArray[np.float64], iecm.SolveInfo]:
        """Crosstalk removal of the usable frames (S), warm-started across pushes."""
        if self.threads == 1 and self.stream:
            return self._iecm_in_order(G, progress)
        g0 = None
        if self._g_last is not None:
            g0 = G.copy()  # iecm.solve starts the runs after the first from G, as without g0
            g0[0] = self._g_last
        g, info = iecm.solve(G, self.method, g0=g0, threads=self.threads, rtol=IECM_RTOL, g_floor=_G_FLOOR,
                             progress=progress, return_info=True)
        self._g_last = g[-1].copy()
        return g, info

    def _iecm_in_order(self, G: NDArray[np.float64], progress: bool | None) -> tuple[NDArray[np.float64],
                                                                                        iecm.SolveInfo]:
        """IECM on the carried one-worker stream (:meth:`psmat.iecm.Stream.process`), frame after frame."""
        from .._progress import tqdm

        if self._stream is None:
            self._stream = iecm.Stream(self.shape, str(self.method), threads=1, max_pending=_PENDING,
                                       rtol=IECM_RTOL, g_floor=_G_FLOOR)
        g = np.empty_like(G)
        infos = []
        show = progress if progress is not None else len(G) >= 2000
        t0 = time.perf_counter()
        with tqdm(total=len(G), unit="frame", desc="IECM", disable=None if show else True, leave=False) as bar:
            for k, (_, g_k, frame_info) in enumerate(self._stream.process(G, close=False)):
                g[k] = g_k
                infos.append(frame_info)
                bar.update(1)
        info = iecm.SolveInfo(**{n: np.array([getattr(i, n) for i in infos]) for n in _PER_FRAME},
                              method=str(self.method), wall_time_s=time.perf_counter() - t0, threads=1)
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


def process_counts(counts: NDArray[Any], dt: float | ArrayLike, *, valid: NDArray[np.bool_] | None = None,
                   circuit: Circuit | None = None, sensor: MPICreep | None = None, g_rest: float = 0.0,
                   pitch_cm: float | None = None, method: str | None = "newton", threads: int | None = None,
                   progress: bool | None = None, geometry: Geometry | None = None) -> Processed:
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
    pitch_cm, geometry
        Where the cells are, for the CoP, as :class:`Processor` (default the default profile's).
    method, threads
        As :class:`Processor`; ``threads`` None (default) uses all cores.
    progress : bool, optional
        IECM progress bar (default: on for >= 2000 frames when writing to a terminal).
    """
    c = np.asarray(counts)
    if c.ndim != 3:
        raise ValueError(f"counts must be (T, R, C), got shape {c.shape}")
    with Processor(c.shape[1:], circuit=circuit, sensor=sensor, g_rest=g_rest, pitch_cm=pitch_cm, method=method,
                   threads=threads, geometry=geometry) as proc:
        return proc.push(c, dt, valid=valid, progress=progress)

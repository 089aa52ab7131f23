"""What the simulated devices measure, one tick at a time (docs/spec.md §5).

* :class:`PsmSource` — a pressure scene (:mod:`psmat.twin.scenes`) played through the mat's
  physics (:class:`psmat.twin.mat.MatPhysics`): ADC counts per frame. Scenes: ``"sway"`` (a
  person whose CoP follows a recorded force-platform trajectory from the BDS data set shipped
  with psmat; a trial that cannot be found is an error, never a substitute), ``"quiet"``, ``"single-leg"``, ``"sitting"``
  (the seated twin following the thesis' posture protocol, :mod:`psmat.twin.seated`).
  The scene loops when it ends; the sensor state carries on.
* :class:`ImuSource` — the five spine IMUs' Euler angles (degrees) of the seated twin following
  the protocol (the same person and session as the ``"sitting"`` scene of the same seed), with
  the device's drift, noise and 1/16° steps (:mod:`psmat.twin.seated`).
* :class:`DaqSource` — the material DAQ's ten sensors on the pneumatic platform (counts).

Sources are computed in blocks (one ``forward`` batch per block), so a tick costs a copy.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from .. import _checks
from ..profile import Profile, default_geometry
from . import scenes as _scenes
from .mat import MatPhysics
from .seated import draw_imu_device, imu_readings, seated_session
from .sway import time_base

__all__ = ["PsmSource", "ImuSource", "DaqSource", "CalibrationFixture", "SCENES", "make_scene", "check_scene",
           "MAX_SCENE_VALUES"]

SCENES = ("sway", "quiet", "single-leg", "sitting")
#: the most pressure values (frames x cells) a scene holds: 2**28 float64, 2 GiB
MAX_SCENE_VALUES = 2**28


def check_scene(duration_s: float, rate_hz: float, shape: tuple[int, int]) -> tuple[float, float]:
    """``(rate_hz, duration_s)`` checked for a scene (:func:`make_scene`), or ValueError: a rate above
    the PSM firmware's 1000 Hz, a duration that is not a positive number, or more than
    :data:`MAX_SCENE_VALUES` pressure values (frames x cells)."""
    rate_hz = _checks.rate_hz("rate_hz", rate_hz)
    duration_s = _checks.positive("duration_s", duration_s)
    R, C = _checks.shape2(shape)
    values = math.ceil(duration_s * rate_hz) * R * C
    if values > MAX_SCENE_VALUES:
        raise ValueError(f"a scene of {duration_s:g} s at {rate_hz:g} Hz on {R}x{C} cells holds {values:,} pressure "
                         f"values ({8 * values / 1e9:.3g} GB); at most {MAX_SCENE_VALUES:,} (shorten duration_s or "
                         "lower rate_hz)")
    return rate_hz, duration_s


def make_scene(name: str, duration_s: float, rate_hz: float, shape: tuple[int, int] = (16, 16), *,
               bds_trial: int = 1, seed: int = 0, pitch_cm: float | None = None) -> _scenes.PressureScene:
    """A named pressure scene (psi) of ``duration_s`` at ``rate_hz`` (see the module docstring), on a mat of
    ``shape`` cells at ``pitch_cm`` (default the thesis mat's pitch, :func:`psmat.profile.default_geometry`).

    Raises
    ------
    ValueError
        A rate above the PSM firmware's 1000 Hz, a duration that is not a positive number, or a
        scene of more than :data:`MAX_SCENE_VALUES` pressure values; checked before anything is
        computed.
    """
    rate_hz, duration_s = check_scene(duration_s, rate_hz, shape)
    pitch = default_geometry().pitch_cm if pitch_cm is None else _checks.positive("pitch_cm", pitch_cm)
    if name == "sway":
        from ..io import bds_trial as _bds

        rec = _bds(bds_trial)  # a missing trial is a one-line FileNotFoundError, never a substitute scene
        keep = rec.t <= rec.t[0] + duration_s
        scene = _scenes.trajectory_sway(rec.t[keep], rec.cop_ml_cm[keep], rec.cop_ap_cm[keep],
                                          rec.fz_n[keep], rate_hz, shape, pitch)
        scene.meta["source"] = f"BDS{bds_trial:05d}"
        return scene
    if name == "sitting":
        return seated_session(seed, shape=shape, pitch_cm=pitch).pressure(time_base(duration_s, rate_hz)[0], shape,
                                                                         pitch)
    makers = {"quiet": _scenes.quiet_standing, "single-leg": _scenes.single_leg_sway}
    if name not in makers:
        raise ValueError(f"unknown scene {name!r}; choose one of {', '.join(SCENES)}")
    return makers[name](duration_s, rate_hz, shape, pitch_cm=pitch, seed=seed)


@dataclass
class PsmSource:
    """Counts (R, C) uint16 per tick of a scene played through the mat's physics."""

    scene: _scenes.PressureScene
    physics: MatPhysics
    block: int = 64
    #: the mat's profile when its rows and columns are sent in another order than the logical one:
    #: the counts come out in wire order (:meth:`psmat.Profile.logical_to_wire`), as a reader sees them
    wire: Profile | None = None

    def __post_init__(self) -> None:
        if self.scene.pressure_psi.shape[1:] != self.physics.shape:
            raise ValueError("the scene and the mat physics have different shapes")
        if self.wire is not None and tuple(self.wire.shape) != self.physics.shape:
            raise ValueError(f"the wire order is for a {self.wire.shape} mat, the physics is {self.physics.shape}")
        self._k = 0  # frame index into the scene (wraps)
        self._buf = np.empty((0, *self.physics.shape), np.uint16)
        self._pos = 0
        self.frames = 0  # frames produced

    @classmethod
    def named(cls, scene: str = "sway", rate_hz: float = 100.0, shape: tuple[int, int] | None = None, *,
              duration_s: float = 60.0, bds_trial: int = 1, seed: int = 0, profile: Profile | None = None,
              **physics) -> "PsmSource":
        """A named scene (:func:`make_scene`) played through a mat's physics.

        ``profile`` (a mat's :class:`psmat.Profile`) gives the shape, the pitch the scene is drawn
        at, the circuit (unless ``circuit=`` is passed among ``physics``) and the wire order of the
        counts; without it the mat is the thesis' (``shape`` default 16 x 16). ``physics`` are
        further :class:`MatPhysics` arguments.
        """
        if profile is not None:
            if profile.kind != "psm":
                raise ValueError(f"profile {profile.name!r} is a {profile.kind}, not a mat")
            if shape is not None and tuple(shape) != tuple(profile.shape):
                raise ValueError(f"shape {tuple(shape)} is not the profile's {tuple(profile.shape)}")
            shape = tuple(profile.shape)
            physics.setdefault("circuit", profile.circuit())
        shape = (16, 16) if shape is None else tuple(shape)
        sc = make_scene(scene, duration_s, rate_hz, shape, bds_trial=bds_trial, seed=seed,
                        pitch_cm=None if profile is None else profile.pitch_cm)
        wire = profile if profile is not None and (profile.row_order or profile.col_order) else None
        return cls(sc, MatPhysics(shape=shape, dt=1.0 / rate_hz, seed=seed, **physics), wire=wire)

    def _refill(self) -> None:
        T = self.scene.pressure_psi.shape[0]
        idx = (self._k + np.arange(self.block)) % T
        self._k = int((self._k + self.block) % T)
        self._buf = self.physics.counts(self.scene.pressure_psi[idx])
        if self.wire is not None:
            self._buf = self.wire.logical_to_wire(self._buf)
        self._pos = 0

    def next(self) -> NDArray[np.uint16]:
        """The counts of the next frame."""
        if self._pos >= len(self._buf):
            self._refill()
        c = self._buf[self._pos]
        self._pos += 1
        self.frames += 1
        return c


@dataclass
class ImuSource:
    """Euler angles (5, 3) degrees per tick — heading, roll, pitch of each spine IMU, sensor 1 the
    cervical one — of the seated twin following the posture protocol (about 175 s, then again).

    ``angles_deg`` (T, 5, 3), when given, are served instead (in turn, looping).
    """

    rate_hz: float = 10.0
    seed: int = 0
    angles_deg: NDArray[np.float32] | None = None

    def __post_init__(self) -> None:
        if self.angles_deg is None:
            session = seated_session(self.seed)
            t = np.arange(int(session.duration_s * self.rate_hz)) / self.rate_hz
            rng = np.random.default_rng([self.seed, 1])
            device = draw_imu_device(rng, "TWINIMU1")
            self.angles_deg, _ = imu_readings(session.true_angles(t), self.rate_hz, device, rng)
        self.angles_deg = np.asarray(self.angles_deg, dtype=np.float32)
        if self.angles_deg.ndim != 3 or self.angles_deg.shape[1:] != (5, 3) or self.angles_deg.shape[0] < 1:
            raise ValueError(f"angles_deg must be (T, 5, 3) degrees, got shape {self.angles_deg.shape}")
        self._k = 0

    def next(self) -> NDArray[np.float32]:
        """The angles (5, 3) in degrees of the next tick."""
        a = self.angles_deg[self._k % self.angles_deg.shape[0]]
        self._k += 1
        return a


@dataclass
class DaqSource:
    """Ten sensors' 10-bit counts per 500 ms tick on the pneumatic platform (docs/spec.md §4 protocols)."""

    protocol: str = "descending"
    seed: int = 0

    def __post_init__(self) -> None:
        from ..sensor import protocols
        from ..sensor.pneumatic import divider_counts, simulate_run

        make = {"descending": protocols.descending_hysteresis, "ascending": protocols.ascending_hysteresis}
        if self.protocol not in make:
            raise ValueError(f"unknown protocol {self.protocol!r}; choose one of {', '.join(make)}")
        run = simulate_run(make[self.protocol](), cells=10, rng=self.seed)
        self._counts = np.asarray(divider_counts(run.g), dtype=np.uint16)
        self._k = 0

    def next(self) -> NDArray[np.uint16]:
        c = self._counts[self._k % len(self._counts)]
        self._k += 1
        return c


@dataclass
class CalibrationFixture:
    """The calibration set-ups of docs/spec.md §2 on the twin: what the box reads with the mat
    unplugged (every cell open) or with one row wired to one column (a short), through the
    same measurement chain; ``mode = "mat"`` passes the mat's own frames through.

    Set ``mode`` to ``"mat"``, ``"open"`` or ``("short", row, col)`` while the twin runs.
    """

    mat: PsmSource
    mode: object = "mat"
    wire_s: float = 1e6  # a wire: 1 µΩ

    def next(self) -> NDArray[np.uint16]:
        frame = self.mat.next()  # the mat's time goes on (and its sensor state) whatever is plugged
        if self.mode == "mat":
            return frame
        phys = self.mat.physics
        G = np.zeros(phys.shape)
        if self.mode != "open":
            kind, i, p = self.mode  # type: ignore[misc]
            if kind != "short":
                raise ValueError(f"mode must be 'mat', 'open' or ('short', row, col), got {self.mode!r}")
            G[i, p] = self.wire_s
        counts = phys.circuit.counts(G, noise_v=phys.noise_v, rng=phys._rng)
        # (i, p) is a logical row and column: on the wire they come in the mat's order, as its frames do
        return counts if self.mat.wire is None else self.mat.wire.logical_to_wire(counts)

"""One trial of the honest simulation of a balance study (:mod:`psmat.synth._balance`): the true CoP trajectory on
the platform's clock, what the platform records, and the mat's session, frame chunk by chunk.

Clocks (thesis §3.2.1: the instruments "were started independently"): the platform's clock is
the reference, its samples at ``j / PLATFORM_RATE_HZ`` from 0. The mat's frame ``k`` happens at
platform time ``lead + k·T·(1 + e)`` (``T`` its nominal period, ``e`` its clock's error) and is
stamped by the box's µs counter ``d0 + k·T``, so in the convention of
:func:`psmat.balance.align` (``cop(t) ≈ cop_ref(t + lag)``) the lag at frame ``k`` is
``lead − d0 + k·T·e``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..io import SessionWriter
from ..twin import MatPhysics
from ..twin.field import mat_centre_cm
from ..twin.scenes import stance_groups, trajectory_sway
from ..twin.steering import convex_hull, solve_group_fractions
from ..twin.sway import band_noise
from ._lab import MatTally, host_times, write_mat_chunk

__all__ = ["PLATFORM_RATE_HZ", "TRIALS", "STANCE", "Source", "Trajectory", "plan_trajectory", "platform_table",
           "record_session", "SessionTruth"]

#: The platform's rate in the thesis' second experiment (Table 3.4: PS-2141 at 100 Hz).
PLATFORM_RATE_HZ = 100.0
#: Trials of thesis §3.2.1, in the order performed, and the feet on the mat in each.
TRIALS = ("right-leg", "left-leg", "rotation")
#: ("romberg", two feet, eyes open then closed, is the optional fourth trial of ``--romberg``.)
STANCE = {"right-leg": "right", "left-leg": "left", "rotation": "two", "romberg": "two"}
#: Single-leg sway against the two-legged BDS trials: about twice as large with eyes open
#: (double- to single-leg stance, J. Biomech. 2020, "Transition from double-leg to single-leg
#: stance in the assessment of postural stability"), capped by the foot's reach.
SINGLE_LEG_SCALE = 2.0
#: Share of the way to the edge of the feet's reach the scaled trajectory may use.
REACH_MARGIN = 0.8
#: Trunk circles (thesis §3.2.1: "about half cycle per second"): frequency (Hz) and the
#: CoP's semi-axes (cm; our choice, the thesis gives none), drawn per trial; frequency and
#: amplitude wander by this log-SD over 10–100 s; the circles start 1–3 s into the recording
#: and ramp in over RAMP_S.
ROTATION_HZ = (0.4, 0.6)
ROTATION_CM = (2.0, 4.0)
ROTATION_WANDER = 0.1
RAMP_S = 2.0
#: How far the feet's nominal CoP may stand from the mat centre (cm, each axis).
PLACEMENT_CM = 1.0
#: Least share of the load every group of a foot keeps (the scenes' default).
MIN_FRACTION = 0.02
#: Frames per chunk of the mat's simulation (bounded memory).
CHUNK = 1000


@dataclass(frozen=True)
class Source:
    """A force-platform recording used as the sway of a trial (BDS: 100 Hz, M-L, A-P, Fz)."""

    name: str
    t: NDArray[np.float64]
    ml_cm: NDArray[np.float64]
    ap_cm: NDArray[np.float64]
    fz_n: NDArray[np.float64]

    @property
    def rate_hz(self) -> float:
        return float((self.t.size - 1) / (self.t[-1] - self.t[0]))


@dataclass
class Trajectory:
    """The true CoP of a trial on the platform's clock, on the source's sample grid.

    ``t`` (s, platform clock), ``cop_cm`` (M, 2) in mat coordinates, ``fz_n`` (M,) N; between
    samples the CoP and the force are linear (what both instruments sample).
    """

    t: NDArray[np.float64]
    cop_cm: NDArray[np.float64]
    fz_n: NDArray[np.float64]
    info: dict[str, Any] = field(default_factory=dict)

    def at(self, times: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """CoP (n, 2) cm and force (n,) N at platform-clock times."""
        cop = np.column_stack([np.interp(times, self.t, self.cop_cm[:, k]) for k in range(2)])
        return cop, np.interp(times, self.t, self.fz_n)


def _reflect(i: NDArray[np.int64], n: int) -> NDArray[np.int64]:
    """Indices into a recording of n samples played forwards, backwards, forwards, ... (no jump)."""
    if n == 1:
        return np.zeros_like(i)
    j = i % (2 * (n - 1))
    return np.where(j < n, j, 2 * (n - 1) - j)


def _scale_within_reach(groups: Any, nominal: NDArray[np.float64], position: NDArray[np.float64],
                        disp: NDArray[np.float64], wanted: float, min_fraction: float) -> float:
    """``min(wanted, REACH_MARGIN · k_max)``: ``k_max`` the largest k with ``position + k·disp``
    reachable by the groups (the steering's own reach, :func:`solve_group_fractions`)."""
    centroids = np.array([lobes.cop_cm for _, lobes in groups])
    try:
        pts = convex_hull(disp)  # a convex reach holds the trajectory iff it holds its hull
    except ValueError:
        pts = disp

    def inside(k: float) -> bool:
        target = position + k * pts
        return bool(np.all(solve_group_fractions(centroids, nominal, target, min_fraction)[1] == target))

    hi = wanted / REACH_MARGIN
    if inside(hi):
        return wanted
    lo = 0.0
    for _ in range(40):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if inside(mid) else (lo, mid)
    return REACH_MARGIN * lo


def _rotation(t: NDArray[np.float64], fs: float, t_on: float, rng: np.random.Generator) -> tuple[NDArray, dict]:
    """Trunk circles seen from above (thesis §3.2.1 "Rotation"): (M, 2) cm and their parameters."""
    f0 = float(rng.uniform(*ROTATION_HZ))
    a = rng.uniform(*ROTATION_CM, size=2)
    turn = 1.0 if rng.random() < 0.5 else -1.0
    phase0 = float(rng.uniform(0.0, 2.0 * np.pi))
    band = (0.01, 0.1)
    freq = f0 * np.exp(ROTATION_WANDER * band_noise(t.size, fs, band, rng))
    amp = np.exp(ROTATION_WANDER * band_noise(t.size, fs, band, rng))
    phase = phase0 + 2.0 * np.pi * np.concatenate([[0.0], np.cumsum(freq[:-1]) / fs])
    ramp = np.clip((t - t_on) / RAMP_S, 0.0, 1.0)
    env = amp * 0.5 * (1.0 - np.cos(np.pi * ramp))  # raised-cosine start
    circle = np.column_stack([a[0] * env * np.cos(phase), turn * a[1] * env * np.sin(phase)])
    info = {"freq_hz": f0, "semi_axes_cm": a.tolist(), "direction": "counter-clockwise" if turn > 0 else "clockwise",
            "start_s": t_on, "ramp_s": RAMP_S, "wander": ROTATION_WANDER}
    return circle, info


def plan_trajectory(trial: str, src: Source, span: tuple[float, float], weight_n: float, shape: tuple[int, int],
                    pitch_cm: float, foot: dict[str, float], rng: np.random.Generator,
                    position_cm: NDArray[np.float64] | None = None) -> Trajectory:
    """The true trajectory of ``trial`` over the platform-clock ``span`` (s), drawn from ``src``.

    The source is cut at a random start, played back and forth if it is too short, its mean
    removed (its sway around the feet's nominal CoP, placed within :data:`PLACEMENT_CM` of the
    mat centre), scaled for a single-leg trial, plus trunk circles for ``"rotation"``; its
    force scaled to the body weight. ``position_cm`` (mat coordinates, cm) places the feet where
    an earlier part of the same stance left them instead of drawing a place (no draw then).
    """
    fs = src.rate_hz
    lo = math.floor(span[0] * fs) - 1
    n = math.ceil(span[1] * fs) + 2 - lo
    looped = n > src.t.size
    i0 = int(rng.integers(0, src.t.size)) if looped else int(rng.integers(0, src.t.size - n + 1))
    idx = _reflect(i0 + np.arange(n), src.t.size)
    t = (lo + np.arange(n)) / fs
    disp = np.column_stack([src.ml_cm[idx], src.ap_cm[idx]])
    disp -= disp.mean(axis=0)
    fz = src.fz_n[idx] * (weight_n / float(np.mean(src.fz_n[idx])))
    stance = STANCE[trial]
    if position_cm is None:
        position = mat_centre_cm(shape, pitch_cm) + rng.uniform(-PLACEMENT_CM, PLACEMENT_CM, 2)
    else:
        position = np.asarray(position_cm, dtype=np.float64)
    groups, nominal, _ = stance_groups(stance, shape, pitch_cm, tuple(position), **foot)
    info: dict[str, Any] = {"trial": trial, "stance": stance, "source": src.name,
                            "source_start_s": float(src.t[i0] - src.t[0]), "looped": looped,
                            "position_cm": position.tolist(), "rotation": None}
    if trial == "rotation":
        circle, info["rotation"] = _rotation(t, fs, max(span[0], 0.0) + float(rng.uniform(1.0, 3.0)), rng)
        disp = disp + circle
        wanted = 1.0
    else:
        wanted = SINGLE_LEG_SCALE if stance != "two" else 1.0
    k = _scale_within_reach(groups, nominal, position, disp, wanted, MIN_FRACTION)
    info.update(sway_scale=k, sway_scale_wanted=wanted)
    return Trajectory(t, position + k * disp, fz, info)


def platform_table(traj: Trajectory, n: int, origin_cm: NDArray[np.float64]) -> str:
    """The platform's CSV (time,x,y,Fz; s, cm, N) for ``n`` samples from its clock's 0:
    the mat's axes, the platform's origin (``x_fp = x_mat + origin``), Fz to its 0.1 N."""
    t = np.arange(n) / PLATFORM_RATE_HZ
    cop, fz = traj.at(t)
    cop = cop + origin_cm
    rows = "".join(f"{a:.4f},{b:.4f},{c:.4f},{d:.1f}\n" for a, b, c, d in zip(t, cop[:, 0], cop[:, 1], fz))
    return "time,x,y,Fz\n" + rows


@dataclass
class SessionTruth:
    """What the mat's session really was, frame by frame (see :func:`record_session`)."""

    t_platform_s: NDArray[np.float64]
    t_host_s: NDArray[np.float64]
    cop_cm: NDArray[np.float64]
    force_n: NDArray[np.float64]
    valid: NDArray[np.bool_]
    pressure_mean_psi: NDArray[np.float64]
    clipped_frames: int
    saturated_fraction: float
    force_on_mat_min: float


def record_session(path: Path, traj: Trajectory, mat: MatPhysics, *, trial: str, lead_s: float, frames: int,
                   rate_hz: float, clock_error: float, device_start_us: int, host_start_s: float, loss_rate: float,
                   pitch_cm: float, foot: dict[str, float], device: dict[str, Any], calibration: dict[str, Any],
                   metadata: dict[str, Any], rng: np.random.Generator, profile: dict[str, Any] | None = None,
                   events: Sequence[tuple[int, str]] = ()) -> SessionTruth:
    """Simulate and write one mat session (:class:`psmat.io.SessionWriter`) in chunks of :data:`CHUNK` frames.

    Frame ``k`` happens at platform time ``lead_s + k·T·(1 + clock_error)`` (``T = 1/rate_hz``);
    its device time is ``device_start_us + round(k·T·1e6)`` µs, its host time ``host_start_s``
    plus that instant plus a USB latency (1 ms + exponential 1 ms, never backwards). A frame
    is lost on the wire with probability ``loss_rate`` and kept as the reader keeps a frame that
    failed its check: counts 0, ``valid`` False, no sequence number or device time (-1).
    ``events``: markers (frame index, label), each written at the host time of that frame's arrival
    (an operator's click as the frame comes, on the session's host clock).
    """
    period = 1.0 / rate_hz
    period_true = period * (1.0 + clock_error)
    k = np.arange(frames)
    t_platform = lead_s + k * period_true
    device_us = device_start_us + np.round(k * period * 1e6).astype(np.int64)
    host = host_times(t_platform, host_start_s, rng)
    lost = rng.random(frames) < loss_rate
    lost[[0, -1]] = False
    R, C = mat.shape
    cop = np.empty((frames, 2))
    force = np.empty(frames)
    tally = MatTally.empty((R, C))
    position = tuple(traj.info["position_cm"])
    bounds = list(range(0, frames, CHUNK)) + [frames]
    if len(bounds) > 2 and bounds[-1] - bounds[-2] < 2:  # no chunk of one frame: a scene needs two
        del bounds[-2]
    with SessionWriter(path, (R, C), device, calibration=calibration, metadata=metadata, profile=profile) as w:
        for a, b in zip(bounds[:-1], bounds[1:]):
            target, fz = traj.at(t_platform[a:b])
            disp = target - np.asarray(position)
            scene = trajectory_sway(t_platform[a:b], disp[:, 0], disp[:, 1], fz, 1.0 / period_true, (R, C), pitch_cm,
                                    centre=False, stance=STANCE[trial], position_cm=position,
                                    min_fraction=MIN_FRACTION, **foot)
            write_mat_chunk(w, mat, scene, slice(a, b), host, lost, k, device_us, tally)
            cop[a:b], force[a:b] = scene.cop_true_cm, fz
        for k_ev, label in events:
            w.add_event(float(host[k_ev]), label)
        w.set_counters(bad_frames=int(lost.sum()))
    return SessionTruth(t_platform, host, cop, force, ~lost, tally.pressure_sum_psi / frames, tally.clipped_frames,
                        tally.saturated_fraction(frames), tally.force_on_mat_min)

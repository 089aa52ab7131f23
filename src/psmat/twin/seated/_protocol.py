"""The thesis' posture protocol as one trajectory of a seated person (thesis §4.3, docs/spec.md §8 "Data").

Thesis §4.3: the volunteer sits on the cushion and bounces a little (for synchronisation); holds
a straight back for 30 s, leans forward for 30 s and backwards for 30 s; repeats the bounces and
rocks slowly back and forth between the three postures, several swings; repeats the slow
bounces and swings. Its data (about 62 500 windows of 50 samples at 10 Hz over 36 sessions,
§4.3) make sessions of about 175 s. :func:`protocol_phases` draws that plan:

========== ============================================================================
settle      2–4 s sitting straight (the recording has started)
bounce      3–5 bounces at the subject's rate (1.5–2.5 Hz)
straight    28–32 s
to_forward  2–3 s, then ``forward`` 28–32 s
to_back     2.5–3.5 s, then ``back`` 28–32 s
to_straight 2–3 s
bounce      as the first
rocking     3–4 swings of the subject's period (7–11 s): straight, forward, straight, back, straight
bounce      3–5 slow bounces (0.6 × the rate)
rocking     as the first
settle      2–3 s straight
========== ============================================================================

(our choices for what the thesis leaves open: the lengths of the transitions, bounces and
swings). A shorter session (``duration_s``) is the same plan scaled in time, bounces and swings
keeping their number.

:func:`posture_trajectory` turns the plan into the posture, sampled on a 200 Hz grid: the lean
``λ`` (0 straight, +1 the day's forward posture, −1 its backward one; raised-cosine transitions,
a sine while rocking), what it does to the pelvis tilt and the lumbar and thoracic flexion
(:class:`~psmat.twin.seated._subject.SeatedSubject`: forward, part at the hips and part in the
spine; back, the pelvis rolling back and the spine slumping), the shares at the hips and in the
lumbar spine wandering by 0.08 (SD, 0.005–0.05 Hz) about the subject's own so that no two
excursions are alike, a slow slump over the session (the day's ``slump_deg`` of lumbar flexion
by its end), the slow sway (band-limited noise, 0.02–0.3 Hz), breathing (the thoracic flexion),
the sideways lean, and the bounces (the body's vertical acceleration as a fraction of g, which
also flexes the lumbar spine by 3° per g as the trunk lands). Our choices throughout. Angles
in degrees, times in s.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ._subject import SeatedDay, SeatedSubject
from ..sway import band_noise

__all__ = ["Phase", "PostureState", "PostureTrajectory", "protocol_phases", "posture_trajectory", "GRID_HZ"]

#: Rate of the trajectory's grid (Hz); :meth:`PostureTrajectory.at` interpolates it linearly.
GRID_HZ = 200.0
#: Band of the slow postural sway (Hz).
SWAY_BAND_HZ = (0.02, 0.3)
#: SD and band (Hz) of the slow wandering of the shares of a lean at the hips and in the lumbar spine.
MIX_SD = 0.08
MIX_BAND_HZ = (0.005, 0.05)
#: Lumbar flexion per g of vertical acceleration in a bounce (degrees).
BOUNCE_FLEX_DEG = 3.0
#: Lean of each held phase; transitions go from the previous phase's lean to the next.
_HELD = {"settle": 0.0, "bounce": 0.0, "straight": 0.0, "forward": 1.0, "back": -1.0}
_TRANSITION = {"to_forward": (0.0, 1.0), "to_back": (1.0, -1.0), "to_straight": (-1.0, 0.0)}


@dataclass(frozen=True)
class Phase:
    """One step of the protocol: ``name``, ``[start_s, end_s)`` on the protocol's clock, and its
    bounce or swing count (``cycles``) and bounce amplitude scale (``scale``)."""

    name: str
    start_s: float
    end_s: float
    cycles: int = 0
    scale: float = 1.0

    def as_dict(self) -> dict[str, Any]:
        return {"name": self.name, "start_s": self.start_s, "end_s": self.end_s, "cycles": self.cycles}


def protocol_phases(subject: SeatedSubject, rng: np.random.Generator, duration_s: float | None = None) -> list[Phase]:
    """The session's plan (module docstring), from 0 s; scaled to last ``duration_s`` when given."""
    u = rng.uniform
    b = subject.bounce_hz
    plan: list[tuple[str, float, int]] = []

    def bounce(rate: float) -> None:
        n = int(rng.integers(3, 6))
        plan.append(("bounce", n / rate, n))

    def rocking() -> None:
        n = int(rng.integers(3, 5))
        plan.append(("rocking", n * subject.rock_period_s * u(0.9, 1.1), n))

    plan.append(("settle", u(2.0, 4.0), 0))
    bounce(b)
    plan += [("straight", u(28.0, 32.0), 0), ("to_forward", u(2.0, 3.0), 0), ("forward", u(28.0, 32.0), 0),
             ("to_back", u(2.5, 3.5), 0), ("back", u(28.0, 32.0), 0), ("to_straight", u(2.0, 3.0), 0)]
    bounce(b)
    rocking()
    bounce(0.6 * b)
    rocking()
    plan.append(("settle", u(2.0, 3.0), 0))
    total = sum(d for _, d, _ in plan)
    k = 1.0 if duration_s is None else duration_s / total
    out, t = [], 0.0
    for name, d, n in plan:
        out.append(Phase(name, t, t + d * k, n))
        t += d * k
    return out


@dataclass
class PostureState:
    """The posture at some instants (arrays of one length T).

    Attributes
    ----------
    lean : λ, −1 (back) .. 0 (straight) .. +1 (forward)
    pelvis_deg : pelvis tilt, positive anterior (forward), degrees, from the subject's upright
    lumbar_deg, thoracic_deg : flexion of the lumbar and thoracic spine, degrees
    lateral_deg : sideways lean of the trunk, positive to the right, degrees
    bounce : vertical acceleration of the body, fraction of g
    """

    lean: NDArray[np.float64]
    pelvis_deg: NDArray[np.float64]
    lumbar_deg: NDArray[np.float64]
    thoracic_deg: NDArray[np.float64]
    lateral_deg: NDArray[np.float64]
    bounce: NDArray[np.float64]

    FIELDS = ("lean", "pelvis_deg", "lumbar_deg", "thoracic_deg", "lateral_deg", "bounce")

    def as_arrays(self) -> dict[str, NDArray[np.float64]]:
        return {f: getattr(self, f) for f in self.FIELDS}


@dataclass
class PostureTrajectory:
    """The session's posture on a :data:`GRID_HZ` grid from 0 to ``duration_s`` (:func:`posture_trajectory`)."""

    t_s: NDArray[np.float64]
    state: PostureState
    phases: list[Phase]

    @property
    def duration_s(self) -> float:
        return self.phases[-1].end_s

    def at(self, t_s: ArrayLike) -> PostureState:
        """The posture at times ``t_s`` (s; linear interpolation, held before 0 and after the end)."""
        t = np.asarray(t_s, dtype=np.float64)
        return PostureState(*(np.interp(t, self.t_s, getattr(self.state, f)) for f in PostureState.FIELDS))


def _lean_and_bounce(phases: list[Phase], t: NDArray[np.float64], bounce: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    lean = np.zeros_like(t)
    acc = np.zeros_like(t)
    for ph in phases:
        m = (t >= ph.start_s) & (t < ph.end_s)
        x = (t[m] - ph.start_s) / (ph.end_s - ph.start_s)  # 0..1 through the phase
        if ph.name in _HELD:
            lean[m] = _HELD[ph.name]
        elif ph.name in _TRANSITION:
            a, b = _TRANSITION[ph.name]
            lean[m] = a + (b - a) * 0.5 * (1.0 - np.cos(np.pi * x))
        elif ph.name == "rocking":
            lean[m] = np.sin(2.0 * np.pi * ph.cycles * x)
        if ph.name == "bounce":
            acc[m] = bounce * np.sin(2.0 * np.pi * ph.cycles * x)
    lean[t >= phases[-1].end_s] = _HELD.get(phases[-1].name, 0.0)
    return lean, acc


def posture_trajectory(subject: SeatedSubject, day: SeatedDay, rng: np.random.Generator,
                       duration_s: float | None = None) -> PostureTrajectory:
    """One session's posture (module docstring): the plan, the lean, and what it does to the body.

    Parameters
    ----------
    subject : SeatedSubject
    day : SeatedDay
    rng : numpy.random.Generator
        Draws the plan, the sway and the breathing's phase.
    duration_s : float, optional
        The session's length; default the plan's own (about 175 s).
    """
    phases = protocol_phases(subject, rng, duration_s)
    end = phases[-1].end_s
    n = int(math.floor(end * GRID_HZ)) + 2
    t = np.arange(n) / GRID_HZ
    lean, acc = _lean_and_bounce(phases, t, subject.bounce)
    fwd = np.clip(lean, 0.0, None) * subject.forward_deg * day.forward_scale
    back = np.clip(-lean, 0.0, None) * subject.back_deg * day.back_scale
    # the way of leaning wanders slowly about the subject's own: no two excursions alike
    hinge = np.clip(subject.hinge + MIX_SD * band_noise(n, GRID_HZ, MIX_BAND_HZ, rng), 0.05, 0.95)
    lumbar = np.clip(subject.lumbar + MIX_SD * band_noise(n, GRID_HZ, MIX_BAND_HZ, rng), 0.05, 0.95)
    q = subject.slump
    spine = (1.0 - hinge) * fwd + q * back  # the spine's flexion
    sway = [subject.sway_deg * band_noise(n, GRID_HZ, SWAY_BAND_HZ, rng) for _ in range(3)]
    breath = subject.breath_deg * np.sin(2.0 * np.pi * subject.breath_hz * t + rng.uniform(0.0, 2.0 * np.pi))
    slumping = day.slump_deg * t / end  # the lumbar spine flexes slowly over the session
    state = PostureState(
        lean=lean,
        pelvis_deg=day.pelvis_offset_deg + hinge * fwd - (1.0 + q) * back + sway[0],
        lumbar_deg=lumbar * spine + slumping + BOUNCE_FLEX_DEG * acc + sway[1],
        thoracic_deg=(1.0 - lumbar) * spine + breath + sway[2],
        lateral_deg=day.lateral_bias_deg + subject.lateral_sway_deg * band_noise(n, GRID_HZ, SWAY_BAND_HZ, rng),
        bounce=acc,
    )
    return PostureTrajectory(t, state, phases)

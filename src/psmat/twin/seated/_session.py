"""The seated twin (docs/spec.md §8 "Data"): one posture trajectory drives the cushion and the spine IMUs.

A :class:`SeatedSession` is a person (:mod:`psmat.twin.seated._subject`) following the thesis'
protocol for one session (:mod:`psmat.twin.seated._protocol`). Its posture gives, at any instants,

* the cushion's pressure (:meth:`SeatedSession.pressure`): the seat of
  :func:`~psmat.twin.anatomy.seat_groups` placed and turned on the mat as that day's sitting,
  loaded by the moment balance of :mod:`psmat.twin.seated._body` (the tuberosities, the thighs
  when leaning forward, the sacrum when leaning back, the weight's share on the cushion, the
  bounces) and shared by :mod:`psmat.twin.seated._seat` — a
  :class:`~psmat.twin.scenes.PressureScene` in psi for :class:`~psmat.twin.mat.MatPhysics`;
* the five IMUs' true readings (:meth:`SeatedSession.true_angles`, :mod:`psmat.twin.seated._imu`),
  to which :func:`~psmat.twin.seated._imu.imu_readings` adds the device's drift and noise.

The two streams can be sampled at their own instants (each device on its own clock): both are
functions of the one trajectory. The mapping from posture to pressure is the subject's own
(weight, pelvis, thighs, how they lean, where they sit), as is the mapping from posture to
angles (curvature, where the sensors land): the same lean gives different images and angles
on different people, which is what makes held-out subjects hard (thesis §4.4).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..._checks import nonneg_int, positive, positive_int, shape2
from ..field import mat_centre_cm, mat_pitch_cm
from ..scenes import PressureScene
from ._scenes import seat_scene
from ._imu import true_angles
from ._protocol import PostureTrajectory, posture_trajectory
from ._seat import SeatLayout, seat_layout
from ._body import seat_targets
from ._subject import SeatedDay, SeatedSubject, draw_seated_day, draw_seated_subject

__all__ = ["SeatedSession", "seated_session"]


@dataclass
class SeatedSession:
    """A person on the cushion following the protocol for one session.

    Attributes
    ----------
    subject : SeatedSubject
    day : SeatedDay
    trajectory : PostureTrajectory
        The posture over the session, on the protocol's clock (s from its start).
    layout : SeatLayout
        The seat as placed on the mat that day.
    """

    subject: SeatedSubject
    day: SeatedDay
    trajectory: PostureTrajectory
    layout: SeatLayout

    @classmethod
    def build(cls, subject: SeatedSubject, day: SeatedDay, trajectory: PostureTrajectory) -> "SeatedSession":
        """The session with the seat of ``subject`` placed as ``day`` says."""
        layout = seat_layout(day.seat_origin_cm, day.seat_rotation_deg, subject.tuberosity_distance_cm,
                             **subject.anatomy())
        return cls(subject, day, trajectory, layout)

    @property
    def duration_s(self) -> float:
        return self.trajectory.duration_s

    def pressure(self, t_s: ArrayLike, shape: tuple[int, int] = (16, 16), pitch_cm: float | None = None,
                 supersample: int = 5, min_fraction: float = 0.02) -> PressureScene:
        """The cushion's pressure at the instants ``t_s`` (s, protocol clock).

        Returns
        -------
        PressureScene
            Pressure (T, R, C) psi; ``force_n`` the seat's force; ``meta`` as
            :func:`~psmat.twin.seated._scenes.seat_scene`'s plus ``seat_share``, ``hat_forward_cm``
            (T,) and the posture (``posture``: :class:`~psmat.twin.seated._protocol.PostureState`).
        """
        shape_ = shape2(shape)
        pitch = mat_pitch_cm(shape_) if pitch_cm is None else positive("pitch_cm", pitch_cm)
        t = np.asarray(t_s, dtype=np.float64)
        state = self.trajectory.at(t)
        tg = seat_targets(self.subject, state, self.layout)
        return seat_scene("seated", self.layout, t, tg.force_n, tg.cop_seat_cm, tg.contact_cm,
                          self.subject.thigh_share, shape_, pitch, positive_int("supersample", supersample),
                          min_fraction, {"seat_share": tg.seat_share, "hat_forward_cm": tg.hat_forward_cm,
                                         "contact_cm": tg.contact_cm, "posture": state,
                                         "weight_n": self.subject.weight_n})

    def true_angles(self, t_s: ArrayLike) -> NDArray[np.float64]:
        """The IMUs' true readings (T, 5, 3) — heading, roll, pitch in degrees — at ``t_s`` (s)."""
        return true_angles(self.subject, self.day, self.trajectory.at(np.asarray(t_s, dtype=np.float64)))


def seated_session(seed: int = 0, *, shape: tuple[int, int] = (16, 16), pitch_cm: float | None = None,
                   duration_s: float | None = None, subject: SeatedSubject | None = None,
                   day: SeatedDay | None = None) -> SeatedSession:
    """A seeded person (or ``subject``) on the mat ``shape`` for one session of the protocol.

    Parameters
    ----------
    seed : int
        Seeds the person, the day and the trajectory.
    shape, pitch_cm
        The mat (cells; cm, default the thesis' 32 cm mat, :func:`~psmat.twin.field.mat_pitch_cm`).
    duration_s : float, optional
        The session's length (s); default the protocol's own (about 175 s).
    subject, day : optional
        Given instead of drawn.
    """
    rng = np.random.default_rng(nonneg_int("seed", seed))
    shape_ = shape2(shape)
    pitch = mat_pitch_cm(shape_) if pitch_cm is None else positive("pitch_cm", pitch_cm)
    if duration_s is not None:
        duration_s = positive("duration_s", duration_s)
    person = draw_seated_subject(rng) if subject is None else subject
    today = draw_seated_day(rng, mat_centre_cm(shape_, pitch)) if day is None else day
    return SeatedSession.build(person, today, posture_trajectory(person, today, rng, duration_s))

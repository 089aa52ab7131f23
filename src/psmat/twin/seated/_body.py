"""The seated body's geometry (docs/spec.md §8 "Data"): the back's pitch along the spine, and what the
posture does to the cushion's load.

The back
--------
A position on the back is ``v``, its distance along the skin from S3 (0) to C7 (1) as a share
of the back's length. Its pitch (the angle of the back's surface from the vertical in the
sagittal plane, positive when its top leans forward — docs/spec.md §8's angle convention) is

    θ(v, t) = θ₀(v) + P(t) + L(t)·s((v − 0.05)/0.45) + T(t)·s((v − 0.45)/0.55)

with θ₀ the subject's upright curvature (a monotone cubic through the knots of
:data:`~psmat.twin.seated._subject.KNOTS_V`, held beyond them), ``P`` the pelvis tilt (the whole
back turns with the pelvis), ``L`` and ``T`` the lumbar and thoracic flexion, spread over the
lumbar (v 0.05–0.5) and thoracic (v 0.45–1) parts by the smoothstep ``s(x) = 3x² − 2x³`` (our
choice). Eq. 4.4 of the thesis reads the IMUs as the tangents of such a curve at points 90 mm
apart along it (:func:`sensor_sites`), exact where the curvature between them is constant.

The load on the cushion
-----------------------
The trunk, head and arms (HAT, 0.678 of the body mass: Winter, Biomechanics and Motor Control
of Human Movement, Table 4.1) have their centre of mass 0.6 of the way up the back and
0.058 × height in front of its surface (half a trunk's depth: our choice). The back starts at
S3, 7 cm behind and 9 cm above the tuberosities at 1.68 m (scaled with height; our choice),
and the pelvis turns about the tuberosities. When the HAT's centre moves forward by ``Δd`` from
the subject's upright (cm, :func:`hat_offset_cm`), its moment ``0.678·W·Δd`` is taken by the
cushion (share β, the subject's ``moment_share``) and by the knees and feet on the floor (the
rest, at the knees: the thigh's length turned by its splay), so

    seat share   s = s₀ − 0.678·(1 − β)·Δd / x_knee
    seat CoP     w = (s₀·w₀ + 0.678·β·Δd) / s                  (seat frame, cm forward)

with ``w₀`` the upright shares' CoP. The cushion's reach is limited: its CoP goes no further
forward than where the thighs carry 80 % of its load, nor back than where the sacrum carries
50 % (our choices); beyond, ``w`` stays at that limit and the share follows from the whole
moment, ``s·w + (1 − s)·x_knee = s₀·w₀ + (1 − s₀)·x_knee + 0.678·Δd`` (leaning far forward
the knees take over). The share is kept within 0.4–0.98. Sideways the cushion takes the same share β of the HAT's
moment (its centre ``h·sin(lean)`` to the side, ``h`` its height above the seat). The seat's
force is ``W·s·(1 + a)``, ``a`` the body's vertical acceleration in g (bounces). The pelvis
rolls on its tuberosities, whose radius we take as 4 cm: the contact moves ``4 cm · P`` (rad)
forward (:func:`seat_targets`). The moment balance is exact by construction: seat and floor
together carry ``0.678·W·Δd`` more.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.interpolate import PchipInterpolator

from ...spine import N_SENSORS, SPACING_MM
from ._protocol import PostureState
from ._seat import SeatLayout
from ._subject import KNOTS_V, SeatedDay, SeatedSubject

__all__ = ["back_pitch_deg", "sensor_sites", "hat_offset_cm", "SeatTargets", "seat_targets", "HAT_SHARE"]

#: Share of the body mass in head, arms and trunk (Winter, Table 4.1).
HAT_SHARE = 0.678
#: Height of the HAT's centre of mass along the back (share of S3..C7).
HAT_V = 0.6
#: Depth of the HAT's centre of mass in front of the back, per cm of height.
HAT_DEPTH_PER_HEIGHT = 0.058
#: S3 relative to the tuberosities at 1.68 m (w forward, z up), cm.
S3_CM = (-7.0, 9.0)
#: The most of the cushion's load the thighs and the sacrum carry; a moment beyond goes to the floor.
MAX_THIGH_SHARE = 0.8
MAX_SACRUM_SHARE = 0.5
#: Range of the weight's share on the cushion.
SHARE_RANGE = (0.4, 0.98)
#: Radius on which the pelvis rolls on its tuberosities, cm.
ROLL_RADIUS_CM = 4.0
_GRID_V = np.linspace(0.0, 1.0, 61)


def _smoothstep(x: NDArray[np.float64]) -> NDArray[np.float64]:
    x = np.clip(x, 0.0, 1.0)
    return x * x * (3.0 - 2.0 * x)


def back_pitch_deg(subject: SeatedSubject, state: PostureState, v: ArrayLike) -> NDArray[np.float64]:
    """The back's pitch θ(v, t) (module docstring), degrees, (T, len(v)) for positions ``v`` (share of S3..C7)."""
    vv = np.asarray(v, dtype=np.float64)
    upright = PchipInterpolator(KNOTS_V, subject.upright_pitch_deg)(np.clip(vv, 0.0, 1.0))
    lumbar = _smoothstep((vv - 0.05) / 0.45)
    thoracic = _smoothstep((vv - 0.45) / 0.55)
    return (upright[None, :] + state.pelvis_deg[:, None] + state.lumbar_deg[:, None] * lumbar[None, :]
            + state.thoracic_deg[:, None] * thoracic[None, :])


def sensor_sites(subject: SeatedSubject, day: SeatedDay) -> NDArray[np.float64]:
    """Positions ``v`` (5,) of the IMUs: the top one ``day.top_sensor_cm`` below C7, the others every
    90 mm along the back (docs/spec.md §8); sensor 1 is the cervical one."""
    below_c7 = day.top_sensor_cm + np.arange(N_SENSORS) * SPACING_MM / 10.0
    return 1.0 - below_c7 / subject.back_length_cm


def hat_offset_cm(subject: SeatedSubject, state: PostureState) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Where the HAT's centre of mass is, relative to the tuberosities: forward ``w`` and up ``z`` (T,) cm."""
    theta = np.radians(back_pitch_deg(subject, state, _GRID_V))  # (T, V)
    p = np.radians(state.pelvis_deg)
    k = subject.height_cm / 168.0
    s3w, s3z = S3_CM[0] * k, S3_CM[1] * k
    w0 = s3w * np.cos(p) + s3z * np.sin(p)  # S3 turned with the pelvis about the tuberosities
    z0 = -s3w * np.sin(p) + s3z * np.cos(p)
    dv = subject.back_length_cm * (_GRID_V[1] - _GRID_V[0])
    upto = int(round(HAT_V * (_GRID_V.size - 1)))
    # trapezoid rule along the back from S3 to the HAT's level
    sw, cz = np.sin(theta[:, : upto + 1]), np.cos(theta[:, : upto + 1])
    w = w0 + dv * (sw.sum(axis=1) - 0.5 * (sw[:, 0] + sw[:, -1]))
    z = z0 + dv * (cz.sum(axis=1) - 0.5 * (cz[:, 0] + cz[:, -1]))
    depth = HAT_DEPTH_PER_HEIGHT * subject.height_cm
    th = theta[:, upto]
    return w + depth * np.cos(th), z - depth * np.sin(th)


@dataclass
class SeatTargets:
    """What the posture asks of the cushion, per instant (:func:`seat_targets`).

    Attributes
    ----------
    force_n : (T,) the seat's total force, N
    seat_share : (T,) share of the weight on the cushion, before the bounce's acceleration
    cop_seat_cm : (T, 2) the seat's CoP in the seat frame (u right, w forward), cm
    contact_cm : (T,) the tuberosities' rolling contact along w, cm
    hat_forward_cm : (T,) Δd, the HAT's centre forward of its upright position, cm
    """

    force_n: NDArray[np.float64]
    seat_share: NDArray[np.float64]
    cop_seat_cm: NDArray[np.float64]
    contact_cm: NDArray[np.float64]
    hat_forward_cm: NDArray[np.float64]


def seat_targets(subject: SeatedSubject, state: PostureState, layout: SeatLayout) -> SeatTargets:
    """The seat's force, CoP and contact for a posture (the moment balance of the module docstring)."""
    upright = PostureState(*(np.zeros(1) for _ in PostureState.FIELDS))
    d0, _ = hat_offset_cm(subject, upright)
    d, h = hat_offset_cm(subject, state)
    dd = d - d0[0]
    beta, s0 = subject.moment_share, subject.seat_share
    knee = subject.thigh_length_cm * math.cos(math.radians(subject.thigh_splay_deg))
    loc = layout.local_cm
    w_it, w_th, w_sa = loc[0:4, 1].mean(), loc[4, 1], loc[6, 1]
    t0 = subject.thigh_share
    w0 = (1.0 - t0) * w_it + t0 * w_th
    share = s0 - HAT_SHARE * (1.0 - beta) * dd / knee
    w = (s0 * w0 + HAT_SHARE * beta * dd) / share
    # beyond the cushion's reach the floor takes the rest: s·w + (1 − s)·x_knee = the whole moment
    contact = ROLL_RADIUS_CM * np.radians(state.pelvis_deg)
    w_in = w_it + np.clip(contact, -layout.roll_cm, layout.roll_cm)  # where the tuberosities touch
    total = s0 * w0 + (1.0 - s0) * knee + HAT_SHARE * dd
    front = w_in + MAX_THIGH_SHARE * (w_th - w_in)
    rear = w_in + MAX_SACRUM_SHARE * (w_sa - w_in)
    for limit, beyond in ((front, w > front), (rear, w < rear)):
        w = np.where(beyond, limit, w)
        share = np.where(beyond, (knee - total) / (knee - limit), share)
    share = np.clip(share, *SHARE_RANGE)
    u = HAT_SHARE * beta * h * np.sin(np.radians(state.lateral_deg)) / share
    force = subject.weight_n * share * (1.0 + state.bounce)
    return SeatTargets(force, share, np.column_stack([u, w]), contact, dd)

"""Anatomy of the twin's loads (SPEC §5): feet and a seat, as lobes (:class:`~psmat.twin.field.Lobes`).

The foot
--------
:func:`foot` builds a plantar pressure distribution of length ``length_cm`` (heel to toe
tip, default 24 cm) and width ``width_cm`` (default 9 cm) from lobes under the heel, the
lateral midfoot, the metatarsal heads (medial, central, lateral), the hallux and the
lesser toes. Its load is split between the *rearfoot* (heel + midfoot; ``heel_fraction``,
default 0.6) and the *forefoot*.

Load groups
-----------
The scene generators (:mod:`psmat.twin.scenes`) move the load between **groups** of lobes
with unit force each: :func:`two_feet_groups` (left/right rearfoot/forefoot),
:func:`single_foot_groups` (medial/lateral rearfoot/forefoot of one foot) and
:func:`seat_groups` (left/right ischial tuberosity and thigh). Positions in cm, mat
coordinates (:mod:`psmat.twin.field`).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .._checks import finite, fraction, positive
from .field import Lobes, mat_centre_cm

__all__ = ["foot", "two_feet", "two_feet_groups", "single_foot_groups", "seat_groups", "check_side",
           "check_foot_size"]

# Lobes in the foot's own frame for a 24 cm x 9 cm foot: u along the foot (cm, toes
# positive, foot centre at 0: heel end -12, toe tip +12), v across it (cm, positive =
# lateral). Columns: u, v, semi-axis along u, semi-axis along v, share of its group.
_FOOT_PARTS: dict[str, tuple[float, float, float, float]] = {
    "heel": (-7.7, 0.0, 4.2, 3.6),
    "heel_medial": (-7.7, -1.4, 4.0, 2.6),
    "heel_lateral": (-7.7, 1.4, 4.0, 2.6),
    "midfoot": (-2.0, 2.2, 4.8, 1.7),
    "mth_medial": (5.2, -2.0, 2.5, 2.1),
    "mth_central": (5.4, 0.4, 2.5, 2.0),
    "mth_lateral": (4.2, 2.6, 2.3, 1.7),
    "hallux": (10.0, -2.1, 1.9, 1.6),
    "toes": (9.3, 1.2, 1.6, 2.4),
}
# Groups: how each group's load is shared among the parts (fractions, sum 1).
_REAR = {"heel": 0.85, "midfoot": 0.15}
_FORE = {"mth_medial": 0.28, "mth_central": 0.30, "mth_lateral": 0.14, "hallux": 0.17, "toes": 0.11}
# Single-leg stance: four groups so that one foot can steer the CoP in M-L and A-P.
_REAR_MEDIAL = {"heel_medial": 1.0}
_REAR_LATERAL = {"heel_lateral": 0.7, "midfoot": 0.3}
_FORE_MEDIAL = {"mth_medial": 0.55, "mth_central": 0.15, "hallux": 0.30}
_FORE_LATERAL = {"mth_lateral": 0.55, "mth_central": 0.15, "toes": 0.30}
_REF_LENGTH_CM = 24.0
_REF_WIDTH_CM = 9.0


def _foot_part_lobes(
    parts: dict[str, float],
    x_cm: float,
    y_cm: float,
    side: str,
    length_cm: float,
    width_cm: float,
    toe_out_deg: float,
) -> Lobes:
    """Unit-force group of foot parts for a foot centred at (x, y)."""
    su, sv = length_cm / _REF_LENGTH_CM, width_cm / _REF_WIDTH_CM
    phi = math.radians(toe_out_deg)
    # Left foot: toes turned outwards = towards -x (counter-clockwise); lateral side -x.
    along = np.array([-math.sin(phi), math.cos(phi)])
    lateral = np.array([-math.cos(phi), -math.sin(phi)])
    names = list(parts)
    geo = np.array([_FOOT_PARTS[n] for n in names])
    share = np.array([parts[n] for n in names], dtype=np.float64)
    share = share / share.sum()
    centre = np.array([x_cm, y_cm]) + (geo[:, 0:1] * su) * along + (geo[:, 1:2] * sv) * lateral
    axes = np.column_stack([geo[:, 2] * su, geo[:, 3] * sv])
    angle = np.full(len(names), math.atan2(along[1], along[0]))
    lobes = Lobes(centre, axes, angle, share)
    return lobes.mirrored(x_cm) if side == "right" else lobes


def check_side(side: Any) -> str:
    """``side`` if it is ``"left"`` or ``"right"``, else ValueError."""
    if side not in ("left", "right"):
        raise ValueError(f"side must be 'left' or 'right', got {side!r}")
    return str(side)


def check_foot_size(length_cm: Any, width_cm: Any, toe_out_deg: Any) -> tuple[float, float, float]:
    """Checked foot length and width (cm, > 0) and toe-out angle (degrees, within ±45)."""
    length = positive("foot_length_cm", length_cm)
    width = positive("foot_width_cm", width_cm)
    toe = finite("toe_out_deg", toe_out_deg)
    if not -45.0 <= toe <= 45.0:
        raise ValueError(f"toe_out_deg must lie in [-45, 45] degrees, got {toe_out_deg!r}")
    return length, width, toe


def foot(
    x_cm: float,
    y_cm: float,
    load_n: float = 1.0,
    *,
    side: str = "left",
    length_cm: float = 24.0,
    width_cm: float = 9.0,
    toe_out_deg: float = 0.0,
    heel_fraction: float = 0.6,
) -> Lobes:
    """Plantar pressure field of one foot standing on the mat.

    Parameters
    ----------
    x_cm, y_cm : float
        Centre of the foot (midpoint of heel end and toe tip) in mat coordinates, cm.
    load_n : float
        Force carried by the foot in N (>= 0); the field integrates to it exactly.
    side : {"left", "right"}
        Which foot; the lateral side of the left foot is ``-x``.
    length_cm, width_cm : float
        Foot length (heel to toe tip) and width in cm; the layout scales with them.
    toe_out_deg : float
        Rotation of the foot's axis away from ``+y``, toes outwards (degrees).
    heel_fraction : float
        Share of the load on the rearfoot (heel + lateral midfoot), in [0, 1].

    Returns
    -------
    Lobes
        The foot's pressure field; ``.cells_psi(shape, pitch)`` gives its cell image.
    """
    x = finite("x_cm", x_cm)
    y = finite("y_cm", y_cm)
    load = finite("load_n", load_n)
    if load < 0:
        raise ValueError(f"load_n must be >= 0 N, got {load_n!r}")
    side = check_side(side)
    length, width, toe = check_foot_size(length_cm, width_cm, toe_out_deg)
    h = fraction("heel_fraction", heel_fraction)
    rear = _foot_part_lobes(_REAR, x, y, side, length, width, toe)
    fore = _foot_part_lobes(_FORE, x, y, side, length, width, toe)
    return rear.scaled(h * load) + fore.scaled((1.0 - h) * load)


def two_feet(
    x_cm: float,
    y_cm: float,
    load_n: float = 1.0,
    *,
    stance_cm: float = 15.0,
    stagger_cm: float = 0.0,
    length_cm: float = 24.0,
    width_cm: float = 9.0,
    toe_out_deg: float = 0.0,
    heel_fraction: float = 0.6,
) -> Lobes:
    """Plantar pressure field of two feet (:func:`foot`) sharing ``load_n`` equally.

    Parameters
    ----------
    x_cm, y_cm : float
        Midpoint between the two feet's centres, mat coordinates in cm.
    load_n : float
        Total force in N (>= 0), half on each foot.
    stance_cm : float
        Distance (M-L) between the feet's centres in cm: the left foot is centred at
        ``x − stance/2``, the right at ``x + stance/2``.
    stagger_cm : float
        How far (A-P, cm) the right foot stands ahead of the left: the left foot is centred
        at ``y − stagger/2``, the right at ``y + stagger/2`` (0: side by side).
    length_cm, width_cm, toe_out_deg, heel_fraction
        As :func:`foot`, the same for both feet.

    Returns
    -------
    Lobes
        The left foot's lobes followed by the right foot's.
    """
    x = finite("x_cm", x_cm)
    y = finite("y_cm", y_cm)
    stance = finite("stance_cm", stance_cm)
    stagger = finite("stagger_cm", stagger_cm)
    load = finite("load_n", load_n)
    if load < 0:
        raise ValueError(f"load_n must be >= 0 N, got {load_n!r}")
    half = load / 2.0
    kw = dict(length_cm=length_cm, width_cm=width_cm, toe_out_deg=toe_out_deg, heel_fraction=heel_fraction)
    left = foot(x - stance / 2, y - stagger / 2, half, side="left", **kw)
    right = foot(x + stance / 2, y + stagger / 2, half, side="right", **kw)
    return left + right


def two_feet_groups(
    shape: tuple[int, int],
    pitch: float,
    length: float,
    width: float,
    stance: float,
    toe: float,
    nominal: NDArray[np.float64],
) -> list[tuple[str, Lobes]]:
    """Left/right rearfoot/forefoot groups, placed so the nominal CoP is at the mat centre."""
    centre = mat_centre_cm(shape, pitch)
    xl = centre[0] - stance / 2.0
    left_rear = _foot_part_lobes(_REAR, xl, 0.0, "left", length, width, toe)
    left_fore = _foot_part_lobes(_FORE, xl, 0.0, "left", length, width, toe)
    y_cop = (nominal[0] * left_rear.cop_cm[1] + nominal[1] * left_fore.cop_cm[1]) / (nominal[0] + nominal[1])
    dy = centre[1] - y_cop
    left_rear, left_fore = left_rear.shifted(0.0, dy), left_fore.shifted(0.0, dy)
    return [
        ("left_rear", left_rear),
        ("left_fore", left_fore),
        ("right_rear", left_rear.mirrored(centre[0])),
        ("right_fore", left_fore.mirrored(centre[0])),
    ]


def single_foot_groups(
    centre: NDArray[np.float64], side: str, length: float, width: float, nominal: NDArray[np.float64]
) -> list[tuple[str, Lobes]]:
    """Medial/lateral rearfoot/forefoot groups of one foot pointing along ``+y``, placed so
    that the nominal CoP (group shares ``nominal``) is at ``centre`` (x, y) cm."""
    parts = [
        ("rear_medial", _REAR_MEDIAL),
        ("rear_lateral", _REAR_LATERAL),
        ("fore_medial", _FORE_MEDIAL),
        ("fore_lateral", _FORE_LATERAL),
    ]
    lobes = [_foot_part_lobes(p, centre[0], centre[1], side, length, width, 0.0) for _, p in parts]
    cop0 = (nominal[:, None] * np.array([l.cop_cm for l in lobes])).sum(axis=0)
    lobes = [l.shifted(*(centre - cop0)) for l in lobes]
    return [(n, l) for (n, _), l in zip(parts, lobes)]


def seat_groups(centre: NDArray[np.float64], tuberosity_distance_cm: float) -> list[tuple[str, Lobes]]:
    """Left/right ischial tuberosity and thigh of a person sitting, symmetric about ``x = centre[0]``.

    The tuberosities lie ``tuberosity_distance_cm`` apart at ``y = centre[1] − 4`` cm, the
    thighs extend towards ``+y``. Each group carries a unit force.
    """
    c = centre
    xl = c[0] - tuberosity_distance_cm / 2.0
    y_it = c[1] - 4.0
    # Left ischial tuberosity: sharp bony lobe (60 %) in a broad buttock lobe (40 %).
    left_it = Lobes([[xl, y_it], [xl - 0.5, y_it + 0.5]], [[3.0, 3.0], [7.0, 6.5]], [0.0, 0.0], [0.6, 0.4])
    # Left thigh: an elongated lobe along +y, turned a little outwards.
    thigh_angle = math.pi / 2 + math.radians(8.0)
    left_thigh = Lobes([[xl - 1.5, c[1] + 6.5]], [[8.0, 4.5]], [thigh_angle], [1.0])
    return [
        ("left_ischial", left_it),
        ("left_thigh", left_thigh),
        ("right_ischial", left_it.mirrored(c[0])),
        ("right_thigh", left_thigh.mirrored(c[0])),
    ]

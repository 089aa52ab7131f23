"""Anatomy of the twin's loads (docs/spec.md §5): feet and a seat, as lobes (:class:`~psmat.twin.field.Lobes`).

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
:func:`seat_groups` (left/right ischial tuberosity rolled forward and back, left/right thigh,
sacrum). Positions in cm, mat coordinates (:mod:`psmat.twin.field`).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .._checks import finite, fraction, positive
from .field import Lobes, mat_centre_cm

__all__ = ["foot", "two_feet", "two_feet_groups", "single_foot_groups", "seat_groups", "SEAT_GROUPS",
           "check_side", "check_foot_size"]

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


#: Groups of the seat (:func:`seat_groups`), in this order.
SEAT_GROUPS = ("ischial_left_front", "ischial_left_rear", "ischial_right_front", "ischial_right_rear",
               "thigh_left", "thigh_right", "sacrum")


def seat_groups(
    centre: NDArray[np.float64],
    tuberosity_distance_cm: float,
    *,
    thigh_length_cm: float = 41.0,
    thigh_splay_deg: float = 8.0,
    soft_tissue: float = 1.0,
    roll_cm: float = 1.5,
    rotation_deg: float = 0.0,
) -> list[tuple[str, Lobes]]:
    """The load groups of a person sitting on the mat (:data:`SEAT_GROUPS`), each carrying a unit force.

    The seat's own frame has its origin midway between the ischial tuberosities, ``u`` to the
    person's right and ``w`` forward (towards the knees); ``rotation_deg`` turns it
    counter-clockwise on the mat and ``centre`` (x, y) cm places its origin (at 0° the person
    faces ``+y``, their right is ``+x``, as standing).

    * Each **ischial tuberosity** is a bony lobe (4 cm semi-axes, 55 %) inside a broad buttock
      lobe (8 × 6.5 cm, 45 %, 0.5 cm outwards and back), at ``u = ±d/2``; it comes twice, rolled
      ``roll_cm`` forward (``_front``) and back (``_rear``): the pelvis rolls on its
      tuberosities as it tilts, and the share between the two places the contact.
    * Each **thigh** is an elongated lobe (semi-axes 0.2 × and 4.5 cm) whose centre lies
      0.22 × ``thigh_length_cm`` along the thigh from a point 2 cm outside the tuberosity and
      2 cm forward, turned ``thigh_splay_deg`` outwards (cross-legged sitting turns the thighs out).
    * The **sacrum and coccyx**: one lobe on the midline, ``d/2 + 1.5`` cm behind the
      tuberosities, 5 cm along ``w`` and 4 cm across; it carries load only when the pelvis
      rolls back.

    ``soft_tissue`` scales the buttock, thigh and sacral lobes' widths (a heavier person sits on
    more flesh: the seated twin takes the square root of BMI / 22). Geometry: our choice after
    the seated pressure maps of the literature (two ischial peaks 10–14 cm apart, the thighs in
    front, the sacrum behind), the thesis giving none.

    Parameters
    ----------
    centre : (x, y)
        The seat's origin on the mat, cm.
    tuberosity_distance_cm : float
        Distance between the ischial tuberosities ``d``, cm.
    thigh_length_cm, thigh_splay_deg, soft_tissue, roll_cm, rotation_deg : float
        As above (cm, degrees, factor, cm, degrees).

    Returns
    -------
    list of (name, Lobes)
        In the order of :data:`SEAT_GROUPS`, mat coordinates.
    """
    d = positive("tuberosity_distance_cm", tuberosity_distance_cm)
    thigh = positive("thigh_length_cm", thigh_length_cm)
    splay = math.radians(finite("thigh_splay_deg", thigh_splay_deg))
    k = positive("soft_tissue", soft_tissue)
    roll = finite("roll_cm", roll_cm)
    rot = math.radians(finite("rotation_deg", rotation_deg))
    # (u, w, semi-axis along, semi-axis across, direction of the first axis in the seat frame, share)
    left_it = [(-d / 2, 0.0, 4.0, 4.0, 0.0, 0.55), (-d / 2 - 0.5, -0.5, 8.0 * k, 6.5 * k, 0.0, 0.45)]
    along = 0.22 * thigh
    left_thigh = [(-d / 2 - 2.0 - along * math.sin(splay), 2.0 + along * math.cos(splay), 0.2 * thigh, 4.5 * k,
                   math.pi / 2 + splay, 1.0)]
    sacrum = [(0.0, -(d / 2 + 1.5), 5.0 * k, 4.0 * k, math.pi / 2, 1.0)]

    def place(parts: list[tuple[float, ...]], dw: float = 0.0, mirror: bool = False) -> Lobes:
        a = np.array(parts, dtype=np.float64)
        u, w, ang = a[:, 0], a[:, 1] + dw, a[:, 4]
        if mirror:
            u, ang = -u, np.pi - ang
        c, s = math.cos(rot), math.sin(rot)
        xy = np.column_stack([u * c - w * s, u * s + w * c]) + np.asarray(centre, dtype=np.float64)
        return Lobes(xy, a[:, 2:4], ang + rot, a[:, 5] / a[:, 5].sum())

    return list(zip(SEAT_GROUPS, [
        place(left_it, roll), place(left_it, -roll), place(left_it, roll, True), place(left_it, -roll, True),
        place(left_thigh), place(left_thigh, mirror=True), place(sacrum),
    ]))

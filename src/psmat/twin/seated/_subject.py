"""Who sits on the cushion (docs/spec.md §8 "Data"): a seated subject and what changes from day to day.

:func:`draw_seated_subject` draws a person of thesis Table 4.2 with the anatomy that shapes the
seat's pressure and the spine's angles and the way they lean; :func:`draw_seated_day` draws what a
new session changes: where and how turned they sit on the cushion, where the IMU strip lands on
their back, each sensor's mounting, how far they lean that day. Every number is stated here with
its source, or as our choice where the thesis and the literature at hand give none.

Person (thesis Table 4.2: age 32 ± 14 years, weight 62 ± 9 kg, height 1.68 ± 0.07 m, 5 men and 7 women)
    Height per sex 175 ± 5 cm (men), 163 ± 5 cm (women): their mixture in Table 4.2's 5:7 is
    168 ± 7.7 cm. Weight = BMI · height², BMI 22.5 ± 2.0 (men), 21.5 ± 2.0 (women): 62 ± 9 kg
    in the mixture. Age 32 ± 14, both sexes. Clipped to 150–195 cm, 42–100 kg, 18–70 years.
Pelvis and thighs
    Distance between the ischial tuberosities 11.5 ± 1.0 cm (men), 13.0 ± 1.0 cm (women), clipped
    to 9–16 cm (our choice: seated "sit-bone" widths of 10–15 cm, wider in women). Thigh length
    0.245 · height (Winter, Biomechanics and Motor Control of Human Movement, Fig. 4.1, after
    Drillis & Contini), turned out by 15–35° (cross-legged on a meditation cushion, our choice).
    Soft tissue: the buttock, thigh and sacral lobes widen with sqrt(BMI / 22).
Seat load (:mod:`psmat.twin.seated._body`)
    Share of the weight on the cushion upright 0.70–0.85 (the rest on the knees and feet on the
    floor), the thighs' share of it 0.20–0.35, the share ``β`` of a change in the trunk's moment
    that the cushion takes (the rest goes to the knees and feet on the floor) 0.25–0.45: our
    choices.
Spine
    Back length C7–S3 along the skin 0.27 · height ± 3 % (our choice, 45 cm at 1.68 m; the
    thesis quotes 57–66 cm for the whole back). The upright curvature: the back's pitch at S3,
    L4-5, T12, T7 and C7 (normalised positions 0, 0.2, 0.45, 0.7, 1 from S3 to C7) is
    10, 2, −5, 3 and 18° (sacrum and upper back leaning forward, the lumbar lordosis back;
    our choice for sitting upright), each ± 4° per subject.
Leaning (the protocol, :mod:`psmat.twin.seated._protocol`)
    Forward the top of the back turns by 15–35°, of which 30–80 % at the hips (pelvis tilt)
    and the rest in the spine, 30–70 % of that in the lumbar part; back the trunk reclines by
    8–20°, the pelvis rolling back by (1 + q) times that while the spine flexes by q times it
    (q = 0.2–0.6: a C-shaped slump, the top kept over the seat). Slow postural sway 0.5–1.5°
    (pelvis and spine) and 0.5–2° (sideways), breathing 0.2–0.3 Hz moving the upper back by
    0.3–1°, bounces of 15–35 % of the weight at 1.5–2.5 Hz, rocking periods of 7–11 s. Our choices.
A session (a day)
    The seat's origin within ±3 cm of 4 cm behind the mat's centre and turned by N(0, 6°)
    (clipped ±15°); the IMU strip's top sensor within N(0, 1.5 cm) of C7 (the others follow
    every 90 mm, docs/spec.md §8, so they land on vertebrae that depend on the back's length — thesis
    §4.5); each sensor's mounting offset N(0, 2°) in pitch and roll, N(0, 3°) in heading (strap
    and soft tissue); the day's lean 1 ± 0.12 (clipped 0.7–1.3) times the subject's, forward
    and back separately; the pelvis's upright tilt N(0, 2°) away from the subject's; a sideways
    bias N(0, 1°); a slow slump of 0–4° of lumbar flexion over the session; the room's heading
    uniform. Our choices.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ...units import n_from_kg

__all__ = ["SeatedSubject", "SeatedDay", "draw_seated_subject", "draw_seated_day", "TABLE_4_2", "KNOTS_V",
           "UPRIGHT_PITCH_DEG"]

#: Thesis Table 4.2 (12 volunteers): men's share, and mean and SD of age (years), weight (kg), height (m).
TABLE_4_2 = {"men": 5 / 12, "age": (32.0, 14.0), "weight_kg": (62.0, 9.0), "height_m": (1.68, 0.07)}
#: Per sex: height (cm) and BMI (kg/m²), mean and SD (mixed in 5:7 they give Table 4.2).
_SEX = {"M": {"height_cm": (175.0, 5.0), "bmi": (22.5, 2.0), "it_cm": (11.5, 1.0)},
        "F": {"height_cm": (163.0, 5.0), "bmi": (21.5, 2.0), "it_cm": (13.0, 1.0)}}
_LIMITS = {"height_cm": (150.0, 195.0), "weight_kg": (42.0, 100.0), "age": (18, 70), "it_cm": (9.0, 16.0)}
#: Normalised positions along the back from S3 (0) to C7 (1) of the upright curvature's knots.
KNOTS_V = (0.0, 0.2, 0.45, 0.7, 1.0)
#: The back's pitch at the knots sitting upright, degrees (positive: the back's top leaning forward).
UPRIGHT_PITCH_DEG = (10.0, 2.0, -5.0, 3.0, 18.0)
THIGH_PER_HEIGHT = 0.245
BACK_PER_HEIGHT = 0.27


@dataclass(frozen=True)
class SeatedSubject:
    """A person on the cushion: body, anatomy, and how they lean (see the module docstring for units and sources)."""

    sex: str
    age: int
    height_cm: float
    weight_kg: float
    tuberosity_distance_cm: float
    thigh_splay_deg: float
    seat_share: float  # share of the weight on the cushion, upright
    thigh_share: float  # share of the cushion's load on the thighs, upright
    moment_share: float  # β: share of a change in the trunk's moment taken by the cushion
    back_length_cm: float  # C7 to S3 along the skin
    upright_pitch_deg: tuple[float, ...]  # the back's pitch at KNOTS_V sitting upright
    forward_deg: float  # how far the top of the back turns leaning forward
    hinge: float  # share of the forward lean at the hips
    lumbar: float  # share of the spine's flexion in the lumbar part
    back_deg: float  # how far the trunk reclines leaning back
    slump: float  # q: the spine's flexion leaning back, per degree reclined
    sway_deg: float  # SD of the slow sway of pelvis and spine
    lateral_sway_deg: float  # SD of the slow sideways sway
    breath_hz: float
    breath_deg: float
    bounce: float  # bounce amplitude, fraction of the weight
    bounce_hz: float
    rock_period_s: float

    @property
    def weight_n(self) -> float:
        """Body weight in N under standard gravity (:data:`psmat.units.STANDARD_GRAVITY_M_S2`)."""
        return n_from_kg(self.weight_kg)

    @property
    def bmi(self) -> float:
        return self.weight_kg / (self.height_cm / 100.0) ** 2

    @property
    def thigh_length_cm(self) -> float:
        return THIGH_PER_HEIGHT * self.height_cm

    @property
    def soft_tissue(self) -> float:
        """Width factor of the buttock, thigh and sacral lobes: sqrt(BMI / 22)."""
        return math.sqrt(self.bmi / 22.0)

    def anatomy(self) -> dict[str, float]:
        """Keyword arguments of :func:`psmat.twin.anatomy.seat_groups` for this person."""
        return {"thigh_length_cm": self.thigh_length_cm, "thigh_splay_deg": self.thigh_splay_deg,
                "soft_tissue": self.soft_tissue}

    def as_dict(self) -> dict[str, Any]:
        d = asdict(self)
        d.update(weight_n=self.weight_n, bmi=self.bmi, thigh_length_cm=self.thigh_length_cm,
                 soft_tissue=self.soft_tissue, knots_v=list(KNOTS_V))
        d["upright_pitch_deg"] = list(self.upright_pitch_deg)
        return d


@dataclass(frozen=True)
class SeatedDay:
    """What one session changes (see the module docstring): seat pose, IMU placement and mounting, the day's lean."""

    seat_origin_cm: tuple[float, float]  # the seat's origin on the mat (x, y)
    seat_rotation_deg: float
    top_sensor_cm: float  # the top sensor's distance below C7 along the back (negative: above)
    mount_deg: NDArray[np.float64]  # (5, 3) mounting offsets: heading, roll, pitch
    room_heading_deg: float
    forward_scale: float
    back_scale: float
    pelvis_offset_deg: float
    lateral_bias_deg: float
    slump_deg: float  # lumbar flexion gained slowly over the session

    def as_dict(self) -> dict[str, Any]:
        d = asdict(self)
        d["mount_deg"] = np.asarray(self.mount_deg).tolist()
        d["seat_origin_cm"] = list(self.seat_origin_cm)
        return d


def _normal(rng: np.random.Generator, mean: float, sd: float, lo: float, hi: float) -> float:
    return float(np.clip(rng.normal(mean, sd), lo, hi))


def draw_seated_subject(rng: np.random.Generator, sex: str | None = None) -> SeatedSubject:
    """A person of thesis Table 4.2 on the cushion (every choice in the module docstring).

    Parameters
    ----------
    rng : numpy.random.Generator
    sex : {"M", "F"}, optional
        Drawn with Table 4.2's share of men when not given.
    """
    if sex is None:
        sex = "M" if rng.random() < TABLE_4_2["men"] else "F"
    if sex not in _SEX:
        raise ValueError(f"sex must be 'M' or 'F', got {sex!r}")
    row = _SEX[sex]
    height = round(_normal(rng, *row["height_cm"], *_LIMITS["height_cm"]), 1)
    bmi = rng.normal(*row["bmi"])
    weight = round(float(np.clip(bmi * (height / 100.0) ** 2, *_LIMITS["weight_kg"])), 1)
    age = int(round(_normal(rng, *TABLE_4_2["age"], *_LIMITS["age"])))
    u = rng.uniform
    return SeatedSubject(
        sex=sex, age=age, height_cm=height, weight_kg=weight,
        tuberosity_distance_cm=round(_normal(rng, *row["it_cm"], *_LIMITS["it_cm"]), 2),
        thigh_splay_deg=float(u(15.0, 35.0)), seat_share=float(u(0.70, 0.85)), thigh_share=float(u(0.20, 0.35)),
        moment_share=float(u(0.25, 0.45)),
        back_length_cm=BACK_PER_HEIGHT * height * float(np.exp(rng.normal(0.0, 0.03))),
        upright_pitch_deg=tuple(float(v) for v in np.asarray(UPRIGHT_PITCH_DEG) + rng.normal(0.0, 4.0, 5)),
        forward_deg=float(u(15.0, 35.0)), hinge=float(u(0.3, 0.8)), lumbar=float(u(0.3, 0.7)),
        back_deg=float(u(8.0, 20.0)), slump=float(u(0.2, 0.6)),
        sway_deg=float(u(0.5, 1.5)), lateral_sway_deg=float(u(0.5, 2.0)),
        breath_hz=float(u(0.2, 0.3)), breath_deg=float(u(0.3, 1.0)),
        bounce=float(u(0.15, 0.35)), bounce_hz=float(u(1.5, 2.5)), rock_period_s=float(u(7.0, 11.0)),
    )


def draw_seated_day(rng: np.random.Generator, mat_centre_cm: NDArray[np.float64]) -> SeatedDay:
    """One session's seat pose, IMU placement and mounting, and lean (module docstring).

    Parameters
    ----------
    rng : numpy.random.Generator
    mat_centre_cm : (x, y)
        The mat's centre, cm (:func:`psmat.twin.field.mat_centre_cm`).
    """
    origin = np.asarray(mat_centre_cm, dtype=np.float64) + np.array([0.0, -4.0]) + rng.uniform(-3.0, 3.0, 2)
    mount = np.column_stack([rng.normal(0.0, 3.0, 5), rng.normal(0.0, 2.0, 5), rng.normal(0.0, 2.0, 5)])
    return SeatedDay(
        seat_origin_cm=(float(origin[0]), float(origin[1])),
        seat_rotation_deg=_normal(rng, 0.0, 6.0, -15.0, 15.0),
        top_sensor_cm=float(rng.normal(0.0, 1.5)), mount_deg=mount,
        room_heading_deg=float(rng.uniform(0.0, 360.0)),
        forward_scale=_normal(rng, 1.0, 0.12, 0.7, 1.3), back_scale=_normal(rng, 1.0, 0.12, 0.7, 1.3),
        pelvis_offset_deg=float(rng.normal(0.0, 2.0)), lateral_bias_deg=float(rng.normal(0.0, 1.0)),
        slump_deg=float(rng.uniform(0.0, 4.0)),
    )

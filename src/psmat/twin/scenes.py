"""Seeded pressure scenes of the digital twin (docs/spec.md §5): a person standing or sitting on the mat.

Each generator places the feet (or the seat's lobes, :mod:`psmat.twin.anatomy`) and moves
the load between their groups so that the field's CoP follows a target
(:mod:`psmat.twin.steering`); the cell images are the field averaged over each cell
(:mod:`psmat.twin.field`: psi, cm, cell ``(i, p)`` at ``(p·pitch, i·pitch)``).

* :func:`quiet_standing` — two feet, band-limited sway of a few mm.
* :func:`single_leg_sway` — one foot, larger sway.
* :func:`trajectory_sway` — the CoP follows a recorded force-platform trajectory (e.g.
  the BDS data set; :func:`psmat.io.load_bds`), total force following ``Fz``,
  on two feet or on one (:func:`stance_groups`).
* :func:`uniform_load` — the whole mat under one pressure (a bladder or masses on a rigid
  plate), put on after an unloaded lead-in: the recordings of an equilibration
  (:func:`psmat.pressure.equilibrate`).
* seated scenes — :func:`psmat.twin.seated.sitting` and
  :func:`~psmat.twin.seated.seat_scene` (the cushion, docs/spec.md §8), built on :func:`scene_args`
  and :class:`PressureScene` here.

All return a :class:`PressureScene`, whose ``cop_true_cm`` is the CoP of the continuous field
(what a force platform under the mat would measure). The image's total force equals the load
up to the quadrature error (≪ 1 %) and the part of the field that falls off the mat
(``meta["force_on_mat_fraction"]``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from dataclasses import field as _dc_field
from typing import Any, Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._checks import fraction, nonneg_int, pair, positive, positive_int, shape2, vector
from .anatomy import check_foot_size, check_side, single_foot_groups, two_feet_groups
from ..units import kpa_from_psi
from .field import Lobes, cell_force_n, mat_centre_cm
from .steering import steer
from .sway import check_band, sway_noise, time_base

__all__ = ["PressureScene", "quiet_standing", "single_leg_sway", "trajectory_sway", "stance_groups", "scene_args",
           "STANCES", "uniform_load"]

#: Stances of :func:`trajectory_sway`: both feet, or only the right or the left foot.
STANCES = ("two", "right", "left")


@dataclass
class PressureScene:
    """A simulated recording of pressure on the mat.

    Attributes
    ----------
    pressure_psi : ndarray, shape (T, R, C)
        Cell pressures in psi (>= 0), each the field averaged over the cell's area.
    t : ndarray, shape (T,)
        Frame times in s.
    cop_true_cm : ndarray, shape (T, 2)
        Centre of pressure (x = M-L, y = A-P) of the continuous field in cm, mat coordinates
        (what a force platform under the mat would measure).
    force_n : ndarray, shape (T,)
        Total force of the continuous field in N.
    meta : dict
        Scene description: ``scene``, ``shape``, ``pitch_cm``, ``rate_hz``, ``seed``,
        ``supersample``, ``groups`` (names), ``group_lobes`` (unit-force :class:`Lobes` per
        group), ``weights_n`` (T, G) group forces, ``cop_target_cm`` (T, 2), ``clipped``
        (T,) bool, ``n_clipped``, ``clip_cm`` (T,) distance target → reached,
        ``force_on_mat_fraction`` (T,) share of the load the mat's area sees, and the
        scene's own parameters.
    """

    pressure_psi: NDArray[np.float64]
    t: NDArray[np.float64]
    cop_true_cm: NDArray[np.float64]
    force_n: NDArray[np.float64]
    meta: dict[str, Any] = _dc_field(default_factory=dict)

    @property
    def pitch_cm(self) -> float:
        """Cell pitch in cm."""
        return float(self.meta["pitch_cm"])

    @property
    def pressure_kpa(self) -> NDArray[np.float64]:
        """Cell pressures in kPa (docs/spec.md §1: SI at the API; :attr:`pressure_psi` is in psi, the sensor model's unit)."""
        return kpa_from_psi(self.pressure_psi)

    def field(self, k: int) -> Lobes:
        """The continuous pressure field of frame ``k`` (for checks and re-rendering)."""
        w = self.meta["weights_n"][k]
        out: Lobes | None = None
        for g, lobes in zip(w, self.meta["group_lobes"]):
            part = lobes.scaled(float(g))
            out = part if out is None else out + part
        assert out is not None
        return out

    def cell_force_n(self) -> NDArray[np.float64]:
        """Force seen by the mat, ``Σ p · cell area``, (T,) in N."""
        return cell_force_n(self.pressure_psi, self.pitch_cm)


def _render(
    scene: str,
    groups: Sequence[tuple[str, Lobes]],
    nominal: Sequence[float],
    t: NDArray[np.float64],
    target_cm: NDArray[np.float64],
    force_n: NDArray[np.float64],
    shape: tuple[int, int],
    pitch: float,
    supersample: int,
    min_fraction: float,
    extra: dict[str, Any],
) -> PressureScene:
    """:func:`~psmat.twin.steering.steer` the groups onto the targets and wrap the frames as a scene."""
    s = steer(scene, groups, nominal, target_cm, force_n, shape, pitch, supersample, min_fraction, extra)
    return PressureScene(pressure_psi=s.pressure_psi, t=t, cop_true_cm=s.cop_true_cm, force_n=force_n.copy(), meta=s.meta)


def _mat_args(shape: Any, pitch_cm: Any, min_fraction: Any, supersample: Any) -> tuple[tuple[int, int], float, float, int]:
    """Checked ``(shape, pitch, min_fraction, supersample)`` shared by every scene generator."""
    return (
        shape2(shape),
        positive("pitch_cm", pitch_cm),
        fraction("min_fraction", min_fraction, 0.0, 0.25),
        positive_int("supersample", supersample),
    )


@dataclass(frozen=True)
class _SceneArgs:
    """Checked arguments common to the seeded scene generators (see :func:`_scene_args`)."""

    shape: tuple[int, int]
    pitch: float
    weight: float
    seed: int
    t: NDArray[np.float64]
    rate: float
    sway: tuple[float, float]
    band: tuple[float, float]
    min_fraction: float
    supersample: int

    @property
    def centre(self) -> NDArray[np.float64]:
        """The mat centre (x, y) in cm."""
        return mat_centre_cm(self.shape, self.pitch)

    def rng(self) -> np.random.Generator:
        """A fresh generator seeded with ``seed``."""
        return np.random.default_rng(self.seed)

    def sway_noise(self, rng: np.random.Generator) -> NDArray[np.float64]:
        """Band-limited sway (T, 2) in cm with SDs ``sway`` (M-L, A-P), drawn from ``rng``."""
        return sway_noise(self.t.size, self.rate, self.sway, self.band, rng)

    def render(
        self,
        scene: str,
        groups: Sequence[tuple[str, Lobes]],
        nominal: Sequence[float],
        target_cm: NDArray[np.float64],
        extra: dict[str, Any],
        load_n: float | None = None,
    ) -> PressureScene:
        """:func:`_render` with a constant total force ``load_n`` (default: the weight)."""
        load = self.weight if load_n is None else load_n
        meta = {"rate_hz": self.rate, "seed": self.seed, "weight_n": self.weight,
                "sway_cm": self.sway, "band_hz": self.band}
        meta.update(extra)
        return _render(scene, groups, nominal, self.t, target_cm, np.full(self.t.size, load),
                       self.shape, self.pitch, self.supersample, self.min_fraction, meta)


def scene_args(
    duration_s: Any,
    rate_hz: Any,
    shape: Any,
    pitch_cm: Any,
    weight_n: Any,
    seed: Any,
    sway_cm: Any,
    band_hz: Any,
    min_fraction: Any,
    supersample: Any,
) -> _SceneArgs:
    """Check the arguments shared by :func:`quiet_standing`, :func:`single_leg_sway`, :func:`sitting`."""
    shape_, pitch, lo, s = _mat_args(shape, pitch_cm, min_fraction, supersample)
    weight = positive("weight_n", weight_n)
    seed_ = nonneg_int("seed", seed)
    t, rate = time_base(duration_s, rate_hz)
    return _SceneArgs(shape_, pitch, weight, seed_, t, rate, pair("sway_cm", sway_cm), check_band(band_hz), lo, s)


def _two_feet_args(
    shape: tuple[int, int],
    pitch: float,
    foot_length_cm: Any,
    foot_width_cm: Any,
    stance_cm: Any,
    toe_out_deg: Any,
    heel_fraction: Any,
) -> tuple[list[tuple[str, Lobes]], NDArray[np.float64], dict[str, Any]]:
    """Checked two-feet stance: ``(groups, nominal fractions, meta)`` (see :func:`~psmat.twin.anatomy.two_feet_groups`)."""
    length, width, toe = check_foot_size(foot_length_cm, foot_width_cm, toe_out_deg)
    stance = positive("stance_cm", stance_cm)
    h = fraction("heel_fraction", heel_fraction)
    nominal = np.array([h, 1.0 - h, h, 1.0 - h]) / 2.0
    groups = two_feet_groups(shape, pitch, length, width, stance, toe, nominal)
    meta = {"foot_length_cm": length, "foot_width_cm": width, "stance_cm": stance, "toe_out_deg": toe}
    return groups, nominal, meta


def quiet_standing(
    duration_s: float,
    rate_hz: float,
    shape: tuple[int, int] = (16, 16),
    pitch_cm: float = 2.0,
    weight_n: float = 700.0,
    seed: int = 0,
    *,
    sway_cm: tuple[float, float] = (0.25, 0.35),
    band_hz: tuple[float, float] = (0.2, 1.0),
    foot_length_cm: float = 24.0,
    foot_width_cm: float = 9.0,
    stance_cm: float = 15.0,
    toe_out_deg: float = 7.0,
    heel_fraction: float = 0.6,
    min_fraction: float = 0.02,
    supersample: int = 5,
) -> PressureScene:
    """Two feet standing still, the CoP swaying by a few mm.

    The feet are mirror images about the mat's vertical midline, placed so that the nominal
    CoP is at the mat centre; the CoP follows Gaussian noise band-limited to ``band_hz``
    with standard deviations ``sway_cm`` (M-L, A-P). The total force is ``weight_n``.

    Parameters
    ----------
    duration_s : float
        Length of the recording in s.
    rate_hz : float
        Frame rate in Hz; frames at ``t = k / rate_hz``.
    shape : (R, C)
        Mat size in cells.
    pitch_cm : float
        Cell pitch in cm.
    weight_n : float
        Body weight in N (> 0).
    seed : int
        Seed of the sway noise.
    sway_cm : (float, float)
        Standard deviation of the CoP, (M-L, A-P) in cm; (0, 0) gives a still, symmetric scene.
    band_hz : (float, float)
        Frequency band of the sway, Hz.
    foot_length_cm, foot_width_cm : float
        Foot size in cm.
    stance_cm : float
        Distance between the two feet's long axes at their centres, cm.
    toe_out_deg : float
        Each foot turned outwards by this angle, degrees.
    heel_fraction : float
        Nominal share of each foot's load on the rearfoot.
    min_fraction : float
        Least share of the load any of the four groups keeps.
    supersample : int
        Points per cell side when averaging the field over a cell.

    Returns
    -------
    PressureScene
    """
    a = scene_args(duration_s, rate_hz, shape, pitch_cm, weight_n, seed, sway_cm, band_hz, min_fraction, supersample)
    groups, nominal, feet = _two_feet_args(
        a.shape, a.pitch, foot_length_cm, foot_width_cm, stance_cm, toe_out_deg, heel_fraction
    )
    target = a.centre + a.sway_noise(a.rng())
    return a.render("quiet_standing", groups, nominal, target, feet)


def single_leg_sway(
    duration_s: float,
    rate_hz: float,
    shape: tuple[int, int] = (16, 16),
    pitch_cm: float = 2.0,
    weight_n: float = 700.0,
    seed: int = 0,
    *,
    side: str = "left",
    sway_cm: tuple[float, float] = (0.5, 0.7),
    band_hz: tuple[float, float] = (0.2, 1.5),
    foot_length_cm: float = 24.0,
    foot_width_cm: float = 9.0,
    heel_fraction: float = 0.5,
    min_fraction: float = 0.02,
    supersample: int = 5,
) -> PressureScene:
    """One foot on the mat (single-leg stance), the CoP swaying by 5-7 mm (SD).

    The foot points along ``+y`` with its nominal CoP at the mat centre; the load moves
    between the medial and lateral rearfoot (heel; lateral midfoot) and the medial
    (first metatarsal, hallux) and lateral (lateral metatarsals, lesser toes) forefoot, which
    lets the CoP move in M-L and A-P within the foot. Targets beyond that region (a
    quadrilateral ~3 cm wide at the heel, ~4 cm at the metatarsals) are clipped (``meta``).

    Parameters
    ----------
    duration_s, rate_hz, shape, pitch_cm, weight_n, seed
        As :func:`quiet_standing` (s, Hz, cells, cm, N, -).
    side : {"left", "right"}
        The standing foot.
    sway_cm : (float, float)
        Standard deviation of the CoP, (M-L, A-P) in cm.
    band_hz : (float, float)
        Frequency band of the sway in Hz.
    foot_length_cm, foot_width_cm : float
        Foot size in cm.
    heel_fraction : float
        Nominal share of the load on the rearfoot.
    min_fraction : float
        Least share of the load any group keeps.
    supersample : int
        Points per cell side when averaging the field over a cell.

    Returns
    -------
    PressureScene
    """
    a = scene_args(duration_s, rate_hz, shape, pitch_cm, weight_n, seed, sway_cm, band_hz, min_fraction, supersample)
    side = check_side(side)
    length, width, _ = check_foot_size(foot_length_cm, foot_width_cm, 0.0)
    h = fraction("heel_fraction", heel_fraction)
    centre = a.centre
    nominal = np.array([h, h, 1.0 - h, 1.0 - h]) / 2.0
    groups = single_foot_groups(centre, side, length, width, nominal)
    target = centre + a.sway_noise(a.rng())
    return a.render(
        "single_leg_sway", groups, nominal, target,
        {"side": side, "foot_length_cm": length, "foot_width_cm": width},
    )


def stance_groups(
    stance: str,
    shape: tuple[int, int],
    pitch_cm: float,
    position_cm: tuple[float, float] | None = None,
    *,
    foot_length_cm: float = 24.0,
    foot_width_cm: float = 9.0,
    stance_cm: float = 15.0,
    toe_out_deg: float = 7.0,
    heel_fraction: float = 0.6,
) -> tuple[list[tuple[str, Lobes]], NDArray[np.float64], dict[str, Any]]:
    """The load groups of :func:`trajectory_sway` for a stance, placed on the mat.

    Parameters
    ----------
    stance : {"two", "right", "left"}
        Both feet (left/right rearfoot/forefoot, :func:`~psmat.twin.anatomy.two_feet_groups`)
        or one foot (its medial/lateral rearfoot/forefoot,
        :func:`~psmat.twin.anatomy.single_foot_groups`).
    shape, pitch_cm
        Mat size in cells and cell pitch in cm.
    position_cm : (float, float), optional
        The nominal CoP of the stance, mat coordinates in cm; default the mat centre.
    foot_length_cm, foot_width_cm, stance_cm, toe_out_deg, heel_fraction
        As :func:`quiet_standing` (``stance_cm`` and ``toe_out_deg`` for two feet only).

    Returns
    -------
    groups : list of (name, Lobes)
        Unit-force groups.
    nominal : ndarray, shape (4,)
        Nominal share of the load of each group (sum 1): the CoP at ``position_cm``.
    meta : dict
        ``stance``, ``position_cm`` and the foot parameters used.
    """
    if stance not in STANCES:
        raise ValueError(f"stance must be one of {', '.join(map(repr, STANCES))}, got {stance!r}")
    pitch = positive("pitch_cm", pitch_cm)
    mid = mat_centre_cm(shape2(shape), pitch)
    pos = mid if position_cm is None else np.array(pair("position_cm", position_cm, nonneg=False, labels="x, y"))
    if stance == "two":
        groups, nominal, feet = _two_feet_args(
            shape2(shape), pitch, foot_length_cm, foot_width_cm, stance_cm, toe_out_deg, heel_fraction
        )
        dx, dy = pos - mid
        groups = [(n, l.shifted(dx, dy)) for n, l in groups]
    else:
        length, width, _ = check_foot_size(foot_length_cm, foot_width_cm, 0.0)
        h = fraction("heel_fraction", heel_fraction)
        nominal = np.array([h, h, 1.0 - h, 1.0 - h]) / 2.0
        groups = single_foot_groups(pos, stance, length, width, nominal)
        feet = {"foot_length_cm": length, "foot_width_cm": width}
    return groups, nominal, {"stance": stance, "position_cm": pos, **feet}


def trajectory_sway(
    t: ArrayLike,
    cop_ml_cm: ArrayLike,
    cop_ap_cm: ArrayLike,
    fz_n: ArrayLike,
    rate_hz: float,
    shape: tuple[int, int] = (16, 16),
    pitch_cm: float = 2.0,
    *,
    centre: bool = True,
    stance: str = "two",
    position_cm: tuple[float, float] | None = None,
    foot_length_cm: float = 24.0,
    foot_width_cm: float = 9.0,
    stance_cm: float = 15.0,
    toe_out_deg: float = 7.0,
    heel_fraction: float = 0.6,
    min_fraction: float = 0.02,
    supersample: int = 5,
) -> PressureScene:
    """A person standing on the mat whose CoP follows a recorded force-platform trajectory.

    The recording is resampled (linear interpolation — the mat samples the field at its
    frame times) to ``t[0] + k / rate_hz`` up to ``t[-1]``. The trajectory is relative: with
    ``centre=True`` its mean is moved to ``position_cm`` (``meta["offset_cm"]`` is the shift
    added to the input), otherwise the input is taken as the displacement from
    ``position_cm``. M-L maps to ``x`` (positive = the subject's right), A-P to ``y``
    (positive = anterior, towards the toes). The feet stay in place (:func:`stance_groups`):
    with ``stance="two"`` both feet (as :func:`quiet_standing`) and the load moves between
    the feet and between heel and forefoot; with ``"right"`` or ``"left"`` that foot alone
    (single-leg stance, as :func:`single_leg_sway`) and the load moves between its medial
    and lateral rearfoot and forefoot. The field's CoP equals the target exactly and the
    total force equals ``fz``. Targets out of the feet's reach are moved to the nearest
    reachable point: ``meta["clipped"]``, ``meta["clip_cm"]``.

    Parameters
    ----------
    t : array_like, shape (N,)
        Sample times of the recording in s, strictly increasing.
    cop_ml_cm, cop_ap_cm : array_like, shape (N,)
        Medial-lateral and anterior-posterior CoP in cm. (In the BDS data set COPy is M-L
        and COPx is A-P.)
    fz_n : array_like, shape (N,) or scalar
        Vertical force in N (> 0).
    rate_hz : float
        Frame rate of the scene in Hz.
    shape, pitch_cm
        Mat size in cells and cell pitch in cm.
    centre : bool
        Centre the trajectory's mean on ``position_cm`` (default) or use it as offsets from it.
    stance : {"two", "right", "left"}
        Both feet, or only the right or the left foot on the mat.
    position_cm : (float, float), optional
        Where the stance's nominal CoP stands, mat coordinates in cm; default the mat centre.
    foot_length_cm, foot_width_cm, stance_cm, toe_out_deg, heel_fraction, min_fraction, supersample
        As :func:`quiet_standing` (``stance_cm`` and ``toe_out_deg`` for two feet only).

    Returns
    -------
    PressureScene
    """
    tt = vector("t", t)
    ml = vector("cop_ml_cm", cop_ml_cm)
    ap = vector("cop_ap_cm", cop_ap_cm)
    try:
        fz = np.asarray(fz_n, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError("fz_n must be a number or a 1-D array of numbers (N)") from None
    if fz.ndim == 0:
        fz = np.full(tt.shape, float(fz))
    fz = vector("fz_n", fz)
    if tt.size < 2:
        raise ValueError(f"t needs at least 2 samples, got {tt.size}")
    if not (ml.size == ap.size == fz.size == tt.size):
        raise ValueError(
            f"t, cop_ml_cm, cop_ap_cm and fz_n must have the same length, got "
            f"{tt.size}, {ml.size}, {ap.size}, {fz.size}"
        )
    if np.any(np.diff(tt) <= 0):
        raise ValueError("t must be strictly increasing")
    if np.any(fz <= 0):
        raise ValueError(f"fz_n must be > 0 N (someone standing on the mat), min is {fz.min()!r}")
    rate = positive("rate_hz", rate_hz)
    shape, pitch, lo, s = _mat_args(shape, pitch_cm, min_fraction, supersample)
    groups, nominal, feet = stance_groups(
        stance, shape, pitch, position_cm, foot_length_cm=foot_length_cm, foot_width_cm=foot_width_cm,
        stance_cm=stance_cm, toe_out_deg=toe_out_deg, heel_fraction=heel_fraction,
    )

    n = int(math.floor((tt[-1] - tt[0]) * rate + 1e-9)) + 1
    t_out = tt[0] + np.arange(n) / rate
    t_out = np.minimum(t_out, tt[-1])
    ml_o, ap_o, fz_o = (np.interp(t_out, tt, v) for v in (ml, ap, fz))
    mid = feet["position_cm"]
    offset = mid - (np.array([ml.mean(), ap.mean()]) if centre else 0.0)
    target = np.column_stack([ml_o, ap_o]) + offset
    return _render(
        "trajectory_sway", groups, nominal, t_out, target, fz_o, shape, pitch, s, lo,
        {"rate_hz": rate, "seed": None, "offset_cm": offset, "input_rate_hz": float((tt.size - 1) / (tt[-1] - tt[0])),
         **feet},
    )


def uniform_load(duration_s: float, rate_hz: float, level_kpa: float, shape: tuple[int, int] = (16, 16),
                 pitch_cm: float = 2.0, *, onset_s: float = 1.0, ramp_s: float = 0.5) -> PressureScene:
    """The whole mat under one pressure, put on after an unloaded lead-in.

    Parameters
    ----------
    duration_s : float
        Length of the recording in s.
    rate_hz : float
        Frame rate in Hz.
    level_kpa : float
        The uniform pressure once the load is on, kPa (> 0).
    shape : (R, C)
        Mat size in cells.
    pitch_cm : float
        Cell pitch in cm.
    onset_s : float
        Unloaded time before the load starts to go on, s (>= 0).
    ramp_s : float
        Time the load takes to go on (linear), s (>= 0).

    Returns
    -------
    PressureScene
        Every cell at the same pressure; the CoP at the mat centre.
    """
    shape_, pitch, _, _ = _mat_args(shape, pitch_cm, 0.0, 1)
    level = positive("level_kpa", level_kpa)
    onset = fraction("onset_s", onset_s, 0.0, math.inf)
    ramp = fraction("ramp_s", ramp_s, 0.0, math.inf)
    t, rate = time_base(duration_s, rate_hz)
    on = np.clip((t - onset) / ramp, 0.0, 1.0) if ramp > 0 else (t >= onset).astype(np.float64)
    p_psi = np.broadcast_to((level / kpa_from_psi(1.0)) * on[:, None, None], (t.size,) + shape_).copy()
    force = cell_force_n(p_psi, pitch)
    cop = np.broadcast_to(mat_centre_cm(shape_, pitch), (t.size, 2)).copy()
    meta = {"scene": "uniform_load", "shape": shape_, "pitch_cm": pitch, "rate_hz": rate, "level_kpa": level,
            "onset_s": onset, "ramp_s": ramp}
    return PressureScene(pressure_psi=p_psi, t=t, cop_true_cm=cop, force_n=force, meta=meta)

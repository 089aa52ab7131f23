"""Pressure fields on the mat for the digital twin (SPEC §5): feet, seats, sway.

Arrays in, arrays out, pure NumPy, seeded.

Units and conventions
---------------------
* Pressure in **psi** (the sensor model's unit, SPEC §1; 1 psi = 6894.757 Pa), forces in
  **N**, lengths and positions in **cm**, times in **s**.
* Mat of ``R × C`` cells at ``pitch_cm``; the origin is the centre of cell ``(0, 0)``; cell
  ``(i, p)`` has its centre at ``x = p·pitch`` (medial–lateral, along the columns) and
  ``y = i·pitch`` (anterior–posterior, along the rows). A person stands facing ``+y``
  (toes towards larger ``y``), so their right is ``+x``. The mat's centre is
  ``((C − 1)/2·pitch, (R − 1)/2·pitch)``.
* Centre of pressure of a cell image (SPEC §7): ``x = Σ p·x_cell / Σ p`` at cell centres
  (:func:`cell_cop_cm`).

The continuous field
--------------------
A load is a sum of smooth elliptical **lobes**: lobe ``k`` carries the force ``F_k`` (N)
with the pressure

    q_k(x, y) = F_k · (1 − d²)₊³ / (π a b / 4),   d² = (u/a)² + (v/b)²

(``u, v`` the coordinates along / across the lobe's axes, ``a, b`` its semi-axes in cm).
It is twice continuously differentiable, zero outside the ellipse, integrates to exactly
``F_k`` and has its centre of pressure exactly at the lobe centre, so a field's total force
and CoP are known in closed form (:class:`Lobes`): that CoP is what a force platform under
the mat would measure and is the ``cop_true_cm`` of a scene.

The cell image is the field averaged over each cell's area (``supersample × supersample``
points per cell, 5 × 5 by default), so a continuously moving field gives a continuously
changing image and cell CoP. A cell's force is its pressure times its area (4 cm² at 2 cm
pitch); the image's total force equals the load up to the quadrature error (≪ 1 %) and the
part of the field that falls off the mat (reported in a scene's ``meta``).

The foot
--------
:func:`foot` builds a plantar pressure distribution of length ``length_cm`` (heel to toe
tip, default 24 cm) and width ``width_cm`` (default 9 cm) from lobes under the heel, the
lateral midfoot, the metatarsal heads (medial, central, lateral), the hallux and the
lesser toes. Its load is split between the *rearfoot* (heel + midfoot; ``heel_fraction``,
default 0.6) and the *forefoot*.

Scenes
------
In the scene generators the feet (or the seat's lobes) stay where they are and the load
moves between **groups** of lobes (e.g. left/right rearfoot/forefoot) — as a person
swaying on the spot does. The field's CoP is linear in the group forces, so for each frame
the group forces are solved so that the CoP equals the target exactly; among the
solutions the one closest to the nominal distribution is taken, with every group keeping
at least ``min_fraction`` of the load. Targets the groups cannot reach are moved to the
nearest reachable point and reported (``meta["clipped"]``, ``meta["clip_cm"]``).

* :func:`quiet_standing` — two feet, band-limited sway of a few mm.
* :func:`single_leg_sway` — one foot, larger sway.
* :func:`trajectory_sway` — the CoP follows a recorded force-platform trajectory (e.g.
  the BDS data set; :func:`psmat.io.forceplate.load_bds`), total force following ``Fz``.
* :func:`sitting` — two ischial tuberosities and the thighs on a cushion (SPEC §8), slow
  lean.

All return a :class:`PressureScene`.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass
from dataclasses import field as _dc_field
from typing import Any, Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial import ConvexHull, QhullError

__all__ = [
    "PSI_PA",
    "Lobes",
    "PressureScene",
    "foot",
    "two_feet",
    "cell_centres_cm",
    "cell_pressure_psi",
    "cell_force_n",
    "cell_cop_cm",
    "quiet_standing",
    "single_leg_sway",
    "trajectory_sway",
    "sitting",
]

from ..balance import cop as _cop  # noqa: E402  (one home for the CoP, SPEC §7)
from ..units import PSI_PA  # noqa: E402  (one psi in Pa; one home for the constant)

_N_PER_CM2_TO_PSI = 1.0e4 / PSI_PA  # 1 N/cm² = 1e4 Pa
_BUMP_EXPONENT = 3
_BUMP_INTEGRAL = math.pi / (_BUMP_EXPONENT + 1)  # ∫∫ (1 - r²)₊³ over the unit disk


# ------------------------------------------------------------------------------ checks
def _shape2(shape: Any) -> tuple[int, int]:
    try:
        dims = tuple(shape)
    except TypeError:
        raise ValueError(f"shape must be a pair (rows, cols), got {shape!r}") from None
    if len(dims) != 2:
        raise ValueError(f"shape must be a pair (rows, cols), got {shape!r}")
    out = []
    for d in dims:
        if isinstance(d, (bool, np.bool_)) or not isinstance(d, (int, np.integer)) or d < 1:
            raise ValueError(f"shape must hold two positive integers (rows, cols), got {shape!r}")
        out.append(int(d))
    return out[0], out[1]


def _positive(name: str, value: Any) -> float:
    if np.ndim(value) != 0:
        raise ValueError(f"{name} must be a single number, got an array of shape {np.shape(value)}")
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a positive number, got {value!r}") from None
    if not (math.isfinite(v) and v > 0):
        raise ValueError(f"{name} must be a finite number > 0, got {value!r}")
    return v


def _finite(name: str, value: Any) -> float:
    if np.ndim(value) != 0:
        raise ValueError(f"{name} must be a single number, got an array of shape {np.shape(value)}")
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a finite number, got {value!r}") from None
    if not math.isfinite(v):
        raise ValueError(f"{name} must be a finite number, got {value!r}")
    return v


def _fraction(name: str, value: Any, lo: float = 0.0, hi: float = 1.0) -> float:
    v = _finite(name, value)
    if not lo <= v <= hi:
        raise ValueError(f"{name} must lie in [{lo}, {hi}], got {value!r}")
    return v


def _supersample(value: Any) -> int:
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)) or value < 1:
        raise ValueError(f"supersample must be an integer >= 1, got {value!r}")
    return int(value)


def _seed(seed: Any) -> int:
    if isinstance(seed, (bool, np.bool_)) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ValueError(f"seed must be a non-negative integer, got {seed!r}")
    return int(seed)


def _pair(name: str, value: Any, *, nonneg: bool = True) -> tuple[float, float]:
    a = np.asarray(value, dtype=np.float64) if not isinstance(value, str) else None
    if a is None or a.shape != (2,) or not np.all(np.isfinite(a)) or (nonneg and np.any(a < 0)):
        kind = "non-negative finite" if nonneg else "finite"
        raise ValueError(f"{name} must be a pair of {kind} numbers (ML, AP), got {value!r}")
    return float(a[0]), float(a[1])


def _vector(name: str, value: Any) -> NDArray[np.float64]:
    try:
        a = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a 1-D array of numbers") from None
    if a.ndim != 1:
        raise ValueError(f"{name} must be 1-D, got shape {a.shape}")
    if not np.all(np.isfinite(a)):
        bad = int(np.flatnonzero(~np.isfinite(a))[0])
        raise ValueError(f"{name} must be finite; sample {bad} is {a[bad]!r}")
    return a


# ------------------------------------------------------------------------------ lobes
@dataclass(frozen=True)
class Lobes:
    """A pressure field made of smooth elliptical lobes (see the module docstring).

    Attributes
    ----------
    centre_cm : ndarray, shape (K, 2)
        Lobe centres (x, y) in cm, mat coordinates.
    semi_axes_cm : ndarray, shape (K, 2)
        Semi-axes (a, b) in cm; ``a`` along the direction ``angle_rad``.
    angle_rad : ndarray, shape (K,)
        Direction of each lobe's first axis, counter-clockwise from ``+x``, in rad.
    force_n : ndarray, shape (K,)
        Force carried by each lobe in N (>= 0); the lobe's pressure integrates to it.
    """

    centre_cm: NDArray[np.float64]
    semi_axes_cm: NDArray[np.float64]
    angle_rad: NDArray[np.float64]
    force_n: NDArray[np.float64]

    def __post_init__(self) -> None:
        c = np.asarray(self.centre_cm, dtype=np.float64).reshape(-1, 2)
        k = c.shape[0]
        ax = np.asarray(self.semi_axes_cm, dtype=np.float64).reshape(-1, 2)
        an = np.asarray(self.angle_rad, dtype=np.float64).reshape(-1)
        f = np.asarray(self.force_n, dtype=np.float64).reshape(-1)
        if ax.shape[0] != k or an.shape[0] != k or f.shape[0] != k:
            raise ValueError(
                f"Lobes: centre_cm {c.shape}, semi_axes_cm {ax.shape}, angle_rad {an.shape} and "
                f"force_n {f.shape} must describe the same number of lobes"
            )
        for name, a in (("centre_cm", c), ("semi_axes_cm", ax), ("angle_rad", an), ("force_n", f)):
            if not np.all(np.isfinite(a)):
                raise ValueError(f"Lobes: {name} must be finite")
        if np.any(ax <= 0):
            raise ValueError("Lobes: semi_axes_cm must be > 0")
        if np.any(f < 0):
            raise ValueError("Lobes: force_n must be >= 0 (a mat cannot be pulled)")
        for name, a in (("centre_cm", c), ("semi_axes_cm", ax), ("angle_rad", an), ("force_n", f)):
            a.setflags(write=False)
            object.__setattr__(self, name, a)

    # ---------------------------------------------------------------- closed forms
    @property
    def n_lobes(self) -> int:
        """Number of lobes K."""
        return int(self.force_n.shape[0])

    @property
    def total_force_n(self) -> float:
        """Total force of the field in N (exact: the sum of the lobes' forces)."""
        return float(self.force_n.sum())

    @property
    def cop_cm(self) -> NDArray[np.float64]:
        """Centre of pressure of the continuous field, (x, y) in cm (exact)."""
        f = self.force_n
        tot = f.sum()
        if not tot > 0:
            raise ValueError("the field carries no load; its centre of pressure is undefined")
        return (f[:, None] * self.centre_cm).sum(axis=0) / tot

    # ---------------------------------------------------------------- algebra
    def scaled(self, factor: float) -> "Lobes":
        """The same field with every force multiplied by ``factor`` (>= 0)."""
        factor = _finite("factor", factor)
        if factor < 0:
            raise ValueError(f"factor must be >= 0, got {factor!r}")
        return Lobes(self.centre_cm, self.semi_axes_cm, self.angle_rad, self.force_n * factor)

    def with_total(self, force_n: float) -> "Lobes":
        """The same shape scaled so that the total force is ``force_n`` (N, >= 0)."""
        force_n = _finite("force_n", force_n)
        if force_n < 0:
            raise ValueError(f"force_n must be >= 0, got {force_n!r}")
        tot = self.total_force_n
        if not tot > 0:
            raise ValueError("cannot rescale a field that carries no load")
        return self.scaled(force_n / tot)

    def shifted(self, dx_cm: float, dy_cm: float) -> "Lobes":
        """The field translated by (dx, dy) cm."""
        d = np.array([_finite("dx_cm", dx_cm), _finite("dy_cm", dy_cm)])
        return Lobes(self.centre_cm + d, self.semi_axes_cm, self.angle_rad, self.force_n)

    def mirrored(self, x0_cm: float) -> "Lobes":
        """Mirror image about the line ``x = x0_cm`` (left foot ↔ right foot)."""
        x0 = _finite("x0_cm", x0_cm)
        c = self.centre_cm.copy()
        c[:, 0] = 2.0 * x0 - c[:, 0]
        return Lobes(c, self.semi_axes_cm, np.pi - self.angle_rad, self.force_n)

    def __add__(self, other: "Lobes") -> "Lobes":
        if not isinstance(other, Lobes):
            return NotImplemented
        return Lobes(
            np.concatenate([self.centre_cm, other.centre_cm]),
            np.concatenate([self.semi_axes_cm, other.semi_axes_cm]),
            np.concatenate([self.angle_rad, other.angle_rad]),
            np.concatenate([self.force_n, other.force_n]),
        )

    # ---------------------------------------------------------------- evaluation
    def pressure_psi(self, x_cm: ArrayLike, y_cm: ArrayLike) -> NDArray[np.float64]:
        """Pressure of the continuous field at points (x, y).

        Parameters
        ----------
        x_cm, y_cm : array_like
            Coordinates in cm (broadcast together).

        Returns
        -------
        ndarray
            Pressure in psi, the broadcast shape of ``x_cm`` and ``y_cm``.
        """
        x, y = np.broadcast_arrays(np.asarray(x_cm, dtype=np.float64), np.asarray(y_cm, dtype=np.float64))
        out = np.zeros(x.shape)
        cos, sin = np.cos(self.angle_rad), np.sin(self.angle_rad)
        peak = self.force_n / (_BUMP_INTEGRAL * self.semi_axes_cm[:, 0] * self.semi_axes_cm[:, 1])
        for k in range(self.n_lobes):
            if peak[k] == 0.0:
                continue
            dx = x - self.centre_cm[k, 0]
            dy = y - self.centre_cm[k, 1]
            u = (cos[k] * dx + sin[k] * dy) / self.semi_axes_cm[k, 0]
            v = (cos[k] * dy - sin[k] * dx) / self.semi_axes_cm[k, 1]
            s = np.clip(1.0 - (u * u + v * v), 0.0, None)
            out += peak[k] * s**_BUMP_EXPONENT
        return out * _N_PER_CM2_TO_PSI

    def cells_psi(
        self, shape: tuple[int, int] = (16, 16), pitch_cm: float = 2.0, supersample: int = 5
    ) -> NDArray[np.float64]:
        """The field averaged over each cell of the mat; see :func:`cell_pressure_psi`."""
        return cell_pressure_psi(self, shape, pitch_cm, supersample)


def cell_centres_cm(shape: tuple[int, int] = (16, 16), pitch_cm: float = 2.0) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Cell-centre coordinates ``X, Y`` (each ``(R, C)``, cm): ``X[i,p] = p·pitch``, ``Y[i,p] = i·pitch``."""
    r, c = _shape2(shape)
    pitch = _positive("pitch_cm", pitch_cm)
    return np.meshgrid(np.arange(c) * pitch, np.arange(r) * pitch)


def _subgrid(n: int, pitch: float, s: int) -> NDArray[np.float64]:
    """Sample coordinates (n·s,) along one axis: s midpoints inside each of n cells."""
    off = ((np.arange(s) + 0.5) / s - 0.5) * pitch
    return (np.arange(n)[:, None] * pitch + off[None, :]).ravel()


def cell_pressure_psi(
    lobes: Lobes, shape: tuple[int, int] = (16, 16), pitch_cm: float = 2.0, supersample: int = 5
) -> NDArray[np.float64]:
    """Pressure averaged over each cell's area (what a cell of the mat feels).

    Parameters
    ----------
    lobes : Lobes
        The continuous pressure field.
    shape : (R, C)
        Mat size in cells.
    pitch_cm : float
        Cell pitch in cm (cells are ``pitch × pitch``).
    supersample : int
        The average uses ``supersample × supersample`` midpoints per cell (default 5).

    Returns
    -------
    ndarray, shape (R, C)
        Cell pressure in psi (>= 0).
    """
    r, c = _shape2(shape)
    pitch = _positive("pitch_cm", pitch_cm)
    s = _supersample(supersample)
    xs, ys = _subgrid(c, pitch, s), _subgrid(r, pitch, s)
    p = lobes.pressure_psi(xs[None, :], ys[:, None])
    return p.reshape(r, s, c, s).mean(axis=(1, 3))


def cell_force_n(pressure_psi: ArrayLike, pitch_cm: float = 2.0) -> NDArray[np.float64]:
    """Total force on the mat, ``Σ p · cell area``, in N for each frame.

    Parameters
    ----------
    pressure_psi : array_like, shape (..., R, C)
        Cell pressures in psi.
    pitch_cm : float
        Cell pitch in cm (area ``pitch²`` cm²).

    Returns
    -------
    ndarray, shape (...)
        Force in N.
    """
    p = np.asarray(pressure_psi, dtype=np.float64)
    if p.ndim < 2:
        raise ValueError(f"pressure_psi must be (..., R, C), got shape {p.shape}")
    area_m2 = (_positive("pitch_cm", pitch_cm) * 1e-2) ** 2
    return p.sum(axis=(-2, -1)) * PSI_PA * area_m2


def cell_cop_cm(pressure_psi: ArrayLike, pitch_cm: float = 2.0) -> NDArray[np.float64]:
    """Centre of pressure of cell images (SPEC §7): ``x = Σ p·x_cell / Σ p``.

    Parameters
    ----------
    pressure_psi : array_like, shape (..., R, C)
        Cell pressures (any unit; only ratios matter).
    pitch_cm : float
        Cell pitch in cm; cell ``(i, p)`` is at ``(p·pitch, i·pitch)``.

    Returns
    -------
    ndarray, shape (..., 2)
        (x, y) in cm; NaN for an empty frame.
    """
    return _cop(pressure_psi, _positive("pitch_cm", pitch_cm))


# ------------------------------------------------------------------------------ foot
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


def _check_side(side: Any) -> str:
    if side not in ("left", "right"):
        raise ValueError(f"side must be 'left' or 'right', got {side!r}")
    return str(side)


def _check_foot_size(length_cm: Any, width_cm: Any, toe_out_deg: Any) -> tuple[float, float, float]:
    length = _positive("foot_length_cm", length_cm)
    width = _positive("foot_width_cm", width_cm)
    toe = _finite("toe_out_deg", toe_out_deg)
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
    x = _finite("x_cm", x_cm)
    y = _finite("y_cm", y_cm)
    load = _finite("load_n", load_n)
    if load < 0:
        raise ValueError(f"load_n must be >= 0 N, got {load_n!r}")
    side = _check_side(side)
    length, width, toe = _check_foot_size(length_cm, width_cm, toe_out_deg)
    h = _fraction("heel_fraction", heel_fraction)
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
    x = _finite("x_cm", x_cm)
    y = _finite("y_cm", y_cm)
    stance = _finite("stance_cm", stance_cm)
    stagger = _finite("stagger_cm", stagger_cm)
    load = _finite("load_n", load_n)
    if load < 0:
        raise ValueError(f"load_n must be >= 0 N, got {load_n!r}")
    half = load / 2.0
    kw = dict(length_cm=length_cm, width_cm=width_cm, toe_out_deg=toe_out_deg, heel_fraction=heel_fraction)
    left = foot(x - stance / 2, y - stagger / 2, half, side="left", **kw)
    right = foot(x + stance / 2, y + stagger / 2, half, side="right", **kw)
    return left + right


# ------------------------------------------------------------------------------ scenes
@dataclass
class PressureScene:
    """A simulated recording of pressure on the mat.

    Attributes
    ----------
    pressure : ndarray, shape (T, R, C)
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

    pressure: NDArray[np.float64]
    t: NDArray[np.float64]
    cop_true_cm: NDArray[np.float64]
    force_n: NDArray[np.float64]
    meta: dict[str, Any] = _dc_field(default_factory=dict)

    @property
    def pitch_cm(self) -> float:
        """Cell pitch in cm."""
        return float(self.meta["pitch_cm"])

    def field(self, k: int) -> Lobes:
        """The continuous pressure field of frame ``k`` (for checks and re-rendering)."""
        w = self.meta["weights_n"][k]
        out: Lobes | None = None
        for g, lobes in zip(w, self.meta["group_lobes"]):
            part = lobes.scaled(float(g))
            out = part if out is None else out + part
        assert out is not None
        return out

    def cell_cop_cm(self) -> NDArray[np.float64]:
        """CoP of each cell image (SPEC §7), (T, 2) in cm."""
        return cell_cop_cm(self.pressure, self.pitch_cm)

    def cell_force_n(self) -> NDArray[np.float64]:
        """Force seen by the mat, ``Σ p · cell area``, (T,) in N."""
        return cell_force_n(self.pressure, self.pitch_cm)


def _mat_centre(shape: tuple[int, int], pitch: float) -> NDArray[np.float64]:
    r, c = shape
    return np.array([(c - 1) / 2.0 * pitch, (r - 1) / 2.0 * pitch])


def _convex_hull(points: NDArray[np.float64]) -> NDArray[np.float64]:
    """Vertices of the convex hull of 2-D points (V, 2), counter-clockwise (Qhull orders 2-D hulls so).

    Raises
    ------
    ValueError
        If the points span no area (fewer than 3 distinct points, or all collinear).
    """
    try:
        return points[ConvexHull(points).vertices]
    except QhullError:
        raise ValueError("the load groups' centroids are collinear: the CoP cannot be steered in 2-D") from None


def _project_to_polygon(p: NDArray[np.float64], hull: NDArray[np.float64]) -> NDArray[np.float64]:
    """Nearest points of a convex CCW polygon (incl. its inside) to points p (T, 2)."""
    a = hull
    b = np.roll(hull, -1, axis=0)
    e = b - a  # (V, 2)
    d = p[:, None, :] - a[None, :, :]  # (T, V, 2)
    inside = np.all(e[None, :, 0] * d[..., 1] - e[None, :, 1] * d[..., 0] >= 0.0, axis=1)
    s = np.clip((d * e[None]).sum(-1) / (e * e).sum(-1)[None], 0.0, 1.0)
    q = a[None] + s[..., None] * e[None]  # (T, V, 2)
    dist = np.linalg.norm(p[:, None, :] - q, axis=-1)
    best = q[np.arange(p.shape[0]), np.argmin(dist, axis=1)]
    return np.where(inside[:, None], p, best)


def _solve_group_fractions(
    centroids: NDArray[np.float64],
    nominal: NDArray[np.float64],
    target: NDArray[np.float64],
    lo: float,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Group load fractions f (T, G) with Σf = 1, Σ f·c = CoP and f >= lo.

    Minimises ``||f − nominal||²`` (a convex QP in G variables: the optimum is the
    equality-constrained solution of one active set; all 2^G sets are tried, vectorised
    over T). Targets outside the reachable polygon are first moved to its nearest point.
    Returns ``(f, reached_cop)``.
    """
    g = centroids.shape[0]
    if g * lo > 1.0:
        raise ValueError(f"min_fraction={lo} is too large for {g} groups (needs <= {1.0 / g:.3g})")
    shrunk = lo * centroids.sum(axis=0) + (1.0 - g * lo) * centroids
    hull = _convex_hull(shrunk)
    reach = _project_to_polygon(target, hull)
    moved = np.any(reach != target, axis=1)
    if np.any(moved):  # a hair inside, so that round-off keeps the QP feasible
        centre = hull.mean(axis=0)
        reach[moved] += 1e-10 * (centre - reach[moved])
    a = np.vstack([np.ones(g), centroids.T])  # (3, G)
    b = np.column_stack([np.ones(target.shape[0]), reach])  # (T, 3)
    tol = 1e-9 * (1.0 + np.abs(centroids).max())
    best_f = np.full((target.shape[0], g), np.nan)
    best_obj = np.full(target.shape[0], np.inf)
    for n_fixed in range(g):
        for fixed in itertools.combinations(range(g), n_fixed):
            free = [k for k in range(g) if k not in fixed]
            a_s = a[:, free]
            rhs = b - lo * a[:, list(fixed)].sum(axis=1)[None, :] - nominal[free] @ a_s.T
            y = rhs @ np.linalg.pinv(a_s).T  # min-norm (least-squares) deviation
            f = np.full((target.shape[0], g), lo)
            f[:, free] = nominal[free] + y
            resid = np.abs(f @ a.T - b).max(axis=1)
            ok = (resid <= tol) & np.all(f >= lo - tol, axis=1)
            obj = ((f - nominal) ** 2).sum(axis=1)
            take = ok & (obj < best_obj)
            best_f[take] = f[take]
            best_obj[take] = obj[take]
    if not np.all(np.isfinite(best_obj)):  # pragma: no cover - guarded by the projection
        raise RuntimeError("internal error: no feasible load distribution for a reachable CoP")
    return np.clip(best_f, lo, None), reach


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
    """Solve the group loads for each frame and build the scene."""
    names = [n for n, _ in groups]
    lobes = [l for _, l in groups]
    centroids = np.array([l.cop_cm for l in lobes])
    f0 = np.asarray(nominal, dtype=np.float64)
    f0 = f0 / f0.sum()
    frac, reached = _solve_group_fractions(centroids, f0, target_cm, min_fraction)
    weights = frac * force_n[:, None]  # (T, G) N
    cop_true = (weights @ centroids) / weights.sum(axis=1, keepdims=True)
    basis = np.stack([cell_pressure_psi(l, shape, pitch, supersample) for l in lobes])  # psi per N
    r, c = shape
    pressure = (weights @ basis.reshape(len(lobes), r * c)).reshape(-1, r, c)
    np.clip(pressure, 0.0, None, out=pressure)
    clip_cm = np.linalg.norm(reached - target_cm, axis=1)
    clipped = clip_cm > 1e-8
    seen = cell_force_n(basis, pitch)  # share of each unit group the mat's area sees
    meta: dict[str, Any] = {
        "scene": scene,
        "shape": shape,
        "pitch_cm": pitch,
        "supersample": supersample,
        "groups": names,
        "group_lobes": lobes,
        "nominal_fractions": f0,
        "min_fraction": min_fraction,
        "weights_n": weights,
        "cop_target_cm": target_cm,
        "clipped": clipped,
        "n_clipped": int(clipped.sum()),
        "clip_cm": np.where(clipped, clip_cm, 0.0),
        "force_on_mat_fraction": (frac @ seen),
        "mat_centre_cm": _mat_centre(shape, pitch),
    }
    meta.update(extra)
    return PressureScene(pressure=pressure, t=t, cop_true_cm=cop_true, force_n=force_n.copy(), meta=meta)


def _two_feet_groups(
    shape: tuple[int, int],
    pitch: float,
    length: float,
    width: float,
    stance: float,
    toe: float,
    nominal: NDArray[np.float64],
) -> list[tuple[str, Lobes]]:
    """Left/right rearfoot/forefoot groups, placed so the nominal CoP is at the mat centre."""
    centre = _mat_centre(shape, pitch)
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


def _band_noise(n: int, rate_hz: float, band_hz: tuple[float, float], rng: np.random.Generator) -> NDArray[np.float64]:
    """Unit-SD Gaussian noise with its power in band_hz (FFT mask); zeros if the band is empty."""
    if n < 2:
        return np.zeros(n)
    spec = rng.standard_normal(n // 2 + 1) + 1j * rng.standard_normal(n // 2 + 1)
    f = np.fft.rfftfreq(n, 1.0 / rate_hz)
    spec[(f < band_hz[0]) | (f > band_hz[1])] = 0.0
    x = np.fft.irfft(spec, n)
    sd = x.std()
    return x / sd if sd > 0 else np.zeros(n)


def _time_base(duration_s: Any, rate_hz: Any) -> tuple[NDArray[np.float64], float]:
    duration = _positive("duration_s", duration_s)
    rate = _positive("rate_hz", rate_hz)
    n = int(math.floor(duration * rate + 1e-9))
    if n < 1:
        raise ValueError(f"duration_s={duration_s!r} at rate_hz={rate_hz!r} gives no frame")
    return np.arange(n) / rate, rate


def _band(band_hz: Any) -> tuple[float, float]:
    lo, hi = _pair("band_hz", band_hz)
    if not 0 <= lo < hi:
        raise ValueError(f"band_hz must be (low, high) with 0 <= low < high in Hz, got {band_hz!r}")
    return lo, hi


def _sway(n: int, rate: float, sway_cm: tuple[float, float], band: tuple[float, float], rng: np.random.Generator) -> NDArray[np.float64]:
    return np.column_stack(
        [sway_cm[0] * _band_noise(n, rate, band, rng), sway_cm[1] * _band_noise(n, rate, band, rng)]
    )



def _mat_args(shape: Any, pitch_cm: Any, min_fraction: Any, supersample: Any) -> tuple[tuple[int, int], float, float, int]:
    """Checked ``(shape, pitch, min_fraction, supersample)`` shared by every scene generator."""
    return (
        _shape2(shape),
        _positive("pitch_cm", pitch_cm),
        _fraction("min_fraction", min_fraction, 0.0, 0.25),
        _supersample(supersample),
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
        return _mat_centre(self.shape, self.pitch)

    def rng(self) -> np.random.Generator:
        """A fresh generator seeded with ``seed``."""
        return np.random.default_rng(self.seed)

    def sway_noise(self, rng: np.random.Generator) -> NDArray[np.float64]:
        """Band-limited sway (T, 2) in cm with SDs ``sway`` (M-L, A-P), drawn from ``rng``."""
        return _sway(self.t.size, self.rate, self.sway, self.band, rng)

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


def _scene_args(
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
    weight = _positive("weight_n", weight_n)
    seed_ = _seed(seed)
    t, rate = _time_base(duration_s, rate_hz)
    return _SceneArgs(shape_, pitch, weight, seed_, t, rate, _pair("sway_cm", sway_cm), _band(band_hz), lo, s)


def _two_feet_args(
    shape: tuple[int, int],
    pitch: float,
    foot_length_cm: Any,
    foot_width_cm: Any,
    stance_cm: Any,
    toe_out_deg: Any,
    heel_fraction: Any,
) -> tuple[list[tuple[str, Lobes]], NDArray[np.float64], dict[str, Any]]:
    """Checked two-feet stance: ``(groups, nominal fractions, meta)`` (see :func:`_two_feet_groups`)."""
    length, width, toe = _check_foot_size(foot_length_cm, foot_width_cm, toe_out_deg)
    stance = _positive("stance_cm", stance_cm)
    h = _fraction("heel_fraction", heel_fraction)
    nominal = np.array([h, 1.0 - h, h, 1.0 - h]) / 2.0
    groups = _two_feet_groups(shape, pitch, length, width, stance, toe, nominal)
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
    a = _scene_args(duration_s, rate_hz, shape, pitch_cm, weight_n, seed, sway_cm, band_hz, min_fraction, supersample)
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
    a = _scene_args(duration_s, rate_hz, shape, pitch_cm, weight_n, seed, sway_cm, band_hz, min_fraction, supersample)
    side = _check_side(side)
    length, width, _ = _check_foot_size(foot_length_cm, foot_width_cm, 0.0)
    h = _fraction("heel_fraction", heel_fraction)
    centre = a.centre
    parts = [
        ("rear_medial", _REAR_MEDIAL),
        ("rear_lateral", _REAR_LATERAL),
        ("fore_medial", _FORE_MEDIAL),
        ("fore_lateral", _FORE_LATERAL),
    ]
    lobes = [_foot_part_lobes(p, centre[0], centre[1], side, length, width, 0.0) for _, p in parts]
    nominal = np.array([h, h, 1.0 - h, 1.0 - h]) / 2.0
    cop0 = (nominal[:, None] * np.array([l.cop_cm for l in lobes])).sum(axis=0)
    lobes = [l.shifted(*(centre - cop0)) for l in lobes]
    groups = [(n, l) for (n, _), l in zip(parts, lobes)]
    target = centre + a.sway_noise(a.rng())
    return a.render(
        "single_leg_sway", groups, nominal, target,
        {"side": side, "foot_length_cm": length, "foot_width_cm": width},
    )


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
    ``centre=True`` its mean is moved to the mat centre (``meta["offset_cm"]`` is the shift
    added to the input), otherwise the input is taken as the displacement from the mat
    centre. M-L maps to ``x`` (positive = the subject's right), A-P to ``y`` (positive =
    anterior, towards the toes). Two feet stay in place (as :func:`quiet_standing`); the
    load moves between the feet and between heel and forefoot so that the field's CoP
    equals the target exactly, and the total force equals ``fz``. Targets out of the feet's
    reach are moved to the nearest reachable point: ``meta["clipped"]``, ``meta["clip_cm"]``.

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
        Centre the trajectory's mean on the mat (default) or use it as offsets from the centre.
    foot_length_cm, foot_width_cm, stance_cm, toe_out_deg, heel_fraction, min_fraction, supersample
        As :func:`quiet_standing`.

    Returns
    -------
    PressureScene
    """
    tt = _vector("t", t)
    ml = _vector("cop_ml_cm", cop_ml_cm)
    ap = _vector("cop_ap_cm", cop_ap_cm)
    try:
        fz = np.asarray(fz_n, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError("fz_n must be a number or a 1-D array of numbers (N)") from None
    if fz.ndim == 0:
        fz = np.full(tt.shape, float(fz))
    fz = _vector("fz_n", fz)
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
    rate = _positive("rate_hz", rate_hz)
    shape, pitch, lo, s = _mat_args(shape, pitch_cm, min_fraction, supersample)
    groups, nominal, feet = _two_feet_args(
        shape, pitch, foot_length_cm, foot_width_cm, stance_cm, toe_out_deg, heel_fraction
    )

    n = int(math.floor((tt[-1] - tt[0]) * rate + 1e-9)) + 1
    t_out = tt[0] + np.arange(n) / rate
    t_out = np.minimum(t_out, tt[-1])
    ml_o, ap_o, fz_o = (np.interp(t_out, tt, v) for v in (ml, ap, fz))
    mid = _mat_centre(shape, pitch)
    offset = mid - (np.array([ml.mean(), ap.mean()]) if centre else 0.0)
    target = np.column_stack([ml_o, ap_o]) + offset
    return _render(
        "trajectory_sway", groups, nominal, t_out, target, fz_o, shape, pitch, s, lo,
        {"rate_hz": rate, "seed": None, "offset_cm": offset, "input_rate_hz": float((tt.size - 1) / (tt[-1] - tt[0])),
         **feet},
    )


def sitting(
    duration_s: float,
    rate_hz: float,
    shape: tuple[int, int] = (16, 16),
    pitch_cm: float = 2.0,
    weight_n: float = 700.0,
    seed: int = 0,
    *,
    seat_fraction: float = 0.75,
    lean_cm: tuple[float, float] = (1.0, 1.5),
    lean_period_s: float = 20.0,
    sway_cm: tuple[float, float] = (0.05, 0.05),
    band_hz: tuple[float, float] = (0.1, 0.5),
    tuberosity_distance_cm: float = 12.0,
    min_fraction: float = 0.02,
    supersample: int = 5,
) -> PressureScene:
    """A person sitting on the mat (the meditation cushion, SPEC §8), leaning slowly.

    Two ischial tuberosities (a sharp lobe each inside a broad buttock lobe) at
    ``y = centre − 4 cm`` and the thighs extending towards ``+y``, symmetric about the mat's
    vertical midline. The seat carries ``seat_fraction · weight_n``. The CoP leans
    sinusoidally with amplitudes ``lean_cm`` (M-L, A-P) and period ``lean_period_s`` (random
    phases from ``seed``) plus a little band-limited sway ``sway_cm``; the load moves between
    the left/right tuberosities and thighs.

    Parameters
    ----------
    duration_s, rate_hz, shape, pitch_cm, weight_n, seed
        As :func:`quiet_standing` (s, Hz, cells, cm, N, -).
    seat_fraction : float
        Share of the body weight on the seat, in (0, 1].
    lean_cm : (float, float)
        Amplitude of the lean, (M-L, A-P) in cm; (0, 0) with ``sway_cm=(0, 0)`` is still
        and symmetric.
    lean_period_s : float
        Period of the lean in s.
    sway_cm : (float, float)
        Standard deviation of the extra sway in cm.
    band_hz : (float, float)
        Band of the extra sway in Hz.
    tuberosity_distance_cm : float
        Distance between the ischial tuberosities in cm.
    min_fraction, supersample
        As :func:`quiet_standing`.

    Returns
    -------
    PressureScene
    """
    a = _scene_args(duration_s, rate_hz, shape, pitch_cm, weight_n, seed, sway_cm, band_hz, min_fraction, supersample)
    frac = _fraction("seat_fraction", seat_fraction)
    if frac == 0:
        raise ValueError("seat_fraction must be > 0")
    lean = _pair("lean_cm", lean_cm)
    period = _positive("lean_period_s", lean_period_s)
    dist = _positive("tuberosity_distance_cm", tuberosity_distance_cm)
    t = a.t
    c = a.centre
    xl = c[0] - dist / 2.0
    y_it = c[1] - 4.0
    # Left ischial tuberosity: sharp bony lobe (60 %) in a broad buttock lobe (40 %).
    left_it = Lobes([[xl, y_it], [xl - 0.5, y_it + 0.5]], [[3.0, 3.0], [7.0, 6.5]], [0.0, 0.0], [0.6, 0.4])
    # Left thigh: an elongated lobe along +y, turned a little outwards.
    thigh_angle = math.pi / 2 + math.radians(8.0)
    left_thigh = Lobes([[xl - 1.5, c[1] + 6.5]], [[8.0, 4.5]], [thigh_angle], [1.0])
    groups = [
        ("left_ischial", left_it),
        ("left_thigh", left_thigh),
        ("right_ischial", left_it.mirrored(c[0])),
        ("right_thigh", left_thigh.mirrored(c[0])),
    ]
    nominal = np.array([0.32, 0.18, 0.32, 0.18])
    cop0 = (nominal[:, None] * np.array([l.cop_cm for _, l in groups])).sum(axis=0)
    rng = a.rng()
    phase = rng.uniform(0.0, 2.0 * np.pi, size=2)
    w = 2.0 * np.pi / period
    target = cop0 + np.column_stack(
        [lean[0] * np.sin(w * t + phase[0]), lean[1] * np.sin(w * t + phase[1])]
    ) + a.sway_noise(rng)
    return a.render(
        "sitting", groups, nominal, target,
        {"seat_fraction": frac, "lean_cm": lean, "lean_period_s": period, "lean_phase_rad": phase,
         "tuberosity_distance_cm": dist},
        load_n=frac * a.weight,
    )

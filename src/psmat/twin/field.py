"""The continuous pressure field on the mat and its cell image (docs/spec.md §5, §7).

Units and conventions
---------------------
* Pressure in **psi** inside the twin (the sensor model's unit, docs/spec.md §1; 1 psi = 6894.757 Pa),
  forces in **N**, lengths and positions in **cm**.
* Mat of ``R × C`` cells at ``pitch_cm``; the origin is the centre of cell ``(0, 0)``; cell
  ``(i, p)`` has its centre at ``x = p·pitch`` (medial–lateral, along the columns) and
  ``y = i·pitch`` (anterior–posterior, along the rows) — the convention of
  :func:`psmat.balance.cop` (:func:`psmat.balance.cell_centres_cm`), which gives the CoP of a
  cell image. A person stands facing ``+y`` (toes towards larger ``y``), so
  their right is ``+x``. The mat's centre is ``((C − 1)/2·pitch, (R − 1)/2·pitch)``.
* The thesis' mat is 32 cm square: :func:`mat_pitch_cm` gives the pitch that keeps it for
  any cell count (2 / 1 / 0.5 cm for 16 / 32 / 64 cells).

The field
---------
A load is a sum of smooth elliptical **lobes**: lobe ``k`` carries the force ``F_k`` (N)
with the pressure

    q_k(x, y) = F_k · (1 − d²)₊³ / (π a b / 4),   d² = (u/a)² + (v/b)²

(``u, v`` the coordinates along / across the lobe's axes, ``a, b`` its semi-axes in cm).
It is twice continuously differentiable, zero outside the ellipse, integrates to exactly
``F_k`` and has its centre of pressure exactly at the lobe centre, so a field's total force
and CoP are known in closed form (:class:`Lobes`).

The cell image is the field averaged over each cell's area (``supersample × supersample``
points per cell, 5 × 5 by default), so a continuously moving field gives a continuously
changing image and cell CoP. A cell's force is its pressure times its area (4 cm² at 2 cm
pitch).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._checks import finite, positive, positive_int, shape2
from ..units import PSI_PA  # one psi in Pa; one home for the constant

__all__ = [
    "PSI_PA",
    "MAT_SIZE_CM",
    "Lobes",
    "mat_pitch_cm",
    "mat_centre_cm",
    "cell_pressure_psi",
    "cell_force_n",
]

MAT_SIZE_CM = 32.0
"""Side of the thesis' mat in cm (16 × 16 cells at 2 cm)."""

_N_PER_CM2_TO_PSI = 1.0e4 / PSI_PA  # 1 N/cm² = 1e4 Pa
_BUMP_EXPONENT = 3
_BUMP_INTEGRAL = math.pi / (_BUMP_EXPONENT + 1)  # ∫∫ (1 - r²)₊³ over the unit disk


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
        factor = finite("factor", factor)
        if factor < 0:
            raise ValueError(f"factor must be >= 0, got {factor!r}")
        return Lobes(self.centre_cm, self.semi_axes_cm, self.angle_rad, self.force_n * factor)

    def with_total(self, force_n: float) -> "Lobes":
        """The same shape scaled so that the total force is ``force_n`` (N, >= 0)."""
        force_n = finite("force_n", force_n)
        if force_n < 0:
            raise ValueError(f"force_n must be >= 0, got {force_n!r}")
        tot = self.total_force_n
        if not tot > 0:
            raise ValueError("cannot rescale a field that carries no load")
        return self.scaled(force_n / tot)

    def shifted(self, dx_cm: float, dy_cm: float) -> "Lobes":
        """The field translated by (dx, dy) cm."""
        d = np.array([finite("dx_cm", dx_cm), finite("dy_cm", dy_cm)])
        return Lobes(self.centre_cm + d, self.semi_axes_cm, self.angle_rad, self.force_n)

    def mirrored(self, x0_cm: float) -> "Lobes":
        """Mirror image about the line ``x = x0_cm`` (left foot ↔ right foot)."""
        x0 = finite("x0_cm", x0_cm)
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
    r, c = shape2(shape)
    pitch = positive("pitch_cm", pitch_cm)
    s = positive_int("supersample", supersample)
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
    area_m2 = (positive("pitch_cm", pitch_cm) * 1e-2) ** 2
    return p.sum(axis=(-2, -1)) * PSI_PA * area_m2


def mat_pitch_cm(shape: tuple[int, int]) -> float:
    """Cell pitch in cm that keeps the thesis' 32 cm mat: ``32 / max(R, C)``.

    Parameters
    ----------
    shape : (R, C)
        Mat size in cells.

    Returns
    -------
    float
        Pitch in cm (2 for 16 × 16, 1 for 32 × 32, 0.5 for 64 × 64).
    """
    r, c = shape2(shape)
    return MAT_SIZE_CM / max(r, c)


def mat_centre_cm(shape: tuple[int, int], pitch_cm: float) -> NDArray[np.float64]:
    """The mat's centre ``((C − 1)/2·pitch, (R − 1)/2·pitch)`` in cm (cell ``(0, 0)`` at the origin)."""
    r, c = shape
    return np.array([(c - 1) / 2.0 * pitch_cm, (r - 1) / 2.0 * pitch_cm])

"""The seat's load (docs/spec.md §8 "Data"): how the groups of :func:`~psmat.twin.anatomy.seat_groups` share it.

The seat's frame has ``u`` to the person's right and ``w`` forward, its origin midway between
the ischial tuberosities (:func:`~psmat.twin.anatomy.seat_groups`). For every frame the caller
gives the seat's total force (N), where its centre of pressure must be (``u``, ``w``, cm: a
moment balance, :mod:`psmat.twin.seated._body`) and where the pelvis touches (the tuberosities'
rolling contact, cm along ``w``). The load is shared so that

* **A-P**: three rows — the tuberosities at the contact point, the thighs, the sacrum — carry
  shares ``f`` with ``Σ f = 1`` and ``Σ f·w = w_cop``; of those, the one nearest the person's
  upright shares ``f0`` (ischial ``1 − t0``, thighs ``t0``, sacrum 0) is taken, no share below
  zero (the least-norm deviation from ``f0`` along the line of solutions; a row driven below
  zero is unloaded and the other two carry the moment exactly). Leaning forward thus loads the
  thighs and unloads the sacrum; leaning back loads the sacrum and unloads the thighs.
  Targets outside the rows' reach are moved inside it and reported.
* **Contact**: the tuberosities' share is split between their forward- and backward-rolled
  lobes so that the ischial centroid is at the contact point.
* **M-L**: each left/right pair is split so that its own CoP is at ``u_cop / (1 − f_sacrum)``
  (the sacrum is on the midline), so the field's CoP is the target; each side keeps at least
  ``min_fraction`` of its pair.

Positions in cm, forces in N, pressures in psi (:mod:`psmat.twin.field`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..anatomy import SEAT_GROUPS, seat_groups
from ..field import Lobes, cell_force_n, cell_pressure_psi

__all__ = ["SeatLayout", "SeatLoad", "seat_layout", "share_load", "render_seat"]

# Column of each row's groups in SEAT_GROUPS: ischial front (L, R), ischial rear (L, R), thighs (L, R), sacrum.
_IT_FRONT = (0, 2)
_IT_REAR = (1, 3)
_THIGH = (4, 5)
_SACRUM = 6


@dataclass(frozen=True)
class SeatLayout:
    """A seat placed on the mat: its unit-force groups in mat coordinates and in its own frame.

    Attributes
    ----------
    groups : list of (name, Lobes)
        Mat coordinates (cm), :data:`~psmat.twin.anatomy.SEAT_GROUPS` order.
    local_cm : ndarray, (7, 2)
        Each group's centroid in the seat frame (u, w), cm.
    origin_cm : ndarray, (2,)
        Where the seat's origin is on the mat (x, y), cm.
    rotation_deg : float
        The seat frame's turn on the mat, counter-clockwise, degrees.
    roll_cm : float
        How far the ischial lobes are rolled forward and back, cm.
    """

    groups: list[tuple[str, Lobes]]
    local_cm: NDArray[np.float64]
    origin_cm: NDArray[np.float64]
    rotation_deg: float
    roll_cm: float

    def to_mat(self, uw: NDArray[np.float64]) -> NDArray[np.float64]:
        """Seat-frame points (..., 2) (u, w) cm to mat coordinates (x, y) cm."""
        r = np.radians(self.rotation_deg)
        c, s = np.cos(r), np.sin(r)
        return np.stack([uw[..., 0] * c - uw[..., 1] * s, uw[..., 0] * s + uw[..., 1] * c], axis=-1) + self.origin_cm

    def to_seat(self, xy: NDArray[np.float64]) -> NDArray[np.float64]:
        """Mat coordinates (..., 2) (x, y) cm to the seat frame (u, w) cm."""
        r = np.radians(self.rotation_deg)
        c, s = np.cos(r), np.sin(r)
        d = xy - self.origin_cm
        return np.stack([d[..., 0] * c + d[..., 1] * s, -d[..., 0] * s + d[..., 1] * c], axis=-1)


def seat_layout(origin_cm: Any, rotation_deg: float, tuberosity_distance_cm: float, **anatomy: float) -> SeatLayout:
    """The seat of :func:`~psmat.twin.anatomy.seat_groups` with its origin at ``origin_cm`` (x, y) on the mat,
    turned by ``rotation_deg``; ``anatomy`` are that function's keyword arguments."""
    origin = np.asarray(origin_cm, dtype=np.float64)
    local = seat_groups(np.zeros(2), tuberosity_distance_cm, **anatomy)
    groups = seat_groups(origin, tuberosity_distance_cm, rotation_deg=rotation_deg, **anatomy)
    return SeatLayout(groups, np.array([l.cop_cm for _, l in local]), origin, float(rotation_deg),
                      float(anatomy.get("roll_cm", 1.5)))


@dataclass
class SeatLoad:
    """The seat's load per frame (:func:`share_load`).

    Attributes
    ----------
    weights_n : ndarray, (T, 7)
        Force of each group, N.
    rows : ndarray, (T, 3)
        Shares of the ischial, thigh and sacral rows (sum 1).
    cop_seat_cm : ndarray, (T, 2)
        The centre of pressure reached, seat frame (u, w), cm.
    clip_cm : ndarray, (T,)
        Distance from the target to the CoP reached, cm (0 when reached).
    """

    weights_n: NDArray[np.float64]
    rows: NDArray[np.float64]
    cop_seat_cm: NDArray[np.float64]
    clip_cm: NDArray[np.float64]


def _row_shares(y: NDArray[np.float64], c: NDArray[np.float64], f0: NDArray[np.float64]) -> NDArray[np.float64]:
    """Row shares (T, 3) with Σf = 1, Σf·y = c, f >= 0, nearest to ``f0`` (see the module docstring)."""
    dy = y - y.mean(axis=1, keepdims=True)
    f = f0 + ((c - y @ f0) / (dy * dy).sum(axis=1))[:, None] * dy
    k = np.argmin(f, axis=1)
    for drop in range(3):  # the row driven furthest below zero is unloaded; the other two balance exactly
        rows = np.flatnonzero((k == drop) & (f[:, drop] < 0.0))
        if rows.size == 0:
            continue
        i, j = [r for r in range(3) if r != drop]
        fj = np.clip((c[rows] - y[rows, i]) / (y[rows, j] - y[rows, i]), 0.0, 1.0)
        f[rows, drop] = 0.0
        f[rows, i] = 1.0 - fj
        f[rows, j] = fj
    return f


def share_load(layout: SeatLayout, force_n: NDArray[np.float64], cop_seat_cm: NDArray[np.float64],
               contact_cm: NDArray[np.float64], thigh_share: float, min_fraction: float = 0.02) -> SeatLoad:
    """Share the seat's force between its groups (see the module docstring).

    Parameters
    ----------
    layout : SeatLayout
    force_n : ndarray, (T,)
        The seat's total force, N (>= 0).
    cop_seat_cm : ndarray, (T, 2)
        Target centre of pressure in the seat frame (u, w), cm.
    contact_cm : ndarray, (T,)
        The tuberosities' contact, cm along ``w`` from their unrolled position (within ±``roll_cm``).
    thigh_share : float
        The thighs' share ``t0`` of the upright shares ``f0``.
    min_fraction : float
        Least share of a left/right pair's load either side keeps.

    Returns
    -------
    SeatLoad
    """
    loc = layout.local_cm
    roll = layout.roll_cm
    front = np.clip(0.5 + np.asarray(contact_cm, dtype=np.float64) / (2.0 * roll), 0.0, 1.0)  # share rolled forward
    w_it = front * loc[_IT_FRONT[0], 1] + (1.0 - front) * loc[_IT_REAR[0], 1]
    w_th, w_sa = loc[_THIGH[0], 1], loc[_SACRUM, 1]
    n = front.size
    y = np.column_stack([w_it, np.full(n, w_th), np.full(n, w_sa)])
    target = np.asarray(cop_seat_cm, dtype=np.float64)
    margin = 0.02 * (w_th - w_sa)
    c = np.clip(target[:, 1], w_sa + margin, w_th - margin)
    rows = _row_shares(y, c, np.array([1.0 - thigh_share, thigh_share, 0.0]))
    # M-L: each pair's CoP at e / (1 - f_sacrum), so that the field's is at e (the sacrum is on the midline)
    e = target[:, 0] / np.maximum(1.0 - rows[:, 2], 1e-9)
    w = np.zeros((n, len(SEAT_GROUPS)))
    for (l_, r_), share in ((_IT_FRONT, rows[:, 0] * front), (_IT_REAR, rows[:, 0] * (1.0 - front)),
                            (_THIGH, rows[:, 1])):
        sep = loc[r_, 0] - loc[l_, 0]
        right = np.clip(0.5 + (e - 0.5 * (loc[r_, 0] + loc[l_, 0])) / sep, min_fraction, 1.0 - min_fraction)
        w[:, l_] = share * (1.0 - right)
        w[:, r_] = share * right
    w[:, _SACRUM] = rows[:, 2]
    reached = w @ loc
    weights = w * np.asarray(force_n, dtype=np.float64)[:, None]
    return SeatLoad(weights, rows, reached, np.linalg.norm(reached - target, axis=1))


def render_seat(layout: SeatLayout, weights_n: NDArray[np.float64], shape: tuple[int, int], pitch_cm: float,
                supersample: int = 5) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Cell images of the seat's groups carrying ``weights_n`` (T, 7) N.

    Returns
    -------
    pressure : ndarray, (T, R, C)
        Cell pressures, psi.
    cop_true_cm : ndarray, (T, 2)
        CoP of the continuous field, mat coordinates (x, y) cm.
    on_mat : ndarray, (T,)
        Share of the load that falls on the mat's area.
    """
    lobes = [l for _, l in layout.groups]
    basis = np.stack([cell_pressure_psi(l, shape, pitch_cm, supersample) for l in lobes])  # psi per N
    r, c = shape
    pressure = (weights_n @ basis.reshape(len(lobes), r * c)).reshape(-1, r, c)
    np.clip(pressure, 0.0, None, out=pressure)
    total = weights_n.sum(axis=1)
    centroids = np.array([l.cop_cm for l in lobes])
    cop = (weights_n @ centroids) / np.where(total > 0, total, np.nan)[:, None]
    on_mat = (weights_n @ cell_force_n(basis, pitch_cm)) / np.where(total > 0, total, np.nan)
    return pressure, cop, on_mat

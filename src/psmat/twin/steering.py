"""Load steering (docs/spec.md §5): the group forces that put a field's CoP on a target.

In the scene generators the feet (or the seat's lobes) stay where they are and the load
moves between **groups** of lobes (e.g. left/right rearfoot/forefoot), as a person swaying
on the spot does. The field's CoP is linear in the group forces, so for each frame the
group forces are solved so that the CoP equals the target exactly; among the solutions the
one closest to the nominal distribution is taken, with every group keeping at least
``min_fraction`` of the load. Targets the groups cannot reach are moved to the nearest
reachable point (the convex hull of the shrunk group centroids) and reported.

:func:`steer` then renders the frames' cell images (psi) from one unit-force image per group.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass
from typing import Any, Sequence

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import ConvexHull, QhullError

from .field import Lobes, cell_force_n, cell_pressure_psi, mat_centre_cm

__all__ = ["Steered", "steer", "convex_hull", "project_to_polygon", "solve_group_fractions"]


def convex_hull(points: NDArray[np.float64]) -> NDArray[np.float64]:
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


def project_to_polygon(p: NDArray[np.float64], hull: NDArray[np.float64]) -> NDArray[np.float64]:
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


def solve_group_fractions(
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
    hull = convex_hull(shrunk)
    reach = project_to_polygon(target, hull)
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


@dataclass
class Steered:
    """Frames rendered by :func:`steer`.

    Attributes
    ----------
    pressure_psi : ndarray, shape (T, R, C)
        Cell pressures in psi (>= 0).
    cop_true_cm : ndarray, shape (T, 2)
        CoP of the continuous field, (x, y) in cm.
    meta : dict
        ``scene``, ``shape``, ``pitch_cm``, ``supersample``, ``groups``, ``group_lobes``,
        ``nominal_fractions``, ``min_fraction``, ``weights_n`` (T, G) N, ``cop_target_cm``,
        ``clipped``, ``n_clipped``, ``clip_cm`` (cm), ``force_on_mat_fraction``,
        ``mat_centre_cm`` and the caller's ``extra``.
    """

    pressure_psi: NDArray[np.float64]
    cop_true_cm: NDArray[np.float64]
    meta: dict[str, Any]


def steer(
    scene: str,
    groups: Sequence[tuple[str, Lobes]],
    nominal: Sequence[float],
    target_cm: NDArray[np.float64],
    force_n: NDArray[np.float64],
    shape: tuple[int, int],
    pitch: float,
    supersample: int,
    min_fraction: float,
    extra: dict[str, Any],
) -> Steered:
    """Solve the group loads for each frame (CoP on ``target_cm``, total ``force_n`` N) and
    render the cell images (psi) of the mat ``shape`` at ``pitch`` cm."""
    names = [n for n, _ in groups]
    lobes = [l for _, l in groups]
    centroids = np.array([l.cop_cm for l in lobes])
    f0 = np.asarray(nominal, dtype=np.float64)
    f0 = f0 / f0.sum()
    frac, reached = solve_group_fractions(centroids, f0, target_cm, min_fraction)
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
        "mat_centre_cm": mat_centre_cm(shape, pitch),
    }
    meta.update(extra)
    return Steered(pressure_psi=pressure, cop_true_cm=cop_true, meta=meta)


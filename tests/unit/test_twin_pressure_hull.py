"""The reachable-CoP polygon of the pressure twin is scipy's convex hull.

Reference: Andrew's monotone chain, written out here as the hand-coded hull the twin used
before; the hull (vertices, counter-clockwise order, area) must be the same.
"""

from __future__ import annotations

import numpy as np
import pytest

from psmat.twin.steering import convex_hull


def monotone_chain(points: np.ndarray) -> np.ndarray:
    """Counter-clockwise convex hull by Andrew's monotone chain, collinear points dropped."""
    pts = sorted(set(map(tuple, points)))

    def cross(o: tuple, a: tuple, b: tuple) -> float:
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])

    lower: list[tuple] = []
    for p in pts:
        while len(lower) >= 2 and cross(lower[-2], lower[-1], p) <= 0:
            lower.pop()
        lower.append(p)
    upper: list[tuple] = []
    for p in reversed(pts):
        while len(upper) >= 2 and cross(upper[-2], upper[-1], p) <= 0:
            upper.pop()
        upper.append(p)
    return np.array(lower[:-1] + upper[:-1])


def signed_area(poly: np.ndarray) -> float:
    """Shoelace formula: > 0 for a counter-clockwise polygon."""
    x, y = poly[:, 0], poly[:, 1]
    return 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))


def _point_sets() -> list[np.ndarray]:
    rng = np.random.default_rng(2024)
    sets = [rng.normal(0.0, 10.0, (int(rng.integers(3, 12)), 2)) for _ in range(100)]
    sq = np.array([[0.0, 0.0], [4.0, 0.0], [4.0, 3.0], [0.0, 3.0]])
    # duplicates, a point inside, points on an edge (collinear with two vertices)
    sets.append(np.vstack([sq, sq[:2], [[2.0, 1.5]], [[2.0, 0.0]], [[4.0, 1.0]]]))
    return sets


def test_hull_equals_monotone_chain():
    for k, pts in enumerate(_point_sets()):
        hull, ref = convex_hull(pts), monotone_chain(pts)
        assert sorted(map(tuple, hull)) == sorted(map(tuple, ref)), k  # the same input points, exactly
        assert signed_area(hull) > 0, k  # counter-clockwise, as the projection onto the polygon needs
        assert signed_area(hull) == pytest.approx(signed_area(ref), rel=1e-12), k


@pytest.mark.parametrize("pts", [np.array([[0.0, 0.0], [1.0, 1.0], [2.0, 2.0], [3.0, 3.0]]),
                                 np.array([[1.0, 2.0], [1.0, 2.0], [5.0, 0.0]])])
def test_collinear_or_too_few_points_is_a_clear_error(pts):
    with pytest.raises(ValueError, match="collinear"):
        convex_hull(pts)

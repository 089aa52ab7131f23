"""psmat.posture.spine_points: thesis eq. 4.4 (chained circular arcs, docs/spec.md §8/§9) checked by
hand geometry and against a literal product of the eq. 4.4 matrices; plot_spine (Fig. 4.8)."""

from __future__ import annotations

import numpy as np
import pytest

import psmat
from psmat.posture import spine_points
from psmat.posture import plot_spine

L = 90.0  # mm between sensors (§4.2)


def eq44_literal(angles: np.ndarray, l: float = L) -> np.ndarray:
    """Sensors 1..5 as the thesis writes it: Δα, C = sign(Δα), R = |l/Δα|, T = Trans·Rot,
    prod_j T_j^{j+1} applied to (0, 0, 1). Valid only for Δα != 0 (it divides by Δα)."""
    out = [np.zeros(2)]
    M = np.eye(3)
    for i in range(4):
        da = angles[i + 1] - angles[i]
        C, R = np.sign(da), abs(l / da)
        trans = np.array([[1, 0, C * R * np.sin(da)], [0, 1, C * R * (1 - np.cos(da))], [0, 0, 1]])
        rot = np.array([[np.cos(da), -np.sin(da), 0], [np.sin(da), np.cos(da), 0], [0, 0, 1]])
        M = M @ trans @ rot
        out.append((M @ np.array([0.0, 0.0, 1.0]))[:2])
    return np.array(out)


STRAIGHT = np.array([[0, 0], [90, 0], [180, 0], [270, 0], [360, 0]], float)


@pytest.mark.parametrize("alpha", [0.0, 0.3, -1.2])
def test_straight_spine_lies_on_u_every_90_mm(alpha):
    np.testing.assert_allclose(spine_points(np.full(5, alpha)), STRAIGHT, atol=1e-12)


@pytest.mark.parametrize("k", [0.2, -0.35, 1.5])
def test_uniform_bend_puts_sensors_on_a_circle_of_radius_l_over_dalpha(k):
    angles = 0.1 + k * np.arange(5)
    pts = spine_points(angles)
    R = L / k
    # by hand: start at the origin heading +u, turn by k per arc of length l -> centre (0, l/k),
    # sensor j at R·(sin jk, 1 - cos jk)
    j = np.arange(5)
    np.testing.assert_allclose(pts, np.c_[R * np.sin(j * k), R * (1 - np.cos(j * k))], atol=1e-9)
    np.testing.assert_allclose(np.hypot(pts[:, 0], pts[:, 1] - R), abs(R), rtol=1e-12)
    # an algebraic least-squares circle through the five points (Kasa fit), not using R
    u, v = pts[:, 0], pts[:, 1]
    A = np.c_[2 * u, 2 * v, np.ones(5)]
    (cu, cv, c), *_ = np.linalg.lstsq(A, u**2 + v**2, rcond=None)
    np.testing.assert_allclose([cu, cv], [0.0, R], atol=1e-8)
    np.testing.assert_allclose(np.sqrt(c + cu**2 + cv**2), abs(R), rtol=1e-10)


def test_matches_the_literal_product_of_eq_4_4_matrices():
    rng = np.random.default_rng(4)
    angles = np.cumsum(rng.uniform(-np.pi / 2, np.pi / 2, size=(50, 5)), axis=1)
    expected = np.array([eq44_literal(a) for a in angles])
    np.testing.assert_allclose(spine_points(angles), expected, atol=1e-9)


def test_dalpha_to_zero_is_continuous_and_smooth():
    base = np.array([0.0, 0.0, 0.2, 0.5, 0.4])
    tiny = base.copy()
    tiny[1] = 1e-9
    assert np.all(np.isfinite(spine_points(base)))
    np.testing.assert_allclose(spine_points(tiny), spine_points(base), atol=1e-6)
    # near 0 (where the literal formula is still well conditioned) both agree
    for eps in (1e-6, 1e-4, 1e-2):
        a = base.copy()
        a[1] = eps
        np.testing.assert_allclose(spine_points(a), eq44_literal(a), atol=1e-8)


def test_chord_between_consecutive_sensors_is_that_of_an_arc_of_length_l():
    angles = np.array([0.05, 0.45, 0.35, -0.6, -0.6])
    d = np.diff(angles)
    chord = np.linalg.norm(np.diff(spine_points(angles), axis=0), axis=1)
    expected = np.where(d == 0, L, 2 * (L / np.where(d == 0, 1, d)) * np.sin(d / 2))
    np.testing.assert_allclose(chord, expected, rtol=1e-12)
    assert chord[3] == pytest.approx(L)


def test_invariances_derived_from_eq_4_4():
    # eq. 4.4 sees only Δα and the product starts in sensor 1's frame: a constant added to
    # every angle leaves the points unchanged (not rotated)
    rng = np.random.default_rng(1)
    a = rng.uniform(-0.5, 0.5, size=(20, 5))
    np.testing.assert_allclose(spine_points(a + 0.7), spine_points(a), atol=1e-9)
    # Rot(-x) = mirror·Rot(x)·mirror and the translation's v is odd in Δα: -α mirrors v
    np.testing.assert_allclose(spine_points(-a), spine_points(a) * [1, -1], atol=1e-9)
    # the translation is proportional to l
    np.testing.assert_allclose(spine_points(a, spacing_mm=45.0), spine_points(a) / 2, atol=1e-9)


def test_shapes_single_frame_and_vectorised_over_time():
    rng = np.random.default_rng(2)
    a = rng.uniform(-1, 1, size=(200, 5))
    out = spine_points(a)
    assert out.shape == (200, 5, 2)
    one = spine_points(a[17])
    assert one.shape == (5, 2)
    np.testing.assert_allclose(out[17], one, atol=0)
    np.testing.assert_allclose(out[17], eq44_literal(a[17]), atol=1e-9)
    assert spine_points(np.zeros((0, 5))).shape == (0, 5, 2)
    assert spine_points([0, 0, 0, 0, 0]).dtype == np.float64
    assert psmat.posture.spine_points is spine_points


@pytest.mark.parametrize("bad, exc, match", [
    (np.zeros(4), ValueError, r"shape \(5,\) or \(T, 5\)"),
    (np.zeros((3, 6)), ValueError, r"shape \(5,\) or \(T, 5\)"),
    (np.zeros((2, 3, 5)), ValueError, r"shape \(5,\) or \(T, 5\)"),
    (np.zeros(()), ValueError, r"shape \(5,\) or \(T, 5\)"),
    ([0, 0, np.nan, 0, 0], ValueError, "non-finite"),
    ([[0, 0, 0, 0, 0], [0, np.inf, 0, 0, 0]], ValueError, r"non-finite value\(s\), first at \(1, 1\)"),
    (["a"] * 5, TypeError, "real numeric array"),
    (np.zeros(5, bool), TypeError, "real numeric array"),
])
def test_bad_angles_one_line_errors(bad, exc, match):
    with pytest.raises(exc, match=match) as e:
        spine_points(bad)
    assert "\n" not in str(e.value)


@pytest.mark.parametrize("spacing, exc", [(0.0, ValueError), (-90.0, ValueError), (np.nan, ValueError),
                                          (np.inf, ValueError), ("90", TypeError)])
def test_bad_spacing(spacing, exc):
    with pytest.raises(exc, match="spacing_mm"):
        spine_points(np.zeros(5), spacing_mm=spacing)


def test_plot_spine_returns_figure_and_writes_png(tmp_path):
    from matplotlib.figure import Figure

    t = np.arange(100) / 10.0
    angles = np.outer(np.sin(t), [0.0, 0.1, 0.2, 0.3, 0.35])
    path = tmp_path / "spine.png"
    fig = plot_spine(spine_points(angles), t, every=10, path=path)
    assert isinstance(fig, Figure)
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    ax = fig.axes[0]
    assert len(ax.lines) == 11  # frames 0, 10, ..., 90 (ten) and the last one, 99
    assert ax.get_xlabel() == "v (mm)"
    assert isinstance(plot_spine(spine_points(np.zeros(5))), Figure)


@pytest.mark.parametrize("kwargs, match", [({"t": np.arange(3.0)}, "t must have shape"),
                                           ({"every": 0}, "every must be"), ({"every": 2.5}, "every must be")])
def test_plot_spine_bad_arguments(kwargs, match):
    with pytest.raises(ValueError, match=match):
        plot_spine(spine_points(np.zeros((4, 5))), **kwargs)

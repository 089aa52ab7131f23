"""A recorded trajectory on one foot (single-leg stance, thesis §3.2.1 "flamingo posture"):
``twin.trajectory_sway(stance="right" | "left")`` loads only that foot's cells, follows the
trajectory within the foot's reach, and mirrors the other foot exactly."""

from __future__ import annotations

import numpy as np
import pytest

from psmat import twin
from psmat.balance import cop

RATE = 50.0


def _circle(radius_ml: float, radius_ap: float, n: int = 100) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Times (s) and a CoP ellipse (cm) traced at 0.5 Hz, as offsets from the stance's nominal CoP."""
    t = np.arange(n) / RATE
    th = 2.0 * np.pi * 0.5 * t
    return t, radius_ml * np.cos(th), radius_ap * np.sin(th)


def _loaded_columns(scene: twin.PressureScene) -> np.ndarray:
    """Columns that carry more than 1 % of the most loaded column's mean pressure."""
    col = scene.pressure_psi.mean(axis=0).sum(axis=0)
    return np.flatnonzero(col > 0.01 * col.max())


def test_one_foot_loads_a_foot_wide_strip_two_feet_two_strips() -> None:
    t, ml, ap = _circle(0.5, 0.8)
    width = 9.0  # cm, the foot
    one = twin.trajectory_sway(t, ml, ap, 700.0, RATE, stance="right", centre=False, foot_width_cm=width)
    two = twin.trajectory_sway(t, ml, ap, 700.0, RATE, stance="two", centre=False, foot_width_cm=width)
    c1, c2 = _loaded_columns(one), _loaded_columns(two)
    # one foot: one contiguous strip no wider than the foot plus a cell on each side (2 cm pitch)
    assert np.all(np.diff(c1) == 1)
    assert (c1[-1] - c1[0] + 1) * 2.0 <= width + 2 * 2.0
    # two feet 15 cm apart: two strips with unloaded columns between them
    assert np.any(np.diff(c2) > 1)
    assert (c2[-1] - c2[0] + 1) * 2.0 >= 15.0 + width - 2 * 2.0
    # the mat sees the whole load on one foot too (eq.: sum p·A = Fz)
    np.testing.assert_allclose(one.cell_force_n(), 700.0, rtol=1e-3)


def test_one_foot_follows_the_trajectory_exactly_within_reach() -> None:
    t, ml, ap = _circle(0.5, 0.8)
    scene = twin.trajectory_sway(t, ml, ap, 700.0, RATE, stance="left", centre=False)
    target = scene.meta["position_cm"] + np.column_stack([ml, ap])
    assert scene.meta["n_clipped"] == 0
    np.testing.assert_allclose(scene.cop_true_cm, target, atol=1e-9)
    # the cell image's CoP agrees to a fraction of a millimetre (quadrature of the field)
    np.testing.assert_allclose(cop(scene.pressure_psi, scene.pitch_cm), target, atol=0.05)


def test_one_foot_cannot_reach_as_far_sideways_as_two() -> None:
    t = np.arange(20) / RATE
    lateral = np.full(t.size, 3.0)  # cm towards the subject's right
    still = np.zeros(t.size)
    two = twin.trajectory_sway(t, lateral, still, 700.0, RATE, stance="two", centre=False)
    one = twin.trajectory_sway(t, lateral, still, 700.0, RATE, stance="right", centre=False, foot_width_cm=9.0)
    assert two.meta["n_clipped"] == 0
    assert one.meta["n_clipped"] == t.size
    # the single foot's CoP stays inside the foot: within half its width of the nominal CoP
    reached = one.cop_true_cm[:, 0] - one.meta["position_cm"][0]
    assert np.all((reached > 0) & (reached < 4.5))


def test_right_foot_is_the_mirror_image_of_the_left() -> None:
    t, ml, ap = _circle(0.4, 0.6)
    right = twin.trajectory_sway(t, ml, ap, 650.0, RATE, stance="right", centre=False)
    left = twin.trajectory_sway(t, -ml, ap, 650.0, RATE, stance="left", centre=False)
    # the mat centre (15 cm) lies between columns 7 and 8: reversing the columns mirrors x
    np.testing.assert_allclose(right.pressure_psi[:, :, ::-1], left.pressure_psi, rtol=1e-9, atol=1e-12)


def test_position_moves_the_foot_by_whole_cells() -> None:
    t, ml, ap = _circle(0.3, 0.5, n=20)
    here = twin.trajectory_sway(t, ml, ap, 700.0, RATE, stance="right", centre=False)
    moved = twin.trajectory_sway(t, ml, ap, 700.0, RATE, stance="right", centre=False, position_cm=(13.0, 17.0))
    # 2 cm = one cell: one column to the left, one row up (cell (i, p) at (2p, 2i) cm)
    np.testing.assert_allclose(moved.pressure_psi[:, 1:, :-1], here.pressure_psi[:, :-1, 1:], rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(moved.cop_true_cm - here.cop_true_cm, np.tile([-2.0, 2.0], (t.size, 1)), atol=1e-9)


@pytest.mark.parametrize("kwargs, match", [
    ({"stance": "both"}, "stance must be one of"),
    ({"stance": "right", "position_cm": (1.0, np.nan)}, "position_cm"),
])
def test_bad_stance_arguments_are_one_clear_error(kwargs, match) -> None:
    t, ml, ap = _circle(0.3, 0.5, n=10)
    with pytest.raises(ValueError, match=match):
        twin.trajectory_sway(t, ml, ap, 700.0, RATE, **kwargs)

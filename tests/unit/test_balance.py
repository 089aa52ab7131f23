"""Centre of pressure and Eu (docs/spec.md §7, eq. 3.1) against values worked out by hand."""

from __future__ import annotations

import numpy as np
import pytest

from psmat.balance import cop, eu


def test_one_loaded_cell_is_its_centre():
    p = np.zeros((5, 7))
    p[3, 2] = 10.0
    np.testing.assert_allclose(cop(p, pitch_cm=2.0), [2 * 2.0, 3 * 2.0])  # x along columns, y along rows


def test_two_cells_weigh_by_pressure_and_frames_stack():
    p = np.zeros((2, 4, 4))
    p[0, 0, 0], p[0, 0, 3] = 1.0, 3.0  # x = (0·1 + 3·3)/4 cells = 2.25 cells
    p[1, 1:3, 1:3] = 5.0  # symmetric block: its middle
    out = cop(p, pitch_cm=2.0)
    np.testing.assert_allclose(out, [[4.5, 0.0], [3.0, 3.0]])


def test_missing_and_empty_frames():
    p = np.ones((3, 3))
    p[0, 0] = np.nan  # a missing reading is left out of both sums
    xs = np.array([1, 2, 0, 1, 2, 0, 1, 2], float)
    ys = np.array([0, 0, 1, 1, 1, 2, 2, 2], float)
    np.testing.assert_allclose(cop(p, 1.0), [xs.mean(), ys.mean()])
    assert np.all(np.isnan(cop(np.zeros((4, 4)))))
    with pytest.raises(ValueError, match=">= 0"):
        cop(-np.ones((2, 2)))
    with pytest.raises(ValueError, match="R, C"):
        cop(np.ones(4))


def test_a_missing_reading_in_one_frame_of_a_stack_leaves_the_others_alone():
    """NaN and inf are missing readings, left out of both sums of their own frame only; a negative
    reading behind a NaN (which hides it from a minimum) is still refused, with its index."""
    p = np.zeros((3, 2, 2))
    p[:, 0, 0], p[:, 1, 1] = 1.0, 3.0          # (0, 0) and (2, 2) cm at pitch 2: x = y = 3·2/4 = 1.5
    p[1, 0, 1] = np.nan
    p[2, 0, 1] = np.inf
    np.testing.assert_allclose(cop(p, pitch_cm=2.0), [[1.5, 1.5]] * 3)
    q = np.ones((2, 3, 3))
    q[0, 0, 0], q[1, 2, 1] = np.nan, -0.5
    with pytest.raises(ValueError, match=r"index \(1, 2, 1\) is -0.5"):
        cop(q)


def test_eu_divides_by_n():
    a = np.zeros((4, 2))
    b = np.array([[3.0, 4.0], [0, 0], [0, 0], [0, 0]])  # one distance of 5
    assert eu(a, b) == pytest.approx(5.0 / 4)  # sqrt(25) / N, eq. 3.1
    assert eu(a[:, 0], b[:, 0]) == pytest.approx(3.0 / 4)  # Eu_ML, eq. 3.2
    with pytest.raises(ValueError):
        eu(a, b[:3])

"""The emulated 8x8 mat (thesis §3.2.1): the four choices of rows and columns, in full-mat coordinates."""

from __future__ import annotations

import numpy as np
import pytest

from psmat.balance import subgrid_cops, subgrids


def test_four_choices_of_one_in_two_rows_and_columns() -> None:
    a = np.arange(16 * 16, dtype=float).reshape(16, 16)
    subs = list(subgrids(a, 2.0))
    assert [(s.rows0, s.cols0) for s in subs] == [(0, 0), (0, 1), (1, 0), (1, 1)]
    for s in subs:
        assert s.images.shape == (8, 8) and s.pitch_cm == 4.0
        # cell (i, p) of the choice is cell (r0 + 2i, c0 + 2p) of the full mat
        assert s.images[3, 5] == a[s.rows0 + 6, s.cols0 + 10]
    # together the four choices hold every cell exactly once
    assert sorted(np.concatenate([s.images.ravel() for s in subs])) == list(a.ravel())


def test_a_point_load_on_a_kept_cell_keeps_its_position() -> None:
    # one loaded cell at (row 5, col 9) of a 2 cm mat: x = 18 cm, y = 10 cm; only the choice
    # (odd rows, odd columns) sees it, and reports it where it is
    p = np.zeros((2, 16, 16))
    p[:, 5, 9] = 3.0
    c = subgrid_cops(p, 2.0)
    assert c.shape == (4, 2, 2)
    np.testing.assert_allclose(c[3], [[18.0, 10.0]] * 2)
    assert np.all(np.isnan(c[:3]))


def test_a_smooth_load_has_nearly_the_same_cop_on_every_choice() -> None:
    # a wide Gaussian bump centred at (13.3, 17.1) cm: each 8x8 choice sees its centre within a fraction of a cell
    y, x = np.mgrid[0:16, 0:16] * 2.0
    p = np.exp(-((x - 13.3) ** 2 + (y - 17.1) ** 2) / (2 * 4.0**2))
    c = subgrid_cops(p, 2.0)
    np.testing.assert_allclose(c, np.tile([13.3, 17.1], (4, 1)), atol=0.05)


def test_too_small_a_mat() -> None:
    with pytest.raises(ValueError, match="sub-grid"):
        list(subgrids(np.ones((1, 5)), 2.0))

"""A frame drawn in its mat's coordinates (``psmat.live.mat_image``, ``mat_extent_cm``), for every
direction a profile's axes may take: the pixel under each cell's centre (where
:meth:`psmat.profile.Geometry.cell_centres_cm` puts it) shows that cell."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from psmat.live import mat_extent_cm, mat_image
from psmat.profile import Geometry

# every pair of directions on different lines: 4 x 2 = 8 orientations
ORIENTATIONS = [(x, y) for x, y in itertools.product(("+columns", "-columns", "+rows", "-rows"), repeat=2)
                if x[1:] != y[1:]]


def _pixel(x_cm: float, y_cm: float, extent: tuple[float, float, float, float], shape: tuple[int, int]
           ) -> tuple[int, int]:
    """(row, column) of the pixel of ``imshow(origin="lower", extent=extent)`` that covers (x, y)."""
    left, right, bottom, top = extent
    col = int(np.floor((x_cm - left) / (right - left) * shape[1]))
    row = int(np.floor((y_cm - bottom) / (top - bottom) * shape[0]))
    return row, col


@pytest.mark.parametrize("x,y", ORIENTATIONS)
def test_each_cell_is_drawn_under_its_centre(x: str, y: str) -> None:
    geometry = Geometry((3, 5), 2.5, (7.0, -3.0), x, y)  # not square, origin shifted
    frame = np.arange(15).reshape(3, 5)  # every cell its own value
    image = mat_image(frame, geometry)
    extent = mat_extent_cm(geometry)
    left, right, bottom, top = extent
    assert left < right and bottom < top  # axes grow to the right and upwards
    # the image covers the cells' squares exactly: width = cells along x times the pitch
    assert right - left == pytest.approx(image.shape[1] * 2.5) and top - bottom == pytest.approx(image.shape[0] * 2.5)
    xs, ys = geometry.cell_centres_cm()
    for i, p in np.ndindex(3, 5):
        assert image[_pixel(xs[i, p], ys[i, p], extent, image.shape)] == frame[i, p], (i, p)


def test_the_default_geometry_draws_the_frame_as_it_is() -> None:
    g = Geometry((4, 6), 2.0)
    frame = np.arange(24.0).reshape(4, 6)
    assert np.array_equal(mat_image(frame, g), frame)
    assert mat_extent_cm(g) == (-1.0, 11.0, -1.0, 7.0)  # centres 0 ... 10 and 0 ... 6 cm, 1 cm either side


def test_a_frame_of_another_shape_is_refused() -> None:
    with pytest.raises(ValueError, match="3x5"):
        mat_image(np.zeros((5, 3)), Geometry((3, 5), 2.0))

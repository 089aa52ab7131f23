"""A mat's frame as an image in the mat's own coordinates (cm), whatever its axes' directions.

A profile's geometry (:class:`psmat.profile.Geometry`) may run the M-L axis ``x`` along the
columns or the rows, in the direction of growing or falling index, with cell (0, 0) anywhere
(``origin_cm``). ``imshow(..., origin="lower")`` draws array column ``j`` at growing ``x`` and
row ``i`` at growing ``y``; :func:`mat_image` reorders a frame (transposed when ``x`` runs along
the rows, flipped where an axis runs against the index) so that it does, and :func:`mat_extent_cm`
gives the image's edges in cm. A CoP computed on the same geometry (:func:`psmat.balance.cop`)
then sits on the cells that carry the load, and both axes grow to the right and upwards.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..profile import Geometry

__all__ = ["mat_image", "mat_extent_cm"]


def mat_image(frame: ArrayLike, geometry: Geometry) -> NDArray[Any]:
    """A frame (R, C) reordered for ``imshow(image, origin="lower", extent=mat_extent_cm(geometry))``.

    Parameters
    ----------
    frame : array_like (R, C)
        One frame of the mat in logical rows and columns (any unit).
    geometry : Geometry
        Where its cells are.

    Returns
    -------
    ndarray
        (R, C), or (C, R) when ``x`` runs along the rows: column ``j`` at the ``j``-th smallest
        ``x``, row ``i`` at the ``i``-th smallest ``y``.
    """
    a = np.asarray(frame)
    if a.shape != geometry.shape:
        raise ValueError(f"frame is {a.shape}, the geometry is for a {geometry.shape[0]}x{geometry.shape[1]} mat")
    if geometry.x.endswith("rows"):  # x changes along the rows: the image's columns are the frame's rows
        a = a.T
    if geometry.x.startswith("-"):
        a = a[:, ::-1]
    if geometry.y.startswith("-"):
        a = a[::-1, :]
    return a


def mat_extent_cm(geometry: Geometry) -> tuple[float, float, float, float]:
    """(left, right, bottom, top) of the image of :func:`mat_image`, in cm: each cell a square of the
    pitch centred on its centre, ``left < right`` and ``bottom < top``."""
    half = geometry.pitch_cm / 2
    edges = []
    for coordinate in ("x", "y"):
        _, pos = geometry.axis_positions_cm(coordinate)
        edges += [float(pos.min()) - half, float(pos.max()) + half]
    return edges[0], edges[1], edges[2], edges[3]

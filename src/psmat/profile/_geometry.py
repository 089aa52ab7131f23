"""Where a mat's cells are: shape, pitch, origin and axis directions (docs/spec.md §5 "Device profiles").

Cell ``(i, p)`` (row ``i``, column ``p``) has its centre at::

    x = origin_x + s_x · k_x · pitch        y = origin_y + s_y · k_y · pitch

where ``x`` is the medial-lateral (M-L) coordinate and ``y`` the anterior-posterior (A-P) one,
``k_x`` is ``p`` when ``x`` runs along the columns (``"±columns"``) and ``i`` when it runs along
the rows (``"±rows"``), ``s_x`` is the sign of the direction, and the same for ``y``. The
default, ``x = "+columns"``, ``y = "+rows"`` and origin ``(0, 0)``, is the convention of
:func:`psmat.balance.cop`: cell ``(i, p)`` at ``(p·pitch, i·pitch)``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = ["Geometry", "AXES"]

#: The directions an axis may take: along the columns (x grows with the column index ``p``) or
#: the rows (with the row index ``i``), in the direction of growing (``+``) or falling (``-``) index.
AXES = ("+columns", "-columns", "+rows", "-rows")


def _real(name: str, value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise ValueError(f"{name}: must be a number, got {value!r}")
    return float(value)


@dataclass(frozen=True)
class Geometry:
    """The cells of a mat in centimetres.

    Parameters
    ----------
    shape : (int, int)
        Rows and columns (R, C), each >= 1.
    pitch_cm : float
        Distance between the centres of neighbouring cells (cm), > 0.
    origin_cm : (float, float)
        (x, y) of the centre of cell (0, 0) (cm); default (0, 0).
    x : str
        Direction of the M-L axis, one of :data:`AXES`; default ``"+columns"``.
    y : str
        Direction of the A-P axis, one of :data:`AXES`, on the other set of lines than ``x``;
        default ``"+rows"``.

    Raises
    ------
    ValueError
        A bad value; the message starts with the field's name.
    """

    shape: tuple[int, int]
    pitch_cm: float
    origin_cm: tuple[float, float] = (0.0, 0.0)
    x: str = "+columns"
    y: str = "+rows"

    def __post_init__(self) -> None:
        shape = self.shape
        if (not isinstance(shape, (tuple, list)) or len(shape) != 2
                or any(isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1 for n in shape)):
            raise ValueError(f"shape: must be [rows, columns], two integers >= 1, got {shape!r}")
        pitch = _real("pitch_cm", self.pitch_cm)
        if not (math.isfinite(pitch) and pitch > 0):
            raise ValueError(f"pitch_cm: must be a finite number > 0 (cm), got {self.pitch_cm!r}")
        origin = self.origin_cm
        if not isinstance(origin, (tuple, list)) or len(origin) != 2:
            raise ValueError(f"origin_cm: must be [x, y] in cm, got {origin!r}")
        ox, oy = (_real("origin_cm", v) for v in origin)
        if not (math.isfinite(ox) and math.isfinite(oy)):
            raise ValueError(f"origin_cm: must be finite, got {origin!r}")
        for name in ("x", "y"):
            if getattr(self, name) not in AXES:
                raise ValueError(f"{name}: must be one of {', '.join(AXES)}, got {getattr(self, name)!r}")
        if self.x[1:] == self.y[1:]:
            raise ValueError(f"y: x and y must run along different lines (one along the rows, one along the "
                             f"columns), got x={self.x!r}, y={self.y!r}")
        object.__setattr__(self, "shape", (int(shape[0]), int(shape[1])))
        object.__setattr__(self, "pitch_cm", pitch)
        object.__setattr__(self, "origin_cm", (ox, oy))

    @property
    def cell_area_cm2(self) -> float:
        """Area each cell stands for (cm²): ``pitch²``."""
        return self.pitch_cm * self.pitch_cm

    def axis_positions_cm(self, coordinate: str) -> tuple[int, NDArray[np.float64]]:
        """Along which frame axis ``coordinate`` ("x" or "y") runs and its value on each line.

        Returns
        -------
        axis : int
            -1 when the coordinate changes along the columns of an (..., R, C) frame, -2 along its rows.
        positions_cm : ndarray
            The coordinate (cm) of each column (C,) or row (R,).
        """
        if coordinate not in ("x", "y"):
            raise ValueError(f"coordinate must be 'x' or 'y', got {coordinate!r}")
        direction = self.x if coordinate == "x" else self.y
        origin = self.origin_cm[0] if coordinate == "x" else self.origin_cm[1]
        axis = -1 if direction.endswith("columns") else -2
        n = self.shape[1] if axis == -1 else self.shape[0]
        step = self.pitch_cm if direction[0] == "+" else -self.pitch_cm
        return axis, origin + np.arange(n) * step

    def cell_centres_cm(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """(x, y) of every cell centre (cm): two (R, C) arrays, M-L then A-P."""
        R, C = self.shape
        out = []
        for coordinate in ("x", "y"):
            axis, pos = self.axis_positions_cm(coordinate)
            out.append(np.broadcast_to(pos[None, :] if axis == -1 else pos[:, None], (R, C)).copy())
        return out[0], out[1]

    def with_shape(self, shape: tuple[int, int]) -> Geometry:
        """The same pitch, origin and axes for a mat of another shape."""
        return Geometry(tuple(shape), self.pitch_cm, self.origin_cm, self.x, self.y)  # type: ignore[arg-type]

    def subgrid(self, rows0: int, cols0: int, factor: int) -> Geometry:
        """The geometry of the coarser mat that keeps rows ``rows0, rows0+factor, ...`` and columns
        ``cols0, cols0+factor, ...`` (thesis §3.2.1), in this mat's coordinates (cm)."""
        R, C = self.shape
        if not (0 <= rows0 < factor and 0 <= cols0 < factor and R >= factor and C >= factor):
            raise ValueError(f"no sub-grid ({rows0}, {cols0}) of factor {factor} on a {R}x{C} mat")
        x, y = self.cell_centres_cm()
        shape = (len(range(rows0, R, factor)), len(range(cols0, C, factor)))
        return Geometry(shape, factor * self.pitch_cm, (float(x[rows0, cols0]), float(y[rows0, cols0])), self.x,
                        self.y)

    def to_dict(self) -> dict[str, Any]:
        """Plain values (JSON-able), the keys of a profile's ``[geometry]`` table."""
        return {"shape": list(self.shape), "pitch_cm": self.pitch_cm, "origin_cm": list(self.origin_cm),
                "x": self.x, "y": self.y}

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> Geometry:
        """The inverse of :meth:`to_dict` (``origin_cm``, ``x``, ``y`` optional)."""
        return cls(tuple(d["shape"]), d["pitch_cm"], tuple(d.get("origin_cm", (0.0, 0.0))),  # type: ignore[arg-type]
                   d.get("x", "+columns"), d.get("y", "+rows"))

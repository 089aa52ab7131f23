"""Spine shape from the five IMU pitch angles: chained circular arcs (thesis eq. 4.4, docs/spec.md §8).

The back device's geometry — five sensors (:data:`psmat.protocol.IMU_SHAPE`) 90 mm apart along the
spine — has its one home here, below both users: the seated twin places its sensors with it
(:mod:`psmat.twin.seated`) and the posture study reads their angles with it
(:func:`psmat.posture.spine_points`, the same function re-exported).

Eq. 4.4 moves from sensor i to sensor i+1 with, for ``Δα = α_{i+1} − α_i``,
``C = sign(Δα)``, ``R = |l/Δα|``:

    T_i^{i+1} = Trans(C·R·sin Δα, C·R·(1 − cos Δα)) · Rot(Δα)

and the product ``T_1^2 ··· T_i^{i+1}`` applied to ``(0, 0, 1)`` is sensor i+1 in the frame
of sensor 1. Since ``C·R = l/Δα``, the translation is the chord of an arc of length l and
radius l/Δα, and ``l/Δα·(sin Δα, 1 − cos Δα) = l·sinc(Δα/2)·(cos Δα/2, sin Δα/2)`` with
``sinc x = sin x / x``: the form used here, exact and smooth through Δα = 0 (a straight
segment of length l). Multiplying out the product, the segment from sensor j to j+1 is
that chord turned by ``α_j − α_1``, i.e. a chord of length ``l·sinc(Δα_j/2)`` at the angle
``(α_j + α_{j+1})/2 − α_1`` from the u axis.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ._checks import positive_scalar, real_array
from .protocol import IMU_SHAPE

__all__ = ["spine_points", "N_SENSORS", "SPACING_MM"]

N_SENSORS: int = IMU_SHAPE[0]
"""IMUs on the thesis' back device (§4.2): 5."""
SPACING_MM = 90.0
"""Distance between consecutive sensors along the spine, mm (§4.2: "spaced 90 mm apart")."""


def spine_points(angles: ArrayLike, *, spacing_mm: float = SPACING_MM) -> NDArray[np.float64]:
    """Positions of the five spine sensors from their pitch angles (thesis eq. 4.4), mm.

    Convention (eq. 4.4 and the line after it, "multiplying it by the initial vector
    (0, 0, 1)^T, the position of the first sensor"): sensor 1 — the upper sensor, closest to
    the head (§4.2, "we have taken as reference the upper sensor") — is at (0, 0); u is the
    spine's tangent at sensor 1, pointing down the back towards sensor 5; v is u turned by
    +90° (the rotation block ``[[cos, −sin], [sin, cos]]`` of eq. 4.4 is counter-clockwise in
    (u, v)), so a positive ``Δα = α_{i+1} − α_i`` bends the spine towards +v. Whether +v is
    anterior or posterior is the pitch sign of the IMUs (§4.2: pitch about the frontal X axis).
    Consecutive sensors are joined by a circular arc of length ``spacing_mm`` (not a chord) and
    radius ``spacing_mm/|Δα|``; the thesis assumes ``|Δα| <= π/2`` but the formula holds for
    any angle. Only differences of angles enter: adding a constant to all five angles leaves
    the points unchanged (they are in sensor 1's frame, not the world's).

    Parameters
    ----------
    angles : array_like, (T, 5) or (5,)
        Pitch angle of each sensor (rad), sensor 1 first; finite.
    spacing_mm : float, keyword-only
        Arc length between consecutive sensors, mm (thesis: 90).

    Returns
    -------
    ndarray, (T, 5, 2) or (5, 2)
        (u, v) of each sensor in mm; a straight spine (equal angles) is (0, 0), (l, 0), …, (4l, 0).

    Raises
    ------
    TypeError
        ``angles`` not a real numeric array, ``spacing_mm`` not a real number.
    ValueError
        ``angles`` not of shape (5,) or (T, 5); NaN/inf angles; ``spacing_mm`` not finite and > 0.
    """
    a = real_array(angles, "angles", unit="rad")
    if a.ndim not in (1, 2) or a.shape[-1] != N_SENSORS:
        raise ValueError(f"angles must have shape ({N_SENSORS},) or (T, {N_SENSORS}) in rad, got {a.shape}")
    l = positive_scalar("spacing_mm", spacing_mm)
    d = np.diff(a, axis=-1)  # Δα_j, eq. 4.4
    chord = l * np.sinc(d / (2.0 * np.pi))  # l·sin(Δα/2)/(Δα/2); np.sinc(x) = sin(πx)/(πx)
    phi = 0.5 * (a[..., :-1] + a[..., 1:]) - a[..., :1]  # chord direction from u
    steps = chord[..., None] * np.stack([np.cos(phi), np.sin(phi)], axis=-1)
    out = np.zeros(a.shape + (2,))
    np.cumsum(steps, axis=-2, out=out[..., 1:, :])
    return out

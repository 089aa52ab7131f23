"""Cell conductances of a person standing on the twin's mat (docs/spec.md §5): frames for benchmarks,
tests and the crosstalk demo.

:func:`swaying_feet` is :func:`~psmat.twin.scenes.quiet_standing` (two feet, the CoP swaying
by a few mm) put through the sensor model of :class:`~psmat.twin.mat.MatPhysics` (the thesis'
Velostat model, Table 2.11, with cell-to-cell gains and the leakage ``g_rest`` of an unloaded
cell): pressure becomes conductance only there. The mat is the thesis' 32 cm one unless a
pitch is given (:func:`~psmat.twin.field.mat_pitch_cm`: 2 / 1 / 0.5 cm for 16 / 32 / 64 cells).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from .._checks import positive, positive_int, shape2
from .field import mat_pitch_cm
from .mat import MatPhysics
from .scenes import quiet_standing

__all__ = ["swaying_feet"]

#: Shortest scene rendered (s). The sway is band-limited to 0.2–1 Hz (quiet_standing); a
#: record shorter than a few periods of 0.2 Hz has no frequency inside that band, so short
#: recordings are the first frames of a scene this long.
MIN_SCENE_S = 10.0


def swaying_feet(
    frames: int,
    shape: tuple[int, int] = (16, 16),
    *,
    pitch_cm: float | None = None,
    rate_hz: float = 100.0,
    seed: int = 0,
    weight_n: float = 700.0,
    sway_cm: tuple[float, float] = (0.25, 0.35),
    variability: float = 0.15,
    g_rest: float = 1e-7,
    return_cop_cm: bool = False,
) -> NDArray[np.float64] | tuple[NDArray[np.float64], NDArray[np.float64]]:
    """A recording of cell conductances of two feet in quiet standing.

    Parameters
    ----------
    frames : int
        Number of frames T (>= 1), at ``t = k / rate_hz``.
    shape : (R, C)
        Mat size in cells.
    pitch_cm : float, optional
        Cell pitch in cm; default :func:`~psmat.twin.field.mat_pitch_cm` (a 32 cm mat).
    rate_hz : float
        Frame rate in Hz; also the sensor model's time step (creep).
    seed : int
        Seeds the sway (:func:`~psmat.twin.scenes.quiet_standing`) and the cell gains
        (:class:`~psmat.twin.mat.MatPhysics`).
    weight_n : float
        Body weight in N.
    sway_cm : (float, float)
        Standard deviation of the CoP, (M-L, A-P) in cm.
    variability : float
        SD of the log of the cell gains (0.15: about 15 % cell to cell).
    g_rest : float
        Conductance of an unloaded cell in S (1e-7 S = 10 MΩ).
    return_cop_cm : bool
        Also return ``cop_cm``, the CoP of the continuous pressure field, (T, 2) cm (a flag:
        the suffix names the unit of what it asks for).

    Returns
    -------
    g : ndarray, shape (T, R, C)
        Cell conductances in S, from rest (no load history) at the first frame.
    cop_cm : ndarray, shape (T, 2)
        Only with ``return_cop_cm``: the true CoP (x = M-L, y = A-P) in cm, mat coordinates.
    """
    n = positive_int("frames", frames)
    shape_ = shape2(shape)
    rate = positive("rate_hz", rate_hz)
    pitch = mat_pitch_cm(shape_) if pitch_cm is None else positive("pitch_cm", pitch_cm)
    rendered = max(n, math.ceil(MIN_SCENE_S * rate))
    scene = quiet_standing(rendered / rate, rate, shape_, pitch, weight_n, seed, sway_cm=sway_cm)
    mat = MatPhysics(shape_, dt=1.0 / rate, variability=variability, g_rest=g_rest, seed=seed)
    g = mat.conductance(scene.pressure_psi[:n])
    return (g, scene.cop_true_cm[:n]) if return_cop_cm else g

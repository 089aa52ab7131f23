"""The settled part of a calibration recording: the frames that enter a calibration's average.

A lab starts ``psmat record``, puts the load on (masses on a plate, a person stepping on),
waits, and may take it off before stopping. The load is on where the frame's total
conductance is at least half its 95th percentile (an unloaded mat is orders of magnitude
less conductive); the average starts ``settle_s`` after the load first appears, while it is on.
The sensor model is still run over the whole recording, so the load's history counts.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from .. import _checks
from ..sensor import frame_periods, steps_over_gaps

__all__ = ["settled_frames", "recording_cells"]


def recording_cells(g: object, name: str) -> NDArray[np.float64]:
    """A recording's cell conductances (T, R, C) in S, checked (NaN marks a missing frame)."""
    a = _checks.real_array(g, name, unit="S", allow_nan=True)
    if a.ndim != 3:
        raise ValueError(f"{name} must be a recording of frames (T, R, C) in S, got shape {a.shape}")
    if np.any(a < 0):
        raise ValueError(f"{name} has negative conductances; pass cell conductances (S) after IECM")
    return a


def settled_frames(g: NDArray[np.float64], dt_s: object, settle_s: float, name: str
                   ) -> tuple[NDArray[np.bool_], NDArray[np.float64], NDArray[np.bool_]]:
    """Which frames are complete, their sensor-model steps, and which of them are settled.

    Parameters
    ----------
    g : (T, R, C)
        Cell conductances (S); frames with NaN are missing.
    dt_s : float or (T,)
        Frame period(s) (s).
    settle_s : float
        Time after the load first appears before frames count (s), >= 0.
    name : str
        The recording's name in messages.

    Returns
    -------
    usable : (T,) bool
        Complete frames (the sensor model sees these).
    steps : (U,) float
        Each usable frame's step (s), over missing frames (:func:`psmat.sensor.steps_over_gaps`).
    settled : (U,) bool
        The usable frames that enter the average.
    """
    T = g.shape[0]
    periods = frame_periods(dt_s, T)
    if not (np.isfinite(settle_s) and settle_s >= 0):
        raise ValueError(f"settle_s must be a time >= 0 s, got {settle_s!r}")
    usable = np.all(np.isfinite(g), axis=(1, 2))
    if not usable.any():
        raise ValueError(f"{name}: no complete frame")
    steps, _ = steps_over_gaps(periods, usable)
    total = g[usable].sum(axis=(1, 2))
    on = total >= 0.5 * np.percentile(total, 95)
    if not np.any(total > 0):
        raise ValueError(f"{name}: the mat conducts nowhere; no load on it")
    t = np.cumsum(steps)
    first = int(np.flatnonzero(on)[0])
    settled = on & (t >= t[first] + settle_s)
    if not settled.any():
        raise ValueError(f"{name}: the load is on for less than {settle_s:g} s (settle time) after it appears; "
                         "record longer")
    return usable, steps, settled

"""The sensor model on a stream with missing frames (docs/spec.md §4, the chain's policy of
:mod:`psmat.process`).

A frame lost on the wire (or unusable) is not seen by the sensor model, but the sensor
creeps on while it is missing: the next usable frame is stepped with the whole time since
the previous usable one (its own period plus the missing frames'), eq. 2.23 with the
pressure held. One home for that rule and for the frame periods it is given: the processing
chain, the SCHC scaling factor (eq. 3.3) and the per-cell equilibration all use it.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .. import _checks
from ._mpi_creep import MPICreep

__all__ = ["frame_periods", "steps_over_gaps", "inverse_over_gaps"]


def frame_periods(dt: float | ArrayLike, T: int) -> NDArray[np.float64]:
    """Each frame's period (T,), s, from one period for every frame or one per frame.

    Parameters
    ----------
    dt : float or array (T,)
        One frame period (s), or each frame's time since the frame before it (s).
    T : int
        Number of frames.

    Returns
    -------
    ndarray (T,)
        Periods (s), every one finite and > 0.

    Raises
    ------
    ValueError
        A period that is not > 0, or a number of periods other than 1 or T.
    """
    if np.ndim(dt) == 0:
        return np.full(T, _checks.positive("dt", dt))
    periods = _checks.vector("dt", dt)
    if periods.shape != (T,):
        raise ValueError(f"dt must be one frame period or one per frame ({T},), got shape {periods.shape}")
    if np.any(periods <= 0):
        k = int(np.flatnonzero(periods <= 0)[0])
        raise ValueError(f"dt must be > 0 s for every frame; frame {k} has {float(periods[k])!r}")
    return periods


def steps_over_gaps(periods: ArrayLike, usable: ArrayLike, since: float = 0.0) -> tuple[NDArray[np.float64], float]:
    """Each usable frame's step: the time since the previous usable frame (s).

    Parameters
    ----------
    periods : (T,) float
        Each frame's time since the frame before it (s).
    usable : (T,) bool
        Frames the sensor model sees.
    since : float
        Time already elapsed since the last usable frame before these (s), e.g. carried
        from the previous chunk of a stream.

    Returns
    -------
    steps : (U,) float
        One step per usable frame, in order.
    since : float
        Time after the last usable frame not yet stepped (to carry into the next chunk).
    """
    steps = []
    for period, ok in zip(np.asarray(periods, np.float64).tolist(), np.asarray(usable, bool).tolist()):
        since += period
        if ok:
            steps.append(since)
            since = 0.0
    return np.array(steps, np.float64), since


def inverse_over_gaps(model: MPICreep, g: ArrayLike, periods: float | ArrayLike) -> NDArray[np.float64]:
    """Pressure (psi) of a recording (T, ...) whose missing frames are NaN, from the sensor at rest.

    Parameters
    ----------
    model : MPICreep
        The sensor model.
    g : array (T, ...)
        Conductances (S); a frame with any NaN is missing (NaN out).
    periods : float or (T,)
        One frame period (s) or each frame's time since the previous frame (s); the usable
        frames are stepped over the gaps (:func:`steps_over_gaps`).
    """
    g = np.asarray(g, dtype=np.float64)
    T = g.shape[0]
    usable = np.all(np.isfinite(g.reshape(T, -1)), axis=1)
    steps, _ = steps_over_gaps(frame_periods(periods, T), usable)
    out = np.full_like(g, np.nan)
    if usable.any():
        out[usable] = model.inverse(g[usable], steps)
    return out

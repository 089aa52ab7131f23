"""The sensor model on a stream with missing frames (docs/spec.md §4, the chain's policy of
:mod:`psmat.process`).

A frame lost on the wire (or unusable) is not seen by the sensor model, but the sensor
creeps on while it is missing: the next usable frame is stepped with the whole time since
the previous usable one (its own period plus the missing frames'), eq. 2.23 with the
pressure held. One home for that rule: the processing chain and the SCHC scaling factor
(eq. 3.3) both use it.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .mpi_creep import MPICreep, SensorState

__all__ = ["steps_over_gaps", "inverse_stepped", "inverse_over_gaps"]


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


def inverse_stepped(model: MPICreep, g: ArrayLike, steps: ArrayLike, state: SensorState | None = None
                    ) -> NDArray[np.float64]:
    """Pressure (psi) of samples (T, ...) each with its own time step (s), the operator state
    carried through ``state``: one call of :meth:`MPICreep.inverse` with per-sample periods."""
    g = np.asarray(g, dtype=np.float64)
    steps = np.asarray(steps, np.float64)
    if steps.shape != (g.shape[0],):
        raise ValueError(f"steps must have one value per sample ({g.shape[0]}), got shape {steps.shape}")
    if g.shape[0] == 0:
        return g.copy()
    return model.inverse(g, steps, state)


def inverse_over_gaps(model: MPICreep, g: ArrayLike, periods: float | ArrayLike) -> NDArray[np.float64]:
    """Pressure (psi) of a recording (T, ...) whose missing frames are NaN.

    ``periods``: one frame period (s) or each frame's time since the previous frame. A
    frame with any NaN is missing (NaN out); the usable frames are stepped over the gaps.
    """
    g = np.asarray(g, dtype=np.float64)
    T = g.shape[0]
    per = np.broadcast_to(np.asarray(periods, np.float64), (T,))
    usable = np.all(np.isfinite(g.reshape(T, -1)), axis=1)
    steps, _ = steps_over_gaps(per, usable)
    out = np.full_like(g, np.nan)
    out[usable] = inverse_stepped(model, g[usable], steps)
    return out

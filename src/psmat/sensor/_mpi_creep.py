"""Velostat sensor model: MPI hysteresis + creep, direct and exact inverse (thesis §2.5.1, docs/spec.md §4).

The model runs in the C++ core (``src/cpp/psmat/sensor/mpi_creep.hpp``); this module handles
shapes, units and state. Pressure in psi, conductance in S, sampling period ``dt`` in s.
Streams are (T,) for one cell or (T, ...) for many (e.g. (T, R, C) mat recordings); each cell
has its own operator state, carried in a :class:`SensorState` between chunks of a live stream.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .. import _core
from .._checks import first_bad

__all__ = ["MPICreep", "SensorState", "THESIS_TABLE_2_11", "P_BEYOND"]

#: :meth:`MPICreep.direct` refuses pressures above this many times ``p_max``: a mat's loads reach
#: a few times the identified range (a heel), a thousand psi is a wrong unit or a wrong number
P_BEYOND = 10.0

#: Thesis Table 2.11 (Velostat), SSE_N = 2.74e-9 S^2.
THESIS_TABLE_2_11 = dict(
    rho=1.64e-4, tau=0.269, a1=1.01e-4, a2=-5.32e-6, a3=7.37e-8,
    l=(8.25e-4, 5.26e-6), w=(8.42e-6, 1.90e-6),
)


@dataclass
class SensorState:
    """Operator state of every cell (OSP outputs, creep outputs, previous pressure), in psi."""

    cell_shape: tuple[int, ...]
    _s: object = field(repr=False)

    @property
    def y(self) -> np.ndarray:
        """OSP operator outputs, (n_ops, *cell_shape), psi."""
        return np.asarray(self._s.y).reshape((-1,) + self.cell_shape)

    @property
    def y_creep(self) -> np.ndarray:
        """Creep operator outputs, (n_creep, *cell_shape), psi."""
        return np.asarray(self._s.yc).reshape((-1,) + self.cell_shape)

    @property
    def p_prev(self) -> np.ndarray:
        """Previous pressure sample of each cell, psi."""
        return np.asarray(self._s.p_prev).reshape(self.cell_shape)

    def copy(self) -> "SensorState":
        return SensorState(self.cell_shape, self._s.copy())


class MPICreep:
    """Modified Prandtl-Ishlinskii hysteresis plus creep operators (eq. 2.15-2.25).

    Parameters
    ----------
    rho : float
        Weight scale of the OSP operators, S/psi (eq. 2.18).
    tau : float
        Weight decay, 1/psi (eq. 2.18: b_i = rho exp(-tau r_i)).
    a1, a2, a3 : float
        Polynomial coefficients, S/psi, S/psi^2, S/psi^3 (eq. 2.17).
    l : sequence of float
        Creep rates, 1/s (eq. 2.23).
    w : sequence of float
        Creep weights, S/psi (eq. 2.24).
    n_ops : int
        Number of OSP operators N (thesis: 6).
    p_max : float
        psi; thresholds r_i = (i-1)/N p_max (thesis: 32 psi).
    """

    def __init__(self, rho: float, tau: float, a1: float, a2: float, a3: float, l=(), w=(),
                 n_ops: int = 6, p_max: float = 32.0):
        prm = _core.sensor.MPICreepParams()
        prm.rho, prm.tau, prm.a1, prm.a2, prm.a3 = (float(v) for v in (rho, tau, a1, a2, a3))
        prm.l = [float(v) for v in np.atleast_1d(l)]
        prm.w = [float(v) for v in np.atleast_1d(w)]
        if int(n_ops) != n_ops:
            raise ValueError(f"n_ops must be an integer, got {n_ops!r}")
        prm.n_ops = int(n_ops)
        prm.p_max = float(p_max)
        self._m = _core.sensor.MPICreep(prm)  # validates (ValueError on bad values)
        self.params = dict(rho=prm.rho, tau=prm.tau, a1=prm.a1, a2=prm.a2, a3=prm.a3,
                           l=tuple(prm.l), w=tuple(prm.w), n_ops=prm.n_ops, p_max=prm.p_max)

    @classmethod
    def thesis(cls) -> "MPICreep":
        """The thesis' Velostat model (Table 2.11): 6 operators, p_max = 32 psi, 2 creep operators."""
        return cls(**THESIS_TABLE_2_11)

    def __repr__(self) -> str:
        return "MPICreep(" + ", ".join(f"{k}={v!r}" for k, v in self.params.items()) + ")"

    @property
    def p_max(self) -> float:
        """Upper end of the model's range, psi (the largest threshold is below it)."""
        return float(self.params["p_max"])

    @property
    def thresholds(self) -> np.ndarray:
        """r_i in psi."""
        return np.asarray(self._m.thresholds)

    @property
    def weights(self) -> np.ndarray:
        """b_i in S/psi (eq. 2.18)."""
        return np.asarray(self._m.weights)

    def invertibility_problem(self) -> str:
        """Empty when the model is invertible on [0, p_max]; otherwise the reason (docs/spec.md §4)."""
        return str(self._m.check_invertible())

    def rest_state(self, cell_shape: int | tuple[int, ...] = ()) -> SensorState:
        """Sensor at rest (all operators 0) for cells of the given shape (() = one cell)."""
        shape = (cell_shape,) if isinstance(cell_shape, (int, np.integer)) else tuple(int(v) for v in cell_shape)
        return SensorState(shape, self._m.rest_state(int(np.prod(shape, dtype=np.int64))))

    def _stream(self, x, name: str, dt, state: SensorState | None):
        a = np.asarray(x)
        if a.dtype == object or not (np.issubdtype(a.dtype, np.floating) or np.issubdtype(a.dtype, np.integer)):
            raise TypeError(f"{name} must be a real numeric array, got dtype {a.dtype}")
        if a.ndim < 1:
            raise ValueError(f"{name} must be a (T,) or (T, ...) stream, got a scalar")
        periods = np.atleast_1d(np.asarray(dt, dtype=np.float64))
        if periods.ndim != 1 or periods.size not in (1, a.shape[0]):
            raise ValueError(f"dt must be one sampling period or one per sample ({a.shape[0]}) in s, "
                             f"got shape {np.shape(dt)}")
        if not np.all(np.isfinite(periods) & (periods > 0)):
            raise ValueError(f"dt must be a positive sampling period in s, got {dt!r}" if periods.size == 1
                             else "dt must hold positive sampling periods in s")
        if np.isinf(a).any():
            raise ValueError(f"{name} contains infinite values")
        cells = a.shape[1:]
        if state is None:
            state = self.rest_state(cells)
        elif state.cell_shape != cells:
            raise ValueError(f"state is for cells of shape {state.cell_shape}, the stream has {cells}")
        flat = np.ascontiguousarray(a, dtype=np.float64).reshape(a.shape[0], int(np.prod(cells, dtype=np.int64)))
        return flat, periods, state

    def direct(self, p, dt: float | np.ndarray, state: SensorState | None = None) -> np.ndarray:
        """Conductance (S) for a pressure stream (psi), sampled every ``dt`` s.

        Parameters
        ----------
        p : array_like, shape (T,) or (T, ...)
            Pressure in psi (>= 0). NaN samples give NaN and are skipped (the cell's state
            does not see them).
        dt : float or (T,) array
            Sampling period in s, or each sample's time since the one before it (a real
            clock, or frames missing in between): sample k's creep step (eq. 2.23) is ``dt[k]``.
        state : SensorState, optional
            Operator state to start from and to update in place (a live stream in chunks);
            default: the sensor at rest.

        Raises
        ------
        ValueError
            A negative pressure, one above :data:`P_BEYOND` times ``p_max``, or one whose
            conductance is not a finite number (the state is then left as it was).
        """
        flat, periods, state = self._stream(p, "p", dt, state)
        if np.any(flat < 0):
            raise ValueError("p must be >= 0 psi (the OSP operators are one-sided)")
        top = P_BEYOND * self.p_max
        if np.any(flat > top):
            k = first_bad(flat > top)
            raise ValueError(f"p = {flat[k]:g} psi at sample {k[0]} is beyond {top:g} psi ({P_BEYOND:g} x p_max), "
                             f"where the model means nothing (identified on 0 ... {self.p_max:g} psi); pressures "
                             "are in psi")
        before = state._s.copy()  # a refused stream leaves the state as it was
        g = np.asarray(self._m.direct(flat, periods, state._s))
        bad = ~np.isfinite(g) & np.isfinite(flat)  # NaN in, NaN out: a skipped sample, not an overflow
        if bad.any():
            state._s = before
            k = first_bad(bad)
            raise ValueError(f"p = {flat[k]:g} psi at sample {k[0]} gives a conductance of {g[k]:g} S, not a finite "
                             f"number: check the model's parameters {self!r}")
        return g.reshape(np.shape(p))

    def inverse(self, g, dt: float | np.ndarray, state: SensorState | None = None, *, return_clipped: bool = False):
        """Pressure (psi) from a conductance stream (S): the exact inverse of :meth:`direct`.

        The polynomial term uses the current pressure (an algebraic loop), solved per sample,
        so ``direct(inverse(g)) == g`` to round-off. A conductance below what zero pressure
        gives (more creep than signal) returns p = 0, one above what ``p_max`` gives returns
        ``p_max`` (the model is identified and checked monotone on [0, p_max] only, docs/spec.md §4);
        their number with ``return_clipped``. ``dt``: one sampling period or one per sample (s),
        as in :meth:`direct`.

        Raises
        ------
        ValueError
            When the parameters are not invertible (a non-positive slope, docs/spec.md §4).
        """
        why = self.invertibility_problem()
        if why:
            raise ValueError(f"this sensor model is not invertible: {why}")
        flat, periods, state = self._stream(g, "g", dt, state)
        p, clipped = self._m.inverse(flat, periods, state._s)
        p = np.asarray(p).reshape(np.shape(g))
        return (p, int(clipped)) if return_clipped else p

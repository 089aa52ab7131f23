"""The simulated mat's physics (docs/spec.md §5 "Digital twin"): pressure → ADC counts.

A stream of pressure images (psi, :mod:`psmat.twin.scenes`) goes through

1. the per-cell sensor model — the Velostat MPI hysteresis + creep model
   (:class:`psmat.sensor.MPICreep`, thesis Table 2.11 by default, eq. 2.15–2.24) with
   cell-to-cell variability: a log-normal gain per cell (the thesis names it the main open
   problem, §2.5) — plus a small leakage conductance of an unloaded cell, so that the
   network stays connected (a Velostat cell at rest is megohms, not an open circuit);
2. the crosstalk of the array: the equivalent conductances ``G = F(g)``
   (:func:`psmat.iecm.forward`, eq. 2.5–2.7);
3. the measurement chain (:class:`psmat.Circuit`, docs/spec.md §2): R_mux, R_adc, Gaussian noise on
   the ADC node and 12-bit quantisation.

The sensor state is carried between calls, so a live stream is one continuous experiment.
Pressures above the model's range (``p_max``, 32 psi) saturate there: the model is
identified and checked monotone on [0, p_max] only (docs/spec.md §4).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from .. import iecm
from ..circuit import Circuit
from ..sensor import MPICreep

__all__ = ["MatPhysics", "MatTruth"]


@dataclass
class MatTruth:
    """What the simulation knows and a real mat does not: per-frame ground truth."""

    pressure_psi: NDArray[np.float64]  # (T, R, C) applied, after saturation at p_max
    g: NDArray[np.float64]  # (T, R, C) cell conductances (S)
    G: NDArray[np.float64]  # (T, R, C) equivalent conductances (S)


@dataclass
class MatPhysics:
    """Pressure images (psi) → ADC counts, with state carried between calls.

    Parameters
    ----------
    shape : (R, C)
        Array size.
    dt : float
        Frame period (s) — the sensor model's creep depends on it.
    sensor : MPICreep, optional
        Per-cell model; default the thesis' (Table 2.11).
    variability : float
        Standard deviation of the log of the per-cell gain (0.15 ≈ 15 % cell-to-cell).
    g_rest : float
        Leakage conductance of an unloaded cell (S); 1e-7 S = 10 MΩ.
    circuit : Circuit, optional
        Measurement chain; default ``Circuit()`` (improved prototype, docs/spec.md §2).
    noise_v : float
        SD of the ADC-node noise (V); thesis Table 2.4: about 1 mV.
    seed : int
        Seeds the cell gains and the noise.
    sensitivity : float
        A global conductance factor on every cell (dimensionless, > 0): the thesis found its
        large mat 1.3–4× more conductive than the pneumatic samples the model was fitted on
        (§3.2.2, eq. 3.3). The per-cell gains are ``sensitivity · exp(variability · N(0, 1))``.
    """

    shape: tuple[int, int] = (16, 16)
    dt: float = 0.01
    sensor: MPICreep | None = None
    variability: float = 0.15
    g_rest: float = 1e-7
    circuit: Circuit = field(default_factory=Circuit)
    noise_v: float = 1e-3
    seed: int = 0
    sensitivity: float = 1.0

    def __post_init__(self) -> None:
        R, C = (int(v) for v in self.shape)
        if R < 1 or C < 1:
            raise ValueError(f"shape must be positive, got {self.shape}")
        if not (self.dt > 0 and np.isfinite(self.dt)):
            raise ValueError(f"dt must be a positive number of seconds, got {self.dt}")
        if not (self.variability >= 0 and self.g_rest > 0 and self.noise_v >= 0):
            raise ValueError("variability >= 0, g_rest > 0 (S) and noise_v >= 0 (V) are required")
        if not (self.sensitivity > 0 and np.isfinite(self.sensitivity)):
            raise ValueError(f"sensitivity must be a finite factor > 0, got {self.sensitivity!r}")
        self.shape = (R, C)
        if self.sensor is None:
            self.sensor = MPICreep.thesis()
        self._rng = np.random.default_rng(self.seed)
        self.gain = self.sensitivity * np.exp(self.variability * self._rng.standard_normal(self.shape))
        self._state = self.sensor.rest_state(self.shape)

    def reset(self) -> None:
        """Back to rest (no load history)."""
        self._state = self.sensor.rest_state(self.shape)

    def _pressure(self, pressure_psi: NDArray[np.float64]) -> NDArray[np.float64]:
        """Checked (T, R, C) pressure in psi, saturated at the sensor's ``p_max``."""
        p = np.asarray(pressure_psi, dtype=np.float64)
        if p.ndim == 2:
            p = p[None]
        if p.ndim != 3 or p.shape[1:] != self.shape:
            raise ValueError(f"pressure must be (T, {self.shape[0]}, {self.shape[1]}) psi, got {p.shape}")
        if not np.all(np.isfinite(p)) or np.any(p < 0):
            raise ValueError("pressure must be finite and >= 0 psi")
        return np.minimum(p, self.sensor.p_max)  # the sensor saturates (module docstring)

    def _cells(self, p: NDArray[np.float64]) -> NDArray[np.float64]:
        """Cell conductances (S) of checked pressures: ``gain · direct(p) + g_rest``; advances the state."""
        return self.sensor.direct(p, self.dt, self._state) * self.gain + self.g_rest

    def conductance(self, pressure_psi: NDArray[np.float64]) -> NDArray[np.float64]:
        """Cell conductances g (T, R, C) in S for pressure images (T, R, C) psi, in time order.

        Step 1 of the module docstring alone (the sensor model, each cell's gain, the leakage
        ``g_rest``); the sensor state carries on as in :meth:`counts`.
        """
        return self._cells(self._pressure(pressure_psi))

    def counts(self, pressure_psi: NDArray[np.float64], *, return_truth: bool = False):
        """ADC counts (T, R, C) uint16 for pressure images (T, R, C) psi, in time order.

        With ``return_truth`` also a :class:`MatTruth` (g and G before the circuit).
        """
        p = self._pressure(pressure_psi)
        g = self._cells(p)
        G = iecm.forward(g)
        counts = self.circuit.counts(G, noise_v=self.noise_v, rng=self._rng)
        if return_truth:
            return counts, MatTruth(p, g, G)
        return counts

"""Cell-to-cell variability (the thesis' main open problem, §2.6): models for many cells.

Three ways to turn a multi-cell pneumatic experiment (one applied pressure, T x cells
conductances) into per-cell compensation:

``"shared"``     one model for every cell (the thesis);
``"gain"``       one shared model and a gain k_c per cell: g_c(t) = k_c * g_shared(t), the
                 gains estimated by least squares against the cell-averaged response (mean 1)
                 and the shared model fitted to the gain-normalised responses;
``"per_cell"``   an independent model per cell.
Fits use :func:`psmat.sensor.fit` (variable projection by default).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ._fit import fit
from ._mpi_creep import MPICreep

__all__ = ["CellModels", "fit_cells", "MODES"]

MODES = ("shared", "gain", "per_cell")


@dataclass
class CellModels:
    """Compensation models for ``cells`` cells: ``models[c]`` with gain ``gains[c]``."""

    mode: str
    models: list[MPICreep]
    gains: np.ndarray

    def model_of(self, c: int) -> MPICreep:
        return self.models[c if len(self.models) > 1 else 0]

    def inverse(self, g, dt: float) -> np.ndarray:
        """Pressure (psi) of a (T, cells) conductance stream (S), each cell its own model."""
        g = np.asarray(g, dtype=float)
        if g.ndim != 2 or g.shape[1] != len(self.gains):
            raise ValueError(f"g must be (T, cells) with {len(self.gains)} cells, got {g.shape}")
        if len(self.models) == 1:
            return self.models[0].inverse(g / self.gains, dt)
        return np.column_stack([m.inverse(g[:, c] / self.gains[c], dt) for c, m in enumerate(self.models)])


def fit_cells(p, g, dt: float, mode: str = "gain", method: str = "varpro", **fit_kwargs) -> CellModels:
    """Fit compensation models from a multi-cell experiment.

    Parameters
    ----------
    p : array_like, shape (T,)
        Applied pressure (psi), the same for every cell (a pneumatic chamber).
    g : array_like, shape (T, cells)
        Measured conductances (S).
    dt : float
        Sampling period (s).
    mode : {"shared", "gain", "per_cell"}
    method, **fit_kwargs
        Passed to :func:`psmat.sensor.fit`.
    """
    if mode not in MODES:
        raise ValueError(f"mode must be one of {MODES}, got {mode!r}")
    p = np.asarray(p, dtype=float)
    g = np.asarray(g, dtype=float)
    if p.ndim != 1 or g.ndim != 2 or g.shape[0] != p.shape[0]:
        raise ValueError(f"need p (T,) and g (T, cells) with the same T, got {p.shape} and {g.shape}")
    cells = g.shape[1]
    if mode == "per_cell":
        models = [fit(p, g[:, c], dt, method=method, **fit_kwargs).model for c in range(cells)]
        return CellModels(mode, models, np.ones(cells))
    gains = np.ones(cells)
    if mode == "gain":
        mean = g.mean(axis=1)
        gains = (g * mean[:, None]).sum(axis=0) / np.sum(mean**2)  # least squares g_c ~ k_c * mean
        gains /= gains.mean()
    normalised = g / gains
    # one model for all cells: fit the cells as independent experiments of the same sensor
    res = fit([p] * cells, [normalised[:, c] for c in range(cells)], dt, method=method, **fit_kwargs)
    return CellModels(mode, [res.model], gains)

"""MSE and R² per output (thesis eqs. 4.2, 4.3) and the rows of Table 4.4.

R² = 1 − SS_res / SS_tot per output, SS_tot about the mean of the measured values
(what TorchMetrics' R2Score computes per output); NaN for an output that does not vary.
"""

from __future__ import annotations

import csv
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["OUTPUTS", "mse_per_output", "r2_per_output", "table44_row", "TABLE44_COLUMNS", "write_table44"]

#: The six outputs as named in Table 4.4: sensor 0 cervical .. 4 sacral, and their sum.
OUTPUTS = ("Sensor0", "Sensor1", "Sensor2", "Sensor3", "Sensor4", "Sum")
TABLE44_COLUMNS = ("model", "split", "subset", "n_windows", "MSE",
                   *(f"MSE_{o}" for o in OUTPUTS), *(f"R2_{o}" for o in OUTPUTS))


def _pair(y_true: ArrayLike, y_pred: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    t, p = np.asarray(y_true, dtype=np.float64), np.asarray(y_pred, dtype=np.float64)
    if t.ndim != 2 or t.shape != p.shape or t.shape[0] == 0:
        raise ValueError(f"y_true and y_pred must be the same (N, K) shape with N > 0, got {t.shape} and {p.shape}")
    return t, p


def mse_per_output(y_true: ArrayLike, y_pred: ArrayLike) -> NDArray[np.float64]:
    """Mean squared error of each column (eq. 4.2), in the outputs' unit squared (rad²)."""
    t, p = _pair(y_true, y_pred)
    return np.mean(np.square(p - t), axis=0)


def r2_per_output(y_true: ArrayLike, y_pred: ArrayLike) -> NDArray[np.float64]:
    """Coefficient of determination of each column (eq. 4.3): 1 − SS_res/SS_tot."""
    t, p = _pair(y_true, y_pred)
    ss_res = np.sum(np.square(t - p), axis=0)
    ss_tot = np.sum(np.square(t - t.mean(axis=0)), axis=0)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(ss_tot > 0, 1.0 - ss_res / np.where(ss_tot > 0, ss_tot, 1.0), np.nan)


def table44_row(model: str, split: str, subset: str, y_true: ArrayLike, y_pred: ArrayLike) -> dict[str, Any]:
    """One row of Table 4.4: MSE over all outputs (the loss), MSE and R² per output."""
    t, p = _pair(y_true, y_pred)
    mse, r2 = mse_per_output(t, p), r2_per_output(t, p)
    row: dict[str, Any] = {"model": model, "split": split, "subset": subset, "n_windows": int(t.shape[0]),
                           "MSE": float(mse.mean())}
    row |= {f"MSE_{o}": float(v) for o, v in zip(OUTPUTS, mse)}
    row |= {f"R2_{o}": float(v) for o, v in zip(OUTPUTS, r2)}
    return row


def write_table44(rows: Sequence[dict[str, Any]], path: str | Path) -> Path:
    """Write Table 4.4 rows as CSV (columns :data:`TABLE44_COLUMNS`)."""
    from ..._atomic import open_atomic

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with open_atomic(path, "w") as f:  # whole or not at all
        w = csv.DictWriter(f, fieldnames=TABLE44_COLUMNS, extrasaction="raise")
        w.writeheader()
        for row in rows:
            w.writerow({k: (f"{v:.6g}" if isinstance(v, float) else v) for k, v in row.items()})
    return path

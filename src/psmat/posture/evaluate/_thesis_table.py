"""The thesis' posture result (Table 4.4, §4.4), transcribed once so the
report, the notebook and the docs quote the same numbers.

MSE is over all six outputs (rad², the loss of eq. 4.2); R² per output (eq. 4.3): the five IMU
pitch angles, sensor 0 the cervical one, and their sum. KSI: the same 12 volunteers in training,
validation and test (random 70/10/20 of stride-1 windows, which leak: neighbouring windows share
49 of 50 frames); LSO: P1-P8 train, P9 validation, P10-P12 test (Table 4.3).
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["Table44Row", "TABLE_4_4"]


@dataclass(frozen=True)
class Table44Row:
    """One row of thesis Table 4.4."""

    split: str  # "ksi-leaky" (the thesis' KSI) or "lso"
    subset: str  # "validation" or "test"
    mse: float  # rad², all outputs
    r2: tuple[float, ...]  # per output, in the order of OUTPUTS (psmat.posture.evaluate)


TABLE_4_4: tuple[Table44Row, ...] = (
    Table44Row("ksi-leaky", "validation", 0.036, (0.920, 0.807, 0.764, 0.860, 0.835, 0.881)),
    Table44Row("ksi-leaky", "test", 0.053, (0.913, 0.783, 0.767, 0.848, 0.793, 0.875)),
    Table44Row("lso", "validation", 0.319, (0.184, 0.411, -0.372, 0.202, -1.025, 0.310)),
    Table44Row("lso", "test", 0.428, (0.248, 0.411, -0.073, -0.004, -2.446, 0.253)),
)

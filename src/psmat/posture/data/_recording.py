"""One posture recording ready for learning: the cushion's image and the spine's angles on one time base.

A :class:`Recording` is what :func:`psmat.posture.data.load_posture_study` makes of one session
(crosstalk removed, the mat resampled to the IMU rate, docs/spec.md §8) and what the learning pipeline
(:func:`psmat.posture.learn.train_posture`) consumes.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = ["Recording"]


@dataclass(eq=False)
class Recording:
    """The cushion image and the five pitch angles of one session, sample by sample.

    Attributes
    ----------
    subject : str
        Subject id (``subjects.csv``).
    day : int
        Day of the recording (1, 2, 3 in the thesis protocol).
    t_s : ndarray, (T,) float64
        Sample times in s (the IMU's, on the host clock), increasing.
    image : ndarray, (T, R, C) float32
        Crosstalk-free cell conductance g (S) averaged over each IMU sample (thesis §4.3:
        "conductance ... processed to remove crosstalk and subsampled to the sampling
        frequency of the spine measurement device"); the thesis takes it as proportional to
        pressure.
    angles_rad : ndarray, (T, 5) float64
        Pitch of the five spine IMUs (rad), sensor 1 the cervical one (docs/spec.md §8).
    meta : dict
        Where it came from (session path, alignment lag, rates, ...).
    """

    subject: str
    day: int
    t_s: NDArray[np.float64]
    image: NDArray[np.float32]
    angles_rad: NDArray[np.float64]
    meta: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        self.t_s = np.asarray(self.t_s, dtype=np.float64)
        self.image = np.asarray(self.image, dtype=np.float32)
        self.angles_rad = np.asarray(self.angles_rad, dtype=np.float64)
        T = self.t_s.shape[0]
        if self.t_s.ndim != 1 or self.image.ndim != 3 or self.image.shape[0] != T:
            raise ValueError(f"image must be (T, R, C) with T = len(t_s) = {T}, got {self.image.shape}")
        if self.angles_rad.shape != (T, 5):
            raise ValueError(f"angles_rad must be (T, 5) with T = {T}, got {self.angles_rad.shape}")

    @property
    def n_samples(self) -> int:
        return int(self.t_s.shape[0])

    @property
    def targets(self) -> NDArray[np.float64]:
        """The network's six outputs per sample (docs/spec.md §8): the five angles and their sum (rad)."""
        return np.concatenate([self.angles_rad, self.angles_rad.sum(axis=1, keepdims=True)], axis=1)

"""Posture (thesis chapter 4, docs/spec.md §8): the spine's shape from the back IMUs, and learning it
from the cushion's pressure.

* :func:`spine_points` is eq. 4.4 (chained circular arcs, sensor 1 at the origin; its home is
  :mod:`psmat.spine`, the one home of the back device's geometry); :func:`plot_spine` draws the
  spine over time (Fig. 4.8).
* :mod:`psmat.posture.data` — a study folder → :class:`Recording` per session
  (:func:`load_posture_study`), a mat and IMUs recorded apart aligned (:func:`align_mat_imu`),
  windows, splits, augmentation, subject-invariant inputs.
* :mod:`psmat.posture.evaluate` — MSE and R² (Table 4.4), the thesis' table, the ridge-PCA
  baseline, held-out subjects' calibration, figures.
* :mod:`psmat.posture.learn` — the CNN of §4.3, its training (``train_posture``), fine-tuning and
  held-out subjects (``heldout_study``); needs PyTorch (``psmat[posture]``), which
  ``import psmat.posture`` never imports.

A simulated posture study comes from :func:`psmat.synth.simulate_posture_study`.
"""

from ..spine import N_SENSORS, SPACING_MM, spine_points
from ._plots import plot_spine
from .data import (NO_IMU, SPLIT_NAMES, MatImuAlignment, PostureStudy, Recording, align_mat_imu, load_posture_study,
                   session_recording)
from .evaluate import TABLE_4_4

__all__ = ["spine_points", "N_SENSORS", "SPACING_MM", "plot_spine", "load_posture_study", "session_recording",
           "PostureStudy", "Recording", "NO_IMU", "align_mat_imu", "MatImuAlignment", "SPLIT_NAMES", "TABLE_4_4"]

"""Posture data (thesis §4.3, docs/spec.md §8): from a study folder to the windows a model learns from.

Numpy and scipy only (no PyTorch). Private modules, one concept each:

* ``_study`` — a posture study folder → one :class:`Recording` per session
  (:func:`load_posture_study`, :func:`session_recording`): the mat through the processing chain,
  averaged over each IMU sample (``_resample``, :func:`mean_over_samples`), cached per session
  (``_input_cache``);
* ``_align`` — a mat and IMUs recorded apart aligned by their summed signals (Fig. 4.11,
  :func:`align_mat_imu`; its figure in ``_align_plot``);
* ``_recording`` — :class:`Recording`, the cushion's image and the spine's angles on one time base;
* ``_windows`` — windows of 50 frames, their targets and the standardisation;
* ``_splits`` — the KSI and LSO splits (Table 4.3);
* ``_augment`` — the augmentation of a training window;
* ``_invariant`` — subject-invariant inputs for held-out subjects (beyond the thesis).
"""

from ._align import MatImuAlignment, align_mat_imu, summed_mat_at_rate
from ._align_plot import plot_mat_imu_alignment
from ._augment import BLUR_SIGMA_CELLS, MAX_ROTATION_DEG, MAX_SHIFT_CELLS, SCALES, augment_window
from ._input_cache import cache_digest, read_cached, write_cached
from ._invariant import (CENTRES, Reference, calibration_frames, cop_cells, invariant_features, invariant_images,
                         invariant_recording, session_reference, window_means)
from ._recording import Recording
from ._resample import mean_over_samples
from ._splits import (FRACTIONS, SPLIT_NAMES, SPLITS, SUBSETS, Split, ksi_leaky_split, ksi_split, lso_split,
                      lso_subjects, make_split)
from ._study import DEFAULT_PARAMS, NO_IMU, PostureStudy, load_posture_study, session_recording
from ._windows import WINDOW, Standardiser, WindowTargets, all_windows, frame_masks, window_image

__all__ = [
    # a study folder
    "load_posture_study", "session_recording", "PostureStudy", "DEFAULT_PARAMS", "NO_IMU", "mean_over_samples",
    "read_cached", "write_cached", "cache_digest",
    # recorded apart
    "MatImuAlignment", "align_mat_imu", "summed_mat_at_rate", "plot_mat_imu_alignment",
    # recordings, windows, splits
    "Recording", "WINDOW", "all_windows", "window_image", "WindowTargets", "frame_masks", "Standardiser",
    "SUBSETS", "FRACTIONS", "SPLITS", "SPLIT_NAMES", "Split", "ksi_split", "ksi_leaky_split", "lso_subjects",
    "lso_split", "make_split",
    # augmentation
    "MAX_ROTATION_DEG", "MAX_SHIFT_CELLS", "SCALES", "BLUR_SIGMA_CELLS", "augment_window",
    # subject-invariant inputs
    "CENTRES", "Reference", "calibration_frames", "cop_cells", "session_reference", "invariant_images",
    "invariant_recording", "invariant_features", "window_means",
]

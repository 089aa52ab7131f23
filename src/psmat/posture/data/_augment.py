"""Augmentation of a training window (thesis §4.3), the same transform for all its frames.

Each operation is applied with probability ½, in this order, on the raw conductance (S; the
empty mat is 0, so cells moved in from outside the mat are 0):

* lateral flip: columns reversed (columns are M-L, docs/spec.md §7);
* rotation by an angle uniform in ±15° about the mat's centre (bilinear);
* shift by whole cells, uniform in ±5 rows and ±5 columns;
* scale of the values by ½ or 2. The thesis says the augmented image "is proportional to the
  original": the factor scales the amplitude, not the geometry. It stands for the sitter's
  weight and the mat's unknown conductance scale (chapter 3's f); a ×2 zoom of a seat print
  would leave a 16×16 mat and a ×½ one shrink a pelvis to half, which no sitter produces;
* Gaussian blur, σ uniform in [0.5, 1] cell.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage

__all__ = ["MAX_ROTATION_DEG", "MAX_SHIFT_CELLS", "SCALES", "BLUR_SIGMA_CELLS", "augment_window"]

MAX_ROTATION_DEG = 15.0
MAX_SHIFT_CELLS = 5
SCALES = (0.5, 2.0)
BLUR_SIGMA_CELLS = (0.5, 1.0)
P_APPLY = 0.5


def augment_window(window: NDArray[np.float32], rng: np.random.Generator) -> NDArray[np.float32]:
    """A randomly transformed copy of one window.

    Parameters
    ----------
    window : ndarray, (W, R, C) float32
        The window's images (S); not modified.
    rng : numpy.random.Generator
        Source of the random choices.

    Returns
    -------
    ndarray, (W, R, C) float32
    """
    x = np.array(window, dtype=np.float32)
    if rng.random() < P_APPLY:
        x = x[:, :, ::-1]
    if rng.random() < P_APPLY:
        angle = rng.uniform(-MAX_ROTATION_DEG, MAX_ROTATION_DEG)
        x = ndimage.rotate(x, angle, axes=(2, 1), reshape=False, order=1, mode="constant", cval=0.0)
    if rng.random() < P_APPLY:
        dr, dc = rng.integers(-MAX_SHIFT_CELLS, MAX_SHIFT_CELLS + 1, size=2)
        x = ndimage.shift(x, (0, int(dr), int(dc)), order=0, mode="constant", cval=0.0)
    if rng.random() < P_APPLY:
        x = x * np.float32(SCALES[int(rng.integers(len(SCALES)))])
    if rng.random() < P_APPLY:
        s = rng.uniform(*BLUR_SIGMA_CELLS)
        x = ndimage.gaussian_filter(x, sigma=(0.0, s, s), mode="constant", cval=0.0)
    return np.ascontiguousarray(x, dtype=np.float32)

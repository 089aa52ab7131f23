"""Windows of a posture recording (thesis §4.3, docs/spec.md §8): 50 frames at stride 1, never copied.

A window is named by ``(recording, first frame)``; its image is a slice (a view) of the
recording's ``(T, R, C)`` array, its target the mean over its frames of the six outputs
(the thesis: the network "must be able to reconstruct the temporal average value of each of
the angles"). Standardisation is the thesis': one mean and one SD over all the cells of the
training images, each training frame counted once however many windows contain it.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ..._checks import positive_int
from ._recording import Recording

__all__ = ["WINDOW", "all_windows", "window_image", "WindowTargets", "frame_masks", "Standardiser"]

#: Frames per window (thesis §4.3: 50 at the IMU's 10 Hz, 5 s).
WINDOW = 50


def all_windows(recordings: Sequence[Recording], window: int = WINDOW, *,
                which: Sequence[int] | None = None) -> NDArray[np.int64]:
    """Every stride-1 window of the recordings, ``(N, 2)`` rows of (recording index, first frame).

    Parameters
    ----------
    recordings : sequence of Recording
    window : int
        Frames per window.
    which : sequence of int, optional
        Indices of the recordings to take (all by default).
    """
    window = positive_int("window", window)
    idx = range(len(recordings)) if which is None else which
    rows = [np.stack([np.full(n, r), np.arange(n)], axis=1)
            for r in idx if (n := recordings[r].n_samples - window + 1) > 0]
    return np.concatenate(rows).astype(np.int64) if rows else np.empty((0, 2), np.int64)


def window_image(recordings: Sequence[Recording], row: Sequence[int], window: int = WINDOW) -> NDArray[np.float32]:
    """The ``(window, R, C)`` images of one window: a view into the recording, not a copy."""
    r, s = int(row[0]), int(row[1])
    return recordings[r].image[s:s + window]


class WindowTargets:
    """Window means of the six outputs (5 angles and their sum, rad) in O(1) per window.

    Holds one cumulative sum ``(T + 1, 6)`` per recording (float64).
    """

    def __init__(self, recordings: Sequence[Recording], window: int = WINDOW) -> None:
        self.window = positive_int("window", window)
        self._cum = [np.concatenate([np.zeros((1, 6)), np.cumsum(rec.targets, axis=0)]) for rec in recordings]

    def __call__(self, windows: NDArray[np.int64]) -> NDArray[np.float64]:
        """Targets ``(N, 6)`` of the windows ``(N, 2)``."""
        out = np.empty((len(windows), 6))
        for r in np.unique(windows[:, 0]) if len(windows) else ():
            sel = windows[:, 0] == r
            s = windows[sel, 1]
            out[sel] = (self._cum[r][s + self.window] - self._cum[r][s]) / self.window
        return out


def frame_masks(recordings: Sequence[Recording], windows: NDArray[np.int64],
                window: int = WINDOW) -> list[NDArray[np.bool_]]:
    """Per recording, which frames the windows ``(N, 2)`` cover (``(T,)`` bool each)."""
    masks = []
    for r, rec in enumerate(recordings):
        # +1 at each window's start, -1 past its end; covered where the running count > 0
        d = np.zeros(rec.n_samples + 1, np.int64)
        s = windows[windows[:, 0] == r, 1]
        np.add.at(d, s, 1)
        np.add.at(d, s + window, -1)
        masks.append(np.cumsum(d[:-1]) > 0)
    return masks


@dataclass(frozen=True)
class Standardiser:
    """``(x - mean) / sd`` with one mean and SD (S) of all cells of the training images (thesis §4.3)."""

    mean: float
    sd: float

    @classmethod
    def fit(cls, recordings: Sequence[Recording], windows: NDArray[np.int64], window: int = WINDOW) -> Standardiser:
        """Statistics of the frames the training windows cover, each frame once."""
        n, s1, s2 = 0, 0.0, 0.0
        for rec, m in zip(recordings, frame_masks(recordings, windows, window)):
            if m.any():
                x = rec.image[m].astype(np.float64)
                n, s1, s2 = n + x.size, s1 + x.sum(), s2 + np.square(x).sum()
        if n == 0:
            raise ValueError("no training frames to standardise with")
        mean = s1 / n
        sd = float(np.sqrt(max(s2 / n - mean * mean, 0.0)))
        if not sd > 0:
            raise ValueError("training images are constant: their SD is 0")
        return cls(float(mean), sd)

    def __call__(self, x: NDArray[np.float32]) -> NDArray[np.float32]:
        return ((x - np.float32(self.mean)) / np.float32(self.sd)).astype(np.float32, copy=False)

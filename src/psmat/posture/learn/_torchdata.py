"""The windows as a PyTorch Dataset, built lazily from the recordings' image arrays.

Item ``i`` slices frames ``[s, s + W)`` of its recording (a view), augments it when asked
(:func:`psmat.posture.data.augment_window`), standardises it and returns ``(1, W, R·C)`` float32 (docs/spec.md §8:
a ``50 × (R·C)`` input) with the window's six mean targets. Nothing of size ``N × W`` is held.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from ..data import Recording, Standardiser, WindowTargets, augment_window, window_image
from ._torch import torch

__all__ = ["WindowDataset"]


class WindowDataset(torch.utils.data.Dataset):
    """Windows ``(N, 2)`` (recording, first frame) of ``recordings``.

    Parameters
    ----------
    recordings : sequence of Recording
    windows : ndarray, (N, 2) int
        Rows (recording index, first frame), e.g. one subset of a :class:`~psmat.posture.data.Split`.
    window : int
        Frames per window.
    standardiser : Standardiser
        Training-set statistics.
    augment : bool
        Transform each window (training only).
    seed : int
        Seed of the augmentation; item ``i`` of epoch ``e`` draws from ``default_rng([seed, e, i])``,
        so an item's transform does not depend on the order it is asked in (resumable).
    """

    def __init__(self, recordings: Sequence[Recording], windows: NDArray[np.int64], window: int,
                 standardiser: Standardiser, *, augment: bool = False, seed: int = 0) -> None:
        self.recordings = recordings
        self.windows = np.asarray(windows, dtype=np.int64).reshape(-1, 2)
        self.window = int(window)
        self.standardiser = standardiser
        self.augment = bool(augment)
        self.seed = int(seed)
        self.epoch = 0
        self.targets = WindowTargets(recordings, window)(self.windows).astype(np.float32)

    def __len__(self) -> int:
        return int(self.windows.shape[0])

    def __getitem__(self, i: int) -> tuple[torch.Tensor, torch.Tensor]:
        x = window_image(self.recordings, self.windows[i], self.window)
        if self.augment:
            x = augment_window(x, np.random.default_rng([self.seed, self.epoch, int(i)]))
        x = self.standardiser(x)
        return torch.from_numpy(x.reshape(1, self.window, -1)), torch.from_numpy(self.targets[i])

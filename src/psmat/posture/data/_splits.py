"""Training, validation and test windows (thesis §4.3, Table 4.3; docs/spec.md §8).

* ``"ksi"`` (Keep Subjects In, without leakage): each recording's time is cut into three
  contiguous blocks of 70/10/20 %; a window belongs to a set only when all its frames lie in
  that set's block, so no frame, and so no window, is shared between sets. The validation and
  test blocks sit side by side at a seeded random place in each recording (the training block is
  what is left before and after them), so that over the recordings every phase of the protocol
  is tested.
* ``"ksi-leaky"``: the thesis' split, a random 70/10/20 % of all stride-1 windows. A test window
  shares up to 49 of its 50 frames with training windows; kept to measure that leak.
* ``"lso"`` (Leave Subjects Out): whole subjects per set in the thesis' proportions (Table 4.3:
  8 train, 1 validation, 3 test of 12), i.e. ``round(N/4)`` test and ``round(N/12)`` validation
  subjects (at least one each), the rest training.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ..._checks import fraction
from ._recording import Recording
from ._windows import WINDOW, all_windows

__all__ = ["SUBSETS", "FRACTIONS", "SPLITS", "SPLIT_NAMES", "Split", "ksi_split", "ksi_leaky_split", "lso_subjects",
           "lso_split", "make_split"]

SUBSETS = ("train", "validation", "test")
#: Thesis §4.3: 70 % training, 10 % validation, 20 % test.
FRACTIONS = (0.7, 0.1, 0.2)
SPLITS = ("ksi", "ksi-leaky", "lso")
#: Each split spelled out for a figure or a report (thesis §4.3, Table 4.3).
SPLIT_NAMES = {
    "ksi": "KSI (Keep Subjects In: the same subjects in every set), contiguous blocks of each session",
    "ksi-leaky": "KSI (Keep Subjects In: the same subjects in every set) as in the thesis, random windows "
                 "that share frames across sets",
    "lso": "LSO (Leave Subjects Out: the validation and test subjects are not in training)",
}


@dataclass(frozen=True)
class Split:
    """Windows of each subset.

    Attributes
    ----------
    name : str
        ``"ksi"``, ``"ksi-leaky"`` or ``"lso"``.
    windows : dict of str to ndarray
        ``"train"``, ``"validation"``, ``"test"``: ``(N, 2)`` int64 rows (recording index, first frame).
    subjects : dict of str to tuple of str
        Subjects present in each subset.
    window : int
        Frames per window.
    """

    name: str
    windows: dict[str, NDArray[np.int64]]
    subjects: dict[str, tuple[str, ...]]
    window: int


def _subjects(recordings: Sequence[Recording], windows: dict[str, NDArray[np.int64]]) -> dict[str, tuple[str, ...]]:
    return {k: tuple(sorted({recordings[r].subject for r in np.unique(w[:, 0])})) for k, w in windows.items()}


def _check_fractions(fractions: Sequence[float]) -> tuple[float, float, float]:
    if len(fractions) != 3:
        raise ValueError(f"fractions must be (train, validation, test), got {tuple(fractions)}")
    f = tuple(fraction(f"fractions[{i}]", x) for i, x in enumerate(fractions))
    if not math.isclose(sum(f), 1.0):
        raise ValueError(f"fractions must add up to 1, got {sum(f)}")
    return f  # type: ignore[return-value]


def _block(r: int, lo: int, hi: int, window: int) -> NDArray[np.int64]:
    # Windows wholly inside frames [lo, hi)
    s = np.arange(lo, hi - window + 1, dtype=np.int64)
    return np.stack([np.full_like(s, r), s], axis=1)


def ksi_split(recordings: Sequence[Recording], *, window: int = WINDOW, fractions: Sequence[float] = FRACTIONS,
              seed: int = 0) -> Split:
    """KSI in contiguous blocks per recording (no frame in two sets); see the module note."""
    f = _check_fractions(fractions)
    rng = np.random.default_rng(seed)
    parts: dict[str, list[NDArray[np.int64]]] = {k: [] for k in SUBSETS}
    for r, rec in enumerate(recordings):
        T = rec.n_samples
        n_val, n_test = round(f[1] * T), round(f[2] * T)
        for name, n in (("validation", n_val), ("test", n_test), ("train", T - n_val - n_test)):
            if n < window:
                raise ValueError(f"recording {r} ({rec.subject} day {rec.day}): its {name} block has {n} frames, "
                                 f"fewer than one window of {window}")
        lo = int(rng.integers(0, T - n_val - n_test + 1))
        first, second = (("validation", n_val), ("test", n_test)) if rng.random() < 0.5 else \
            (("test", n_test), ("validation", n_val))
        parts[first[0]].append(_block(r, lo, lo + first[1], window))
        parts[second[0]].append(_block(r, lo + first[1], lo + n_val + n_test, window))
        parts["train"] += [_block(r, 0, lo, window), _block(r, lo + n_val + n_test, T, window)]
    windows = {k: np.concatenate(v) if v else np.empty((0, 2), np.int64) for k, v in parts.items()}
    return Split("ksi", windows, _subjects(recordings, windows), window)


def ksi_leaky_split(recordings: Sequence[Recording], *, window: int = WINDOW, fractions: Sequence[float] = FRACTIONS,
                    seed: int = 0) -> Split:
    """The thesis' KSI: a seeded random 70/10/20 % of all stride-1 windows (leaks; see the module note)."""
    f = _check_fractions(fractions)
    w = all_windows(recordings, window)
    order = np.random.default_rng(seed).permutation(len(w))
    n_train, n_val = round(f[0] * len(w)), round(f[1] * len(w))
    cut = {"train": order[:n_train], "validation": order[n_train:n_train + n_val], "test": order[n_train + n_val:]}
    windows = {k: w[np.sort(v)] for k, v in cut.items()}
    return Split("ksi-leaky", windows, _subjects(recordings, windows), window)


def lso_subjects(subjects: Sequence[str], seed: int | None = None) -> dict[str, tuple[str, ...]]:
    """Subjects of each LSO set in the thesis' proportions (Table 4.3).

    Parameters
    ----------
    subjects : sequence of str
        Subject ids (duplicates ignored); at least 3.
    seed : int or None
        None: the sorted ids in order, training first (P01-P08, P09, P10-P12 for twelve
        subjects, as Table 4.3); an int: a seeded random choice.
    """
    ids = sorted(set(subjects))
    n = len(ids)
    if n < 3:
        raise ValueError(f"LSO needs at least 3 subjects (train, validation, test), got {n}")
    n_test = max(1, math.floor(n * 3 / 12 + 0.5))
    n_val = max(1, math.floor(n / 12 + 0.5))
    if seed is not None:
        ids = [ids[i] for i in np.random.default_rng(seed).permutation(n)]
    n_train = n - n_val - n_test
    return {"train": tuple(sorted(ids[:n_train])), "validation": tuple(sorted(ids[n_train:n_train + n_val])),
            "test": tuple(sorted(ids[n_train + n_val:]))}


def lso_split(recordings: Sequence[Recording], *, window: int = WINDOW, seed: int | None = None) -> Split:
    """LSO: every window of a subject's recordings in that subject's set (:func:`lso_subjects`)."""
    sets = lso_subjects([rec.subject for rec in recordings], seed)
    windows = {k: all_windows(recordings, window, which=[r for r, rec in enumerate(recordings) if rec.subject in ids])
               for k, ids in sets.items()}
    return Split("lso", windows, _subjects(recordings, windows), window)


def make_split(name: str, recordings: Sequence[Recording], *, window: int = WINDOW, seed: int = 0,
               lso_seed: int | None = None) -> Split:
    """The split called ``name`` (one of :data:`SPLITS`)."""
    if name == "ksi":
        return ksi_split(recordings, window=window, seed=seed)
    if name == "ksi-leaky":
        return ksi_leaky_split(recordings, window=window, seed=seed)
    if name == "lso":
        return lso_split(recordings, window=window, seed=lso_seed)
    raise ValueError(f"split must be one of {', '.join(SPLITS)}, got {name!r}")

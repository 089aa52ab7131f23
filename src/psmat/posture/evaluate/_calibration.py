"""A new subject's calibration phase and the windows scored after it (beyond the thesis); numpy only.

Every session of the thesis' protocol opens with ``calibration_s`` = 30 s sitting with a straight
back (§4.3). For a held-out subject that phase is the calibration (the thesis' own suggestion,
§4.4: "a kind of calibration stage would be required"): its windows may adapt a model, and only
the windows after it are scored — a scored window starts at or after the phase's end, so none
shares a frame with the calibration (:func:`heldout_windows`). Every model of
:func:`psmat.posture.learn.heldout_study` is scored on those same windows.

The ridge baseline's calibration (:func:`ridge_variants`) is an offset: the subject's mean
residual over their calibration windows (measured minus predicted angles, rad) added to the
predictions of their scored windows — what a mounting offset of the IMUs or a person's own
straight-back curvature would call for.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ..data import Recording, Split, Standardiser, WindowTargets, calibration_frames, invariant_features, window_means
from ._baseline import RidgePCA, fit_ridge_pca, window_mean_images

__all__ = ["HeldoutWindows", "heldout_windows", "offsets_from_calibration", "apply_offsets", "ridge_variants"]


@dataclass(frozen=True)
class HeldoutWindows:
    """Windows of the held-out subjects of an LSO split, cut at each session's calibration phase.

    Attributes
    ----------
    scored : dict of str to ndarray
        ``"validation"``, ``"test"``: ``(N, 2)`` (recording, first frame) rows of the windows that
        start at or after the end of their session's calibration phase.
    calibration : dict of str to ndarray
        The same subsets' windows lying wholly inside the calibration phase.
    n_calibration : list of int
        Samples of each recording's calibration phase.
    """

    scored: dict[str, NDArray[np.int64]]
    calibration: dict[str, NDArray[np.int64]]
    n_calibration: list[int]


def _rows(r: int, lo: int, hi: int) -> NDArray[np.int64]:
    s = np.arange(lo, hi, dtype=np.int64)
    return np.stack([np.full_like(s, r), s], axis=1)


def heldout_windows(recordings: Sequence[Recording], split: Split, calibration_s: float) -> HeldoutWindows:
    """Calibration and scored windows of the validation and test subjects of ``split``.

    Raises
    ------
    ValueError
        When a held-out session's calibration phase is shorter than one window, or nothing of it
        is left after the phase.
    """
    W = split.window
    n_cal = [calibration_frames(rec, calibration_s) for rec in recordings]
    scored: dict[str, NDArray[np.int64]] = {}
    calib: dict[str, NDArray[np.int64]] = {}
    for subset in ("validation", "test"):
        s_rows, c_rows = [], []
        for r, rec in enumerate(recordings):
            if rec.subject not in split.subjects[subset]:
                continue
            if n_cal[r] < W:
                raise ValueError(f"{rec.subject} day {rec.day}: its first {calibration_s:g} s hold {n_cal[r]} "
                                 f"samples, fewer than one window of {W}")
            if rec.n_samples - W < n_cal[r]:
                raise ValueError(f"{rec.subject} day {rec.day}: no window of {W} samples after its first "
                                 f"{calibration_s:g} s ({rec.n_samples} samples in all)")
            c_rows.append(_rows(r, 0, n_cal[r] - W + 1))
            s_rows.append(_rows(r, n_cal[r], rec.n_samples - W + 1))
        scored[subset] = np.concatenate(s_rows) if s_rows else np.empty((0, 2), np.int64)
        calib[subset] = np.concatenate(c_rows) if c_rows else np.empty((0, 2), np.int64)
    return HeldoutWindows(scored, calib, n_cal)


def offsets_from_calibration(recordings: Sequence[Recording], calibration: NDArray[np.int64],
                             residuals: NDArray[np.float64]) -> dict[str, NDArray[np.float64]]:
    """Mean residual (measured − predicted, rad; ``(6,)``) of each subject over their calibration windows."""
    subj = np.array([recordings[r].subject for r in calibration[:, 0]])
    return {s: residuals[subj == s].mean(axis=0) for s in np.unique(subj)}


def apply_offsets(recordings: Sequence[Recording], windows: NDArray[np.int64], pred: NDArray[np.float64],
                   offsets: dict[str, NDArray[np.float64]]) -> NDArray[np.float64]:
    """``pred`` with each subject's offset (:func:`offsets_from_calibration`) added to their windows' rows."""
    out = pred.copy()
    subj = np.array([recordings[r].subject for r in windows[:, 0]])
    for s, o in offsets.items():
        out[subj == s] += o
    return out


def _standardise_columns(x: dict[str, NDArray[np.float64]]) -> dict[str, NDArray[np.float64]]:
    # z-score each feature with the training windows' mean and SD (the features have different units)
    mu, sd = x["train"].mean(axis=0), x["train"].std(axis=0)
    sd = np.where(sd > 0, sd, 1.0)
    return {k: (v - mu) / sd for k, v in x.items()}


def ridge_variants(recordings: Sequence[Recording], invariant: Sequence[Recording], split: Split,
                   held: HeldoutWindows, calibration_s: float, *, calibrated_suffix: str
                   ) -> tuple[dict[str, RidgePCA], dict[str, dict[str, NDArray[np.float64]]]]:
    """The ridge-on-PCA baseline on three inputs, uncalibrated and offset-calibrated.

    Parameters
    ----------
    recordings, invariant : sequence of Recording
        The study as measured and as :func:`~psmat.posture.data.invariant_recording` made it.
    split : Split
        LSO split: the models are fitted on its training windows, ``k`` and the penalty chosen on
        all its validation windows (:func:`~psmat.posture.evaluate.fit_ridge_pca`).
    held : HeldoutWindows
    calibration_s : float
        Length of the calibration phase (s), for the invariant features' reference.
    calibrated_suffix : str
        Appended to a model's name for its calibrated variant (e.g. ``" calibrated 30 s"``).

    Returns
    -------
    models : dict of str to RidgePCA
        ``"ridge-PCA"`` (window-mean raw image), ``"ridge-PCA invariant"`` (window-mean invariant
        image), ``"ridge-PCA invariant features"`` (window-mean invariant features).
    predictions : dict of str to dict of str to ndarray
        Per model name (the three and their calibrated variants) and subset (``"validation"``,
        ``"test"`` for the uncalibrated ones, ``"test"`` for the calibrated), ``(N, 6)`` rad on
        ``held.scored[subset]``.
    """
    W = split.window
    sets = {"train": split.windows["train"], "validation": split.windows["validation"],
            "validation_scored": held.scored["validation"], "test": held.scored["test"],
            "calibration": held.calibration["test"]}
    targets = WindowTargets(recordings, W)
    y = {k: targets(v) for k, v in sets.items()}
    feats = [invariant_features(rec, calibration_s) for rec in recordings]
    inputs = {
        "ridge-PCA": ({k: window_mean_images(recordings, v, W) for k, v in sets.items()},
                      Standardiser.fit(recordings, sets["train"], W).sd),
        "ridge-PCA invariant": ({k: window_mean_images(invariant, v, W) for k, v in sets.items()},
                                Standardiser.fit(invariant, sets["train"], W).sd),
        "ridge-PCA invariant features": (_standardise_columns({k: window_means(feats, v, W)
                                                                for k, v in sets.items()}), 1.0),
    }
    models: dict[str, RidgePCA] = {}
    preds: dict[str, dict[str, NDArray[np.float64]]] = {}
    for name, (x, sd) in inputs.items():
        m = fit_ridge_pca(x["train"], y["train"], x["validation"], y["validation"], sd=sd)
        models[name] = m
        preds[name] = {"validation": m.predict(x["validation_scored"]), "test": m.predict(x["test"])}
        offsets = offsets_from_calibration(recordings, sets["calibration"],
                                           y["calibration"] - m.predict(x["calibration"]))
        preds[name + calibrated_suffix] = {"test": apply_offsets(recordings, sets["test"], preds[name]["test"],
                                                                  offsets)}
    return models, preds

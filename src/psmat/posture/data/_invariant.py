"""Subject-invariant inputs for held-out subjects (beyond the thesis): numpy and scipy only.

A new person differs from the training subjects in weight (the whole image scales with it, and
with the mat's unknown conductance scale, chapter 3's f) and in where they sit on the cushion
(the whole print moves). Both are removed per session, against the session's **reference**: the
frames of its first ``calibration_s`` seconds, which the thesis' protocol spends sitting with a
straight back (§4.3). Only the mat's images of that phase are used, never its angles: a new
subject needs no IMU for these inputs, only to start a session sitting straight. The phase, not
the whole session's mean, is the reference: it is known as soon as the phase ends (live use),
and it is the same posture in every session, whereas a session's mean depends on how much of it
is spent leaning forward (thighs) or back (sacrum).

* :func:`invariant_images` (the CNN's and the ridge-PCA's invariant input): each image divided by
  the reference's mean total conductance Σg (weight), then moved by a sub-cell bilinear shift
  (:func:`scipy.ndimage.shift`, order 1, ``grid-constant``: zeros coming in, interpolated
  like any other cell) that puts the reference's centre of
  pressure on the mat's centre (seat position). ``centre="session"`` (the default) shifts the
  whole session by one vector, so the print's motion *relative to the straight-back seat* —
  the CoP running forward as the person leans forward, the thesis' main cue — is kept;
  ``centre="frame"`` re-centres every image on its own CoP, removing that motion too and
  leaving only the print's shape. Both are exactly invariant to a whole-cell move of the seat
  and to a scale of the image (:func:`~psmat.posture.data.invariant_images` docs).
  Measured with the ridge-on-PCA baseline on a 12-subject × 3-day study of ``psmat posture
  simulate`` (LSO test subjects P10-P12, windows after the first 30 s; simulation):
  test MSE 0.369 rad² on the raw image, 0.0165 with ``"session"``, 0.0317 with ``"frame"``
  (R² of the five angles 0.81-0.91 and 0.63-0.91) — hence the default.
* :func:`invariant_features` (the ridge model's hand features), per frame, each invariant to
  weight and seat position by construction: the CoP relative to the reference CoP (2, cells),
  the second central moments of the frame's print (3, cells²), the frame's total relative to
  the reference total (1; thighs and back take load off the cushion), and the load share of
  each row and each column of the session-centred image (R + C; front/back and left/right
  load shares, each normalised by the frame's total).

Cells are indexed (row, column); rows are A-P, columns M-L (docs/spec.md §7).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Literal

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage

from ..._checks import positive
from ._recording import Recording

__all__ = ["CENTRES", "Reference", "calibration_frames", "cop_cells", "session_reference", "invariant_images",
           "invariant_recording", "invariant_features", "window_means"]

CENTRES = ("session", "frame")


@dataclass(frozen=True)
class Reference:
    """What a session's straight-back phase says about the sitter and the seat.

    Attributes
    ----------
    total : float
        Mean over the phase's frames of the image's total Σg (S).
    cop_cells : ndarray, (2,)
        Centre of pressure (row, column; in cells) of the phase's summed image.
    """

    total: float
    cop_cells: NDArray[np.float64]


def calibration_frames(rec: Recording, calibration_s: float) -> int:
    """Number of samples in the first ``calibration_s`` seconds of a recording (``t - t[0] < calibration_s``)."""
    calibration_s = positive("calibration_s", calibration_s)
    return int(np.searchsorted(rec.t_s - rec.t_s[0], calibration_s, side="left"))


def cop_cells(images: NDArray[np.floating]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Centre of pressure of each image in cells and its total.

    Parameters
    ----------
    images : ndarray, (T, R, C)
        Conductance (S), taken as proportional to pressure (thesis §4.3).

    Returns
    -------
    cop : ndarray, (T, 2)
        (row, column) of Σ g·index / Σ g; the mat's centre where Σ g = 0.
    total : ndarray, (T,)
        Σ g (S).
    """
    x = np.asarray(images, dtype=np.float64)
    R, C = x.shape[1:]
    total = x.sum(axis=(1, 2))
    rows, cols = x.sum(axis=2) @ np.arange(R), x.sum(axis=1) @ np.arange(C)
    ok = total > 0
    cop = np.tile([(R - 1) / 2, (C - 1) / 2], (len(x), 1))
    cop[ok] = np.stack([rows[ok], cols[ok]], axis=1) / total[ok, None]
    return cop, total


def session_reference(rec: Recording, calibration_s: float) -> Reference:
    """The :class:`Reference` of a recording from its first ``calibration_s`` seconds."""
    n = calibration_frames(rec, calibration_s)
    if n == 0:
        raise ValueError(f"{rec.subject} day {rec.day}: no sample in the first {calibration_s} s")
    phase = rec.image[:n].astype(np.float64)
    total = float(phase.sum(axis=(1, 2)).mean())
    if not total > 0:
        raise ValueError(f"{rec.subject} day {rec.day}: the mat reads nothing in the first {calibration_s} s "
                         "(no reference for the invariant inputs)")
    cop, _ = cop_cells(phase.sum(axis=0)[None])
    return Reference(total, cop[0])


def _shift(img: NDArray[np.float64], by: NDArray[np.float64]) -> NDArray[np.float64]:
    # bilinear sub-cell move of one (R, C) image; cells moved in from outside the mat are 0
    return ndimage.shift(img, by, order=1, mode="grid-constant", cval=0.0, prefilter=False)


def invariant_images(images: NDArray[np.floating], ref: Reference, *,
                     centre: Literal["session", "frame"] = "session") -> NDArray[np.float32]:
    """Images divided by the reference total and moved so the chosen CoP sits on the mat's centre.

    Parameters
    ----------
    images : ndarray, (T, R, C)
        Conductance (S).
    ref : Reference
        The session's straight-back reference (:func:`session_reference`).
    centre : {"session", "frame"}
        ``"session"``: every image moved by the one vector that puts ``ref.cop_cells`` on the centre;
        ``"frame"``: each image moved so its own CoP is on the centre.

    Returns
    -------
    ndarray, (T, R, C) float32
        Dimensionless (units of the reference's mean total). Scaling the images by ``k`` (and so
        the reference) and moving the seat by whole cells (so the reference CoP) leaves it
        unchanged, while nothing of the print leaves the mat.
    """
    if centre not in CENTRES:
        raise ValueError(f"centre must be one of {', '.join(CENTRES)}, got {centre!r}")
    x = np.asarray(images, dtype=np.float64) / ref.total
    R, C = x.shape[1:]
    mid = np.array([(R - 1) / 2, (C - 1) / 2])
    if centre == "session":
        out = ndimage.shift(x, (0.0, *(mid - ref.cop_cells)), order=1, mode="grid-constant", cval=0.0, prefilter=False)
    else:
        cop, _ = cop_cells(x)
        out = np.stack([_shift(img, mid - c) for img, c in zip(x, cop)]) if len(x) else x
    return out.astype(np.float32)


def invariant_recording(rec: Recording, calibration_s: float, *,
                        centre: Literal["session", "frame"] = "session") -> Recording:
    """The recording with :func:`invariant_images` of its images (angles, times unchanged)."""
    ref = session_reference(rec, calibration_s)
    meta = {**rec.meta, "invariant": {"centre": centre, "calibration_s": float(calibration_s),
                                      "reference_total_S": ref.total, "reference_cop_cells": ref.cop_cells.tolist()}}
    return replace(rec, image=invariant_images(rec.image, ref, centre=centre), meta=meta)


def invariant_features(rec: Recording, calibration_s: float) -> NDArray[np.float64]:
    """Per-frame features invariant to the sitter's weight and seat position (see the module note).

    Returns
    -------
    ndarray, (T, 6 + R + C)
        Columns: CoP row and column minus the reference's (cells); variance of the print along
        rows, along columns, and their covariance (cells²); Σg / reference Σg; the load share of
        each of the R rows and each of the C columns of the session-centred image (fractions of
        the frame's total; 0 for an empty frame).
    """
    ref = session_reference(rec, calibration_s)
    x = rec.image.astype(np.float64)
    R, C = x.shape[1:]
    cop, total = cop_cells(x)
    ok = total > 0
    w = np.where(ok, total, 1.0)
    dr, dc = np.arange(R)[None] - cop[:, :1], np.arange(C)[None] - cop[:, 1:]
    rows, cols = x.sum(axis=2), x.sum(axis=1)
    var_r = np.sum(rows * dr**2, axis=1) / w
    var_c = np.sum(cols * dc**2, axis=1) / w
    cov = np.einsum("trc,tr,tc->t", x, dr, dc) / w
    centred = invariant_images(x, ref).astype(np.float64)
    c_tot = centred.sum(axis=(1, 2))
    c_w = np.where(c_tot > 0, c_tot, 1.0)[:, None]
    shares = np.concatenate([centred.sum(axis=2) / c_w, centred.sum(axis=1) / c_w], axis=1)
    feats = np.column_stack([cop - ref.cop_cells, var_r, var_c, cov, total / ref.total, shares])
    feats[~ok, 2:5] = 0.0
    return feats


def window_means(per_frame: list[NDArray[np.float64]], windows: NDArray[np.int64], window: int
                 ) -> NDArray[np.float64]:
    """Mean over each window of per-frame rows.

    Parameters
    ----------
    per_frame : list of ndarray, (T_r, F)
        One array per recording.
    windows : ndarray, (N, 2)
        (recording, first frame) rows.
    window : int
        Frames per window.

    Returns
    -------
    ndarray, (N, F)
    """
    n_feat = per_frame[0].shape[1] if per_frame else 0
    out = np.empty((len(windows), n_feat))
    for r in np.unique(windows[:, 0]):
        sel = windows[:, 0] == r
        cum = np.concatenate([np.zeros((1, n_feat)), np.cumsum(per_frame[r], axis=0)])
        s = windows[sel, 1]
        out[sel] = (cum[s + window] - cum[s]) / window
    return out

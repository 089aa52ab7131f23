"""One stream averaged over the sample intervals of another (thesis §4.3: the mat "subsampled to the
sampling frequency of the spine measurement device").

:func:`mean_over_samples` makes the learning images of a posture study (:mod:`psmat.posture.data._study`)
and the summed mat signal that aligns a mat and IMUs recorded apart (:mod:`psmat.posture.data._align`),
so the alignment's figure shows what the network sees.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = ["mean_over_samples"]


def mean_over_samples(t_src: NDArray[np.float64], x_src: NDArray[Any], t_dst: NDArray[np.float64]
                      ) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """Average the rows of ``x_src`` over the interval of each destination sample.

    The interval of ``t_dst[k]`` runs from the midpoint with its predecessor to the midpoint with
    its successor (half the neighbouring period at the ends). Rows with a NaN or a non-finite time
    are left out.

    Parameters
    ----------
    t_src : (N,) float
        Source times (s), non-decreasing where finite.
    x_src : (N, ...) array
        Source rows.
    t_dst : (M,) float
        Destination times (s), increasing.

    Returns
    -------
    mean : (M, ...) float64
        The mean of the rows in each interval; NaN where none.
    n : (M,) int
        The rows averaged.
    """
    t_src = np.asarray(t_src, np.float64)
    x = np.asarray(x_src, np.float64)
    t_dst = np.asarray(t_dst, np.float64)
    flat = x.reshape(len(x), -1)
    keep = np.isfinite(t_src) & np.all(np.isfinite(flat), axis=1)
    ts, xs = t_src[keep], flat[keep]
    if ts.size > 1 and np.any(np.diff(ts) < 0):
        raise ValueError("source times must be non-decreasing")
    if t_dst.size == 0:
        return np.empty((0, *x.shape[1:])), np.empty(0, np.int64)
    if t_dst.size > 1 and np.any(np.diff(t_dst) <= 0):
        raise ValueError("destination times must be increasing")
    half = np.diff(t_dst) / 2 if t_dst.size > 1 else np.array([np.inf])
    edges = np.concatenate([[t_dst[0] - half[0]], t_dst[:-1] + half, [t_dst[-1] + half[-1]]])
    idx = np.searchsorted(ts, edges, side="left")
    cs = np.concatenate([np.zeros((1, xs.shape[1])), np.cumsum(xs, axis=0)])
    n = np.diff(idx)
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = (cs[idx[1:]] - cs[idx[:-1]]) / n[:, None]
    mean[n == 0] = np.nan
    return mean.reshape(len(t_dst), *x.shape[1:]), n.astype(np.int64)

"""A linear baseline (beyond the thesis): ridge regression on a PCA of the window-averaged image.

Features: the mean image of each window (``R·C`` cells), standardised as the CNN's input
(training mean and SD), centred on the training mean; PCA by SVD of the training features;
ridge regression of the six window-mean targets on the first ``k`` principal scores. ``k``
and the ridge penalty are chosen on the validation windows (lowest MSE). numpy only.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ..data import Recording, Split, Standardiser, WindowTargets
from ._metrics import table44_row

__all__ = ["COMPONENTS", "PENALTIES", "RidgePCA", "window_mean_images", "fit_ridge_pca", "ridge_pca_rows"]

#: Numbers of principal components tried (capped at the training features' rank).
COMPONENTS = (2, 5, 10, 20, 50, 100, 200)
#: Ridge penalties tried, per training window (the scores are in standardised units).
PENALTIES = tuple(10.0 ** np.arange(-8, 3))


def window_mean_images(recordings: Sequence[Recording], windows: NDArray[np.int64], window: int) -> NDArray[np.float64]:
    """Mean image of each window, ``(N, R·C)``, from one cumulative sum per recording at a time."""
    n_cells = recordings[0].image.shape[1] * recordings[0].image.shape[2] if recordings else 0
    out = np.empty((len(windows), n_cells))
    for r in np.unique(windows[:, 0]):
        sel = windows[:, 0] == r
        img = recordings[r].image.reshape(recordings[r].n_samples, -1)
        cum = np.concatenate([np.zeros((1, img.shape[1])), np.cumsum(img, axis=0, dtype=np.float64)])
        s = windows[sel, 1]
        out[sel] = (cum[s + window] - cum[s]) / window
    return out


@dataclass(frozen=True)
class RidgePCA:
    """A fitted baseline: ``y = y_mean + ((x - x_mean) / sd) V_k B``.

    Attributes
    ----------
    x_mean : ndarray, (P,)
        Training mean of the standardised features.
    sd : float
        Scale of the features (the training SD of the cells, S).
    components : ndarray, (P, k)
        Principal directions V_k.
    coef : ndarray, (k, 6)
        Ridge coefficients B on the scores.
    y_mean : ndarray, (6,)
    penalty : float
        Ridge penalty per training window.
    """

    x_mean: NDArray[np.float64]
    sd: float
    components: NDArray[np.float64]
    coef: NDArray[np.float64]
    y_mean: NDArray[np.float64]
    penalty: float

    @property
    def n_components(self) -> int:
        return int(self.components.shape[1])

    def predict(self, x: NDArray[np.float64]) -> NDArray[np.float64]:
        """Outputs ``(N, 6)`` (rad) of raw window-mean images ``(N, P)`` (S)."""
        return self.y_mean + ((np.asarray(x, dtype=np.float64) / self.sd - self.x_mean) @ self.components) @ self.coef


def fit_ridge_pca(x_train: NDArray[np.float64], y_train: NDArray[np.float64], x_val: NDArray[np.float64],
                  y_val: NDArray[np.float64], *, sd: float = 1.0, components: Sequence[int] = COMPONENTS,
                  penalties: Sequence[float] = PENALTIES) -> RidgePCA:
    """Fit PCA + ridge, choosing ``k`` and the penalty by validation MSE.

    Parameters
    ----------
    x_train, x_val : ndarray, (N, P)
        Raw features (S).
    y_train, y_val : ndarray, (N, 6)
        Targets (rad).
    sd : float
        Feature scale (the training SD of the cells).
    components, penalties : sequence
        Candidates for ``k`` and for the penalty per training window.
    """
    xs = np.asarray(x_train, dtype=np.float64) / sd
    x_mean, y_mean = xs.mean(axis=0), np.asarray(y_train, dtype=np.float64).mean(axis=0)
    xc, yc = xs - x_mean, np.asarray(y_train, dtype=np.float64) - y_mean
    _, s, vt = np.linalg.svd(xc, full_matrices=False)
    rank = int(np.sum(s > s[0] * 1e-10)) if s.size and s[0] > 0 else 0
    if rank == 0:
        raise ValueError("the training features do not vary: nothing to fit")
    zy = (xc @ vt[:rank].T).T @ yc  # (rank, 6): scores' cross-products with the targets
    z_val = (np.asarray(x_val, dtype=np.float64) / sd - x_mean) @ vt[:rank].T
    best: tuple[float, RidgePCA] | None = None
    for k in sorted({min(int(c), rank) for c in components}):
        for a in penalties:
            # Ridge on orthogonal scores: the Gram matrix is diag(s_i^2)
            coef = zy[:k] / (s[:k, None] ** 2 + a * len(xc))
            mse = float(np.mean(np.square(y_mean + z_val[:, :k] @ coef - y_val)))
            if best is None or mse < best[0]:
                best = (mse, RidgePCA(x_mean, float(sd), vt[:k].T.copy(), coef, y_mean, float(a)))
    assert best is not None
    return best[1]


def ridge_pca_rows(recordings: Sequence[Recording], split: Split, standardiser: Standardiser | None = None
                   ) -> tuple[RidgePCA, list[dict[str, object]], dict[str, NDArray[np.float64]]]:
    """Fit the baseline on a split's training windows; Table 4.4 rows for validation and test.

    Returns
    -------
    model : RidgePCA
    rows : list of dict
        :func:`~psmat.posture.evaluate.table44_row` for ``validation`` and ``test`` (model ``"ridge-pca"``).
    predictions : dict of str to ndarray
        ``(N, 6)`` predictions of each of those subsets, in the split's window order.
    """
    w = split.windows
    std = standardiser or Standardiser.fit(recordings, w["train"], split.window)
    targets = WindowTargets(recordings, split.window)
    x = {k: window_mean_images(recordings, w[k], split.window) for k in w}
    y = {k: targets(w[k]) for k in w}
    model = fit_ridge_pca(x["train"], y["train"], x["validation"], y["validation"], sd=std.sd)
    pred = {k: model.predict(x[k]) for k in ("validation", "test")}
    rows = [table44_row("ridge-pca", split.name, k, y[k], pred[k]) for k in ("validation", "test")]
    return model, rows, pred

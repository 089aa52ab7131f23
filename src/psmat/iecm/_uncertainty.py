"""Uncertainty of IECM results (thesis §2.3, eq. 2.11-2.14, Fig. 2.11-2.13).

* :func:`propagate_uncertainty` - the law of propagation (eq. 2.11) with dg/dG = (dG/dg)^-1
  (eq. 2.14), computed in the C++ core from one Cholesky of the SPD form of dG/dg.
* :func:`monte_carlo_uncertainty` - the simulation of Fig. 2.11: add noise to G = F(g),
  re-solve every draw (a batch on all cores), take the standard deviation.
"""

from __future__ import annotations

import numpy as np

from .. import _core
from ._validate import as_frames, check_dense_size
from ._forward import forward
from ._solve import solve

__all__ = ["propagate_uncertainty", "monte_carlo_uncertainty", "inverse_jacobian"]


def _sigma_G_default(G: np.ndarray) -> np.ndarray:
    from ..noise import table_sigma_G  # Table 2.4 / Fig. 2.12 noise model

    return table_sigma_G(G)


def inverse_jacobian(g) -> np.ndarray:
    """dg/dG = (dG/dg)^-1 (eq. 2.14) at cell conductances g (S), shape (R*C, R*C)."""
    frames, _ = as_frames(g, "g", allow_zero=False, max_ndim=2)
    check_dense_size(frames.shape[1:], "inverse_jacobian")
    return _core.iecm.inverse_jacobian(frames[0])


def propagate_uncertainty(g, sigma_G=None) -> np.ndarray:
    """Standard uncertainty of the cell conductances (eq. 2.11).

    Parameters
    ----------
    g : array_like, shape (R, C) or (T, R, C)
        Cell conductances in S (e.g. the IECM solution).
    sigma_G : array_like or float, optional
        Standard deviation of the measured equivalent conductances, in S, broadcastable
        to g. Default: the thesis noise model (Table 2.4 / Fig. 2.12, relative sigma
        interpolated in log R) evaluated at G = F(g).

    Returns
    -------
    numpy.ndarray
        sigma_g in S, shape of g.
    """
    frames, single = as_frames(g, "g", allow_zero=False)
    check_dense_size(frames.shape[1:], "propagate_uncertainty")
    out = np.empty_like(frames)
    for t, gt in enumerate(frames):
        if sigma_G is None:
            sG = _sigma_G_default(forward(gt))
        else:
            sG = np.broadcast_to(np.asarray(sigma_G, dtype=np.float64), np.shape(g))
            sG = np.ascontiguousarray(sG if single else sG[t])
            if not np.all(np.isfinite(sG)) or np.any(sG < 0):
                raise ValueError("sigma_G must be finite and >= 0 (S)")
        out[t] = _core.iecm.propagate_uncertainty(gt, sG)
    return out[0] if single else out


def monte_carlo_uncertainty(
    g,
    sigma_G=None,
    *,
    draws: int = 1000,
    rng: np.random.Generator | int | None = 0,
    method: str = "newton",
    threads: int | None = None,
    return_samples: bool = False,
):
    """Monte-Carlo uncertainty of IECM (thesis Fig. 2.11): SD of g re-solved from noisy G.

    Parameters
    ----------
    g : array_like, shape (R, C)
        True cell conductances in S.
    sigma_G : array_like or float, optional
        SD of the Gaussian noise added to each G (S); default the Table 2.4 model at F(g).
    draws : int
        Number of noisy realisations (the thesis used 1000).
    rng : numpy Generator or seed
    method, threads
        Passed to :func:`psmat.iecm.solve`; the draws are solved as one batch.
    return_samples : bool
        Also return the (draws, R, C) solutions.

    Returns
    -------
    sigma_g : numpy.ndarray, shape (R, C), in S
    samples : numpy.ndarray, only with ``return_samples``
    """
    frames, _ = as_frames(g, "g", allow_zero=False, max_ndim=2)
    if int(draws) != draws or draws < 2:
        raise ValueError(f"draws must be an integer >= 2, got {draws!r}")
    rng = np.random.default_rng(rng)
    G = forward(frames[0])
    sG = _sigma_G_default(G) if sigma_G is None else np.broadcast_to(np.asarray(sigma_G, float), G.shape)
    noisy = G + rng.standard_normal((int(draws),) + G.shape) * sG
    if np.any(noisy <= 0):
        raise ValueError(
            "the noise drove some equivalent conductances to <= 0; sigma_G is too large for a "
            "Gaussian model at these conductances"
        )
    # every draw starts at the true g: only the spread of the solutions matters here
    sol = solve(noisy, method=method, g0=np.broadcast_to(frames[0], noisy.shape), warm_start=False,
                threads=threads, progress=draws >= 2000)
    sd = sol.std(axis=0, ddof=1)
    return (sd, sol) if return_samples else sd

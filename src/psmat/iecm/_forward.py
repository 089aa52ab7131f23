"""IECM forward model and its Jacobian (thesis eq. 2.5-2.7 and 2.13, docs/spec.md §3).

The computation lives in the C++ core (``src/cpp/psmat/iecm/forward.hpp``,
``jacobian.hpp``); this module validates arrays and shapes.
"""

from __future__ import annotations

import numpy as np

from .. import _core
from ._validate import as_frames, check_dense_size

__all__ = ["forward", "jacobian", "hadamard_product"]


def forward(g) -> np.ndarray:
    """Equivalent conductances G = F(g) of the basic readout circuit (eq. 2.5-2.7).

    Parameters
    ----------
    g : array_like, shape (R, C) or (T, R, C)
        Cell conductances in S (>= 0; every row and column needs a conducting cell).

    Returns
    -------
    numpy.ndarray
        G in S, same shape as ``g``: the conductance measured between row i and column p
        with all other lines floating.
    """
    frames, single = as_frames(g, "g", allow_zero=True)
    G, ok = _core.iecm.forward(frames)
    if not ok.all():
        t = int(np.argmin(ok))
        raise ValueError(
            f"g{'' if single else f'[{t}]'}: the resistor network is disconnected (a row or column "
            "has no conducting cell), so its equivalent conductances are undefined"
        )
    return G[0] if single else G


def jacobian(g) -> np.ndarray:
    """dG/dg (eq. 2.13) at cell conductances g.

    Parameters
    ----------
    g : array_like, shape (R, C)
        Cell conductances in S.

    Returns
    -------
    numpy.ndarray, shape (R*C, R*C)
        ``J[a, b] = dG_a/dg_b`` with cells flattened row-major (a = i*C + p); dimensionless.
        The diagonal is exactly 1.
    """
    frames, _ = as_frames(g, "g", allow_zero=True, max_ndim=2)
    check_dense_size(frames.shape[1:], "jacobian")
    return _core.iecm.jacobian(frames[0])


def hadamard_product(g, v) -> np.ndarray:
    """Matrix-free ``(T∘T) v`` in O((R+C)^3) (docs/spec.md §3), T the voltage-difference matrix of eq. 2.13.

    ``J = diag(G)^2 (T∘T)``; this product never forms the (R*C)^2 matrix.

    Parameters
    ----------
    g : array_like, shape (R, C)
        Cell conductances in S.
    v : array_like, shape (R, C)
        Vector (in S) to multiply.

    Returns
    -------
    numpy.ndarray, shape (R, C), in 1/S.
    """
    frames, _ = as_frames(g, "g", allow_zero=True, max_ndim=2)
    v = np.asarray(v, dtype=np.float64)
    if v.shape != frames.shape[1:]:
        raise ValueError(f"v must have the shape of g {frames.shape[1:]}, got {v.shape}")
    return _core.iecm.hadamard_product(frames[0], v)

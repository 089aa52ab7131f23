"""The thesis' IECM approach in plain NumPy/SciPy: the IECM benchmark's baseline.

Deliberately independent of psmat's C++ core: nothing here imports :mod:`psmat.iecm` (or any
of psmat). ``tests/integration/test_bench_baseline.py`` checks it against the reference vectors of
``tests/data/reference/``, closed forms and finite differences.

* :func:`forward_numpy` — ``G = F(g)`` (thesis eq. 2.5–2.7, docs/spec.md §3): the array is a
  bipartite resistor network on ``n = R + C`` nodes (rows ``0..R-1``, then columns
  ``R..R+C-1``); its Laplacian with the last node grounded is inverted (one Cholesky),
  ``M`` is padded with a zero row/column for the ground, and
  ``1/G[i,p] = M[i,i] + M[R+p,R+p] - 2 M[i,R+p]``.
* :func:`jacobian_numpy` — ``dG/dg`` (eq. 2.13) from the same ``M``.
* :func:`solve_least_squares_scipy` — eq. 2.9 with ``scipy.optimize.least_squares`` and a
  numerical ('2-point') Jacobian, with the bound ``g >= 0`` (the thesis' Python version) or
  on ``log g`` (the thesis' C/GSL version).
* :func:`solve_fixed_point_numpy` — eq. 2.10, ``g <- g + beta (G - F(g))``, clipped at a tiny
  positive floor, vectorised over frames.

Conductances in S throughout.
"""

from __future__ import annotations

import time

import numpy as np

__all__ = [
    "forward_numpy",
    "jacobian_numpy",
    "solve_least_squares_scipy",
    "solve_fixed_point_numpy",
]


def _frames(x, name: str) -> tuple[np.ndarray, bool]:
    a = np.asarray(x, dtype=np.float64)
    if a.ndim not in (2, 3) or a.shape[-1] < 2 or a.shape[-2] < 2:
        raise ValueError(f"{name} must have shape (R, C) or (T, R, C) with R, C >= 2, got {a.shape}")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name} has non-finite values")
    return (a[None], True) if a.ndim == 2 else (a, False)


def _grounded_inverse(g: np.ndarray) -> np.ndarray:
    """Padded inverse M (T, n, n) of the grounded Laplacian for frames g (T, R, C)."""
    T, R, C = g.shape
    n = R + C
    L = np.zeros((T, n, n))
    idx_r = np.arange(R)
    idx_c = R + np.arange(C)
    L[:, idx_r, idx_r] = g.sum(axis=2)
    L[:, idx_c, idx_c] = g.sum(axis=1)
    L[:, :R, R:] = -g
    L[:, R:, :R] = -np.swapaxes(g, 1, 2)
    Cm = L[:, : n - 1, : n - 1]  # ground the last node (column C-1)
    # Cholesky of the SPD grounded Laplacian, then M = Cm^-1 = L^-T L^-1.
    chol = np.linalg.cholesky(Cm)
    eye = np.broadcast_to(np.eye(n - 1), Cm.shape)
    Linv = np.linalg.solve(chol, eye)
    M = np.zeros((T, n, n))
    M[:, : n - 1, : n - 1] = np.swapaxes(Linv, 1, 2) @ Linv
    return M


def forward_numpy(g) -> np.ndarray:
    """Equivalent conductances ``G = F(g)`` (S) of the basic readout circuit (eq. 2.5–2.7).

    Parameters
    ----------
    g : array_like, shape (R, C) or (T, R, C)
        Cell conductances in S (> 0; the grounded Laplacian must be positive definite).

    Returns
    -------
    numpy.ndarray
        ``G`` in S, same shape as ``g``.
    """
    a, single = _frames(g, "g")
    R = a.shape[1]
    M = _grounded_inverse(a)
    d = np.diagonal(M, axis1=1, axis2=2)
    inv_G = d[:, :R, None] + d[:, None, R:] - 2.0 * M[:, :R, R:]
    G = 1.0 / inv_G
    return G[0] if single else G


def jacobian_numpy(g) -> np.ndarray:
    """``J[a, b] = dG_a/dg_b`` (eq. 2.13) for one frame, cells flattened row-major.

    ``J = diag(G)² (T∘T)`` with ``T = Bᵀ M B``, ``B`` the (n × RC) incidence matrix whose
    column for cell ``(i, p)`` is ``e_i - e_{R+p}`` (the sign cancels in the square).
    """
    a, single = _frames(g, "g")
    if not single:
        raise ValueError("jacobian_numpy takes one (R, C) frame")
    R, C = a.shape[1:]
    M = _grounded_inverse(a)[0]
    B = np.zeros((R + C, R * C))
    cells = np.arange(R * C)
    B[cells // C, cells] = 1.0
    B[R + cells % C, cells] = -1.0
    Tm = B.T @ M @ B
    G = 1.0 / np.diagonal(Tm)
    return (G**2)[:, None] * Tm**2


def solve_least_squares_scipy(
    G,
    g0=None,
    *,
    param: str = "bounds",
    residual: str = "absolute",
    ftol: float = 1e-12,
    xtol: float = 1e-12,
    gtol: float = 1e-12,
    max_nfev: int | None = None,
    **kwargs,
):
    """Eq. 2.9 the thesis way: ``scipy.optimize.least_squares`` with a numerical Jacobian.

    Parameters
    ----------
    G : array_like, shape (R, C)
        Measured equivalent conductances in S.
    g0 : array_like, optional
        Start (S); default ``G`` (a cold start).
    param : {"bounds", "log"}
        ``"bounds"``: unknowns ``g`` with bounds ``(0, inf)`` and method 'trf' (the thesis'
        Python version); ``"log"``: unknowns ``log g``, unbounded (the thesis' C/GSL way).
    residual : {"absolute", "relative"}
        ``F(g) - G`` in S as in eq. 2.9, or ``F(g)/G - 1``.
    ftol, xtol, gtol, max_nfev, **kwargs
        Passed to ``least_squares`` (``jac='2-point'`` always).

    Returns
    -------
    g : numpy.ndarray, shape (R, C)
        Cell conductances in S.
    result : scipy.optimize.OptimizeResult
        With an extra ``wall_time`` (s).
    """
    from scipy.optimize import least_squares

    Gm = np.asarray(G, dtype=np.float64)
    if Gm.ndim != 2:
        raise ValueError(f"G must be one (R, C) frame, got shape {Gm.shape}")
    shape = Gm.shape
    start = Gm.copy() if g0 is None else np.asarray(g0, dtype=np.float64).reshape(shape)
    if residual == "absolute":
        scale = 1.0
    elif residual == "relative":
        scale = 1.0 / Gm.ravel()
    else:
        raise ValueError(f"residual must be 'absolute' or 'relative', got {residual!r}")
    target = Gm.ravel()

    if param == "bounds":
        def fun(x):
            return (forward_numpy(x.reshape(shape)).ravel() - target) * scale

        x0, bounds, back = start.ravel(), (0.0, np.inf), (lambda x: x)
        method = kwargs.pop("method", "trf")
    elif param == "log":
        def fun(x):
            return (forward_numpy(np.exp(x).reshape(shape)).ravel() - target) * scale

        x0, bounds, back = np.log(start.ravel()), (-np.inf, np.inf), np.exp
        method = kwargs.pop("method", "trf")
    else:
        raise ValueError(f"param must be 'bounds' or 'log', got {param!r}")
    t0 = time.perf_counter()
    res = least_squares(fun, x0, jac="2-point", bounds=bounds, method=method, ftol=ftol,
                        xtol=xtol, gtol=gtol, max_nfev=max_nfev, **kwargs)
    res.wall_time = time.perf_counter() - t0
    return back(res.x).reshape(shape), res


def solve_fixed_point_numpy(
    G,
    beta: float = 0.05,
    rtol: float = 1e-10,
    max_iter: int = 2000,
    *,
    g0=None,
    g_floor: float = 1e-12,
    g_true=None,
    target_error: float | None = None,
    error_threshold: float = 1e-4,
    time_limit: float | None = None,
):
    """Eq. 2.10, ``g <- g + beta (G - F(g))`` clipped at ``g_floor``, for one frame or a batch.

    Frames are iterated together (vectorised over ``T``); a frame stops when its relative
    residual ``max |F(g) - G| / G <= rtol`` (``rtol=0`` runs every frame to ``max_iter``),
    or — when ``g_true`` and ``target_error`` are given (an oracle, for benchmarks only) —
    when its relative error over cells with ``g_true >= error_threshold`` reaches
    ``target_error``.

    Parameters
    ----------
    G : array_like, shape (R, C) or (T, R, C)
        Equivalent conductances in S.
    beta : float
        Damping factor (thesis: 0.05).
    rtol : float
        Stopping tolerance on the relative residual.
    max_iter : int
        Iteration cap per frame.
    g0 : array_like, optional
        Start (S), default ``G``.
    g_floor : float
        Positivity floor (S).
    g_true, target_error, error_threshold :
        Optional oracle stopping rule (see above).
    time_limit : float, optional
        Stop every frame after this many seconds (reported as not converged).

    Returns
    -------
    g : numpy.ndarray
        Shape of ``G``, in S.
    info : dict
        ``iterations`` (T,), ``residual`` (T,), ``converged`` (T,) and ``wall_time`` (s);
        with the oracle also ``error`` (T,) and ``error_history`` (k+1, T), the oracle error
        after each of the k iterations run (NaN for frames already stopped).
    """
    Gf, single = _frames(G, "G")
    if np.any(Gf <= 0):
        raise ValueError("G must be > 0")
    g = Gf.copy() if g0 is None else _frames(g0, "g0")[0].copy()
    if g.shape != Gf.shape:
        raise ValueError(f"g0 must have the shape of G {Gf.shape}, got {g.shape}")
    oracle = g_true is not None and target_error is not None
    if oracle:
        gt = _frames(g_true, "g_true")[0]
        mask = gt >= error_threshold
    T = Gf.shape[0]
    iters = np.zeros(T, dtype=np.int64)
    resid = np.full(T, np.inf)
    done = np.zeros(T, dtype=bool)
    active = np.arange(T)
    history: list[np.ndarray] = []
    last_err = np.full(T, np.nan)
    t0 = time.perf_counter()
    for k in range(max_iter + 1):
        Fg = forward_numpy(g[active])
        r = Gf[active] - Fg
        resid[active] = np.max(np.abs(r) / Gf[active], axis=(1, 2))
        stop = resid[active] <= rtol
        if oracle:
            err = np.abs(g[active] - gt[active]) / gt[active]
            err = np.where(mask[active], err, 0.0).max(axis=(1, 2))
            stop |= err <= target_error
            last_err[active] = err
            h = np.full(T, np.nan)
            h[active] = err
            history.append(h)
        done[active[stop]] = True
        keep = ~stop
        if k == max_iter or not keep.any():
            break
        if time_limit is not None and time.perf_counter() - t0 > time_limit:
            break
        active, r = active[keep], r[keep]
        g[active] = np.maximum(g[active] + beta * r, g_floor)
        iters[active] += 1
    info = {"iterations": iters, "residual": resid, "converged": done,
            "wall_time": time.perf_counter() - t0}
    if oracle:
        info["error"] = last_err
        info["error_history"] = np.array(history)
    if single:
        info = {k: (v[..., 0] if isinstance(v, np.ndarray) else v) for k, v in info.items()}
        return g[0], info
    return g, info

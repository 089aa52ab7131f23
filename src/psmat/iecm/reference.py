"""Reference methods of the IECM inverse: what the recommended methods are checked against.

:func:`psmat.iecm.solve` with ``method="newton"`` (the default) or ``"active_set"`` is what to
use. The methods here are the thesis' own iterations and the slower complementarity Newton that
the active-set method replaced; they run in the same C++ core, take the same G (R, C) or
(T, R, C) in S, and return the same ``g`` (and :class:`~psmat.iecm.SolveInfo`), and
``psmat.iecm.solve(G, method=name)`` dispatches here for each of their names (:data:`METHODS`).

* :func:`fixed_point` - the thesis' iteration g <- g + beta (G - F(g)) (eq. 2.10); converges
  when beta < 2 / lambda_max(dG/dg), slowly on two-feet images (thousands of iterations).
* :func:`lm` - least squares (eq. 2.9) by Levenberg-Marquardt on log g, the analytic Jacobian
  (eq. 2.13): the thesis' C/GSL formulation. On noisy G it can stall: a cell driven towards 0
  sits on a plateau of the cost in log g.
* :func:`bounded_lsq` - least squares (eq. 2.9) on g with the bound g >= g_floor (projected
  Levenberg-Marquardt): the thesis' ``scipy.optimize.least_squares(bounds=(0, inf))``.
* :func:`bounded_newton` - the complementarity problem of noisy frames (F(g) = G on the free
  cells, g at g_floor where even an empty cell over-predicts G; unique, docs/spec.md §3) by a
  semismooth Newton on the Fischer-Burmeister reformulation: the same solution as
  ``"active_set"``, at a linear rate (the earlier default for noisy frames).

The C++ implementations: ``src/cpp/psmat/iecm/solve_fixed_point.cpp``, ``solve_lsq.cpp``,
``solve_bounded_newton.cpp``.
"""

from __future__ import annotations

import numpy as np

from ._info import SolveInfo
from ._run import REFERENCE, run

__all__ = ["METHODS", "fixed_point", "lm", "bounded_lsq", "bounded_newton"]

#: the names ``psmat.iecm.solve(G, method=...)`` dispatches to this module
METHODS = REFERENCE



def fixed_point(G, *, beta: float = 0.05, g0=None, warm_start: bool = True, threads: int | None = None,
                rtol: float = 1e-10, max_iter: int | None = None, g_floor: float = 1e-12,
                progress: bool | None = None, return_info: bool = False
                ) -> np.ndarray | tuple[np.ndarray, SolveInfo]:
    """The thesis' fixed point g <- g + beta (G - F(g)) (eq. 2.10), clipped at g_floor.

    Parameters
    ----------
    G : array_like, shape (R, C) or (T, R, C)
        Equivalent conductances in S.
    beta : float
        Damping (dimensionless); stable for beta < 2 / lambda_max(dG/dg).
    g0, warm_start, threads, rtol, max_iter, g_floor, progress, return_info
        As :func:`psmat.iecm.solve` (``max_iter`` default 20000).

    Returns
    -------
    g : numpy.ndarray
        Cell conductances in S, shape of G (and a :class:`~psmat.iecm.SolveInfo` with ``return_info``).
    """
    return run(G, "fixed_point", beta=beta, g0=g0, warm_start=warm_start, threads=threads, rtol=rtol,
               max_iter=max_iter, g_floor=g_floor, progress=progress, return_info=return_info)


def lm(G, *, g0=None, warm_start: bool = True, threads: int | None = None, rtol: float = 1e-10,
       max_iter: int | None = None, g_floor: float = 1e-12, progress: bool | None = None,
       return_info: bool = False) -> np.ndarray | tuple[np.ndarray, SolveInfo]:
    """Least squares (eq. 2.9) by Levenberg-Marquardt on log g (positivity by construction).

    On noisy G: status ``least_squares`` at a stationary point of the cost, or a stall where a
    cell is driven towards 0.

    Parameters
    ----------
    G : array_like, shape (R, C) or (T, R, C)
        Equivalent conductances in S.
    g0, warm_start, threads, rtol, max_iter, g_floor, progress, return_info
        As :func:`psmat.iecm.solve` (``max_iter`` default 200).

    Returns
    -------
    g : numpy.ndarray
        Cell conductances in S, shape of G (and a :class:`~psmat.iecm.SolveInfo` with ``return_info``).
    """
    return run(G, "lm", g0=g0, warm_start=warm_start, threads=threads, rtol=rtol, max_iter=max_iter,
               g_floor=g_floor, progress=progress, return_info=return_info)


def bounded_lsq(G, *, g0=None, warm_start: bool = True, threads: int | None = None, rtol: float = 1e-10,
                max_iter: int | None = None, g_floor: float = 1e-12, progress: bool | None = None,
                return_info: bool = False) -> np.ndarray | tuple[np.ndarray, SolveInfo]:
    """Least squares (eq. 2.9) on g >= g_floor by projected Levenberg-Marquardt.

    On noisy G: status ``least_squares``, the cells the cost pushes below the floor held there.

    Parameters
    ----------
    G : array_like, shape (R, C) or (T, R, C)
        Equivalent conductances in S.
    g0, warm_start, threads, rtol, max_iter, g_floor, progress, return_info
        As :func:`psmat.iecm.solve` (``max_iter`` default 200).

    Returns
    -------
    g : numpy.ndarray
        Cell conductances in S, shape of G (and a :class:`~psmat.iecm.SolveInfo` with ``return_info``).
    """
    return run(G, "bounded_lsq", g0=g0, warm_start=warm_start, threads=threads, rtol=rtol, max_iter=max_iter,
               g_floor=g_floor, progress=progress, return_info=return_info)


def bounded_newton(G, *, g0=None, warm_start: bool = True, threads: int | None = None, rtol: float = 1e-10,
                   max_iter: int | None = None, g_floor: float = 1e-12, progress: bool | None = None,
                   return_info: bool = False) -> np.ndarray | tuple[np.ndarray, SolveInfo]:
    """The complementarity problem of noisy frames by semismooth Fischer-Burmeister Newton.

    F(g) = G on the free cells, g = g_floor on the cells that even empty over-predict G (status
    ``bounded``, ``info.at_bound`` cells); ``info.residual`` is max |phi| (relative to G). The
    solution of ``psmat.iecm.solve(G, method="active_set")``, reached at a linear rate.

    Parameters
    ----------
    G : array_like, shape (R, C) or (T, R, C)
        Equivalent conductances in S.
    g0, warm_start, threads, rtol, max_iter, g_floor, progress, return_info
        As :func:`psmat.iecm.solve` (``max_iter`` default 1000).

    Returns
    -------
    g : numpy.ndarray
        Cell conductances in S, shape of G (and a :class:`~psmat.iecm.SolveInfo` with ``return_info``).
    """
    return run(G, "bounded_newton", g0=g0, warm_start=warm_start, threads=threads, rtol=rtol,
               max_iter=max_iter, g_floor=g_floor, progress=progress, return_info=return_info)

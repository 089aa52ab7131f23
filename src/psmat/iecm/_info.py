"""Per-frame diagnostics of the IECM inverse: :class:`SolveInfo`, built from the C++ core's reports.

The core reports every frame, alone or in a batch or a stream, as one ``psmat._core.SolveReport``
whose ``status`` is a ``psmat._core.Status``; SolveInfo gathers them into arrays and adds the two
statuses that the floor ``g_floor`` decides, not the data (docs/spec.md §3).
"""

from __future__ import annotations

import sys
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

__all__ = ["SolveInfo"]

# statuses set here rather than by the core: the answer is g_floor's, not the data's (docs/spec.md §3)
_FLOOR_REASONS = {
    "floor_above_data": "g_floor = {g_floor:g} S is not below the measured G; it is a positivity bound and must be "
                        "far below the data",
    "all_at_floor": "every cell ended at g_floor = {g_floor:g} S: no signal above the floor",
}


def _caller_stacklevel() -> int:
    """``stacklevel`` of :func:`warnings.warn` for the first frame outside psmat.iecm, counted from
    the function that calls this one (the caller of the public function, whichever path led here)."""
    frame, level = sys._getframe(1), 1
    while frame is not None and frame.f_globals.get("__name__", "").startswith("psmat.iecm"):
        frame, level = frame.f_back, level + 1
    return level


@dataclass
class SolveInfo:
    """Per-frame diagnostics of :func:`psmat.iecm.solve` (arrays of length T, or 0-d for one frame).

    Attributes
    ----------
    iterations, factorizations, krylov_iterations, evaluations : int arrays
        Newton (or method) iterations, matrix factorisations, PCG iterations and
        forward-model evaluations per frame.
    residual : float array
        Final max_a |F(g)_a - G_a| / G_a (relative, dimensionless); for the bounded methods
        (``active_set``, ``bounded_newton``, Newton's fallback) the complementarity residual, i.e.
        the same over the cells not at the bound.
    cost : float array
        Final 0.5 * sum(((F(g) - G) / G)^2) (dimensionless).
    status : str array
        ``converged``, ``bounded`` (noisy G: complementarity solution with ``at_bound``
        cells at g_floor), ``least_squares`` (noisy G: least-squares point),
        ``max_iterations``, ``stalled``, ``singular`` (the names of ``psmat._core.Status``),
        ``all_at_floor`` (every cell at g_floor) or ``floor_above_data`` (g_floor >= some
        measured G).
    converged : bool array
        True for ``converged``, ``bounded`` and ``least_squares`` (never for a frame that
        g_floor decided).
    used_fallback : bool array
        Newton handed the frame to the active-set method (noisy G, or a warm start with cells
        at the bound), or the active-set method finished it with the bounded Newton.
    at_bound : int array
        Cells held at g_floor (bounded methods, least squares).
    method : str
    wall_time_s : float
        Seconds for the whole call.
    threads : int
    """

    iterations: np.ndarray
    factorizations: np.ndarray
    krylov_iterations: np.ndarray
    evaluations: np.ndarray
    residual: np.ndarray
    cost: np.ndarray
    status: np.ndarray
    converged: np.ndarray
    used_fallback: np.ndarray
    at_bound: np.ndarray
    method: str = "newton"
    wall_time_s: float = 0.0
    threads: int = 1
    extra: dict = field(default_factory=dict)

    _FIELDS = ("iterations", "factorizations", "krylov_iterations", "evaluations", "residual", "cost",
               "converged", "used_fallback", "at_bound")

    @classmethod
    def from_reports(cls, reports: Sequence, method: str, *, single: bool = False, **kw) -> "SolveInfo":
        """From the core's ``psmat._core.SolveReport`` of each frame, in frame order.

        Parameters
        ----------
        reports : sequence of psmat._core.SolveReport
            One per frame.
        method : str
            The method that solved them.
        single : bool
            One frame: 0-d arrays instead of arrays of length 1.
        **kw
            ``wall_time_s``, ``threads``.
        """
        cols = {k: np.array([getattr(r, k) for r in reports]) for k in cls._FIELDS}
        cols["status"] = np.array([r.status.name for r in reports])
        if single:
            cols = {k: v.reshape(()) for k, v in cols.items()}
        return cls(**cols, method=method, **kw)

    def flag_floor(self, G_min: np.ndarray, g: np.ndarray, g_floor: float) -> None:
        """Mark the frames that g_floor decided (module docstring) as not converged.

        Parameters
        ----------
        G_min : numpy.ndarray, shape (T,)
            Smallest measured equivalent conductance of each frame, S.
        g : numpy.ndarray, shape (T, R, C)
            The solution, S.
        g_floor : float
            The lower bound the solver used, S.
        """
        shape = np.shape(self.converged)
        above = (np.asarray(G_min) <= g_floor).reshape(shape)
        # the core's own test for a cell at the bound (at_bound)
        floor = np.all(g <= g_floor * (1.0 + 1e-9), axis=(1, 2)).reshape(shape)
        self.status = np.where(above, "floor_above_data", np.where(floor, "all_at_floor", self.status))
        self.converged = self.converged & ~above & ~floor

    def warn_unconverged(self, g_floor: float, stacklevel: int | None = None) -> None:
        """One RuntimeWarning naming the statuses of the frames that did not converge, if any.

        ``stacklevel`` as :func:`warnings.warn`; None: the caller of the psmat.iecm function.
        """
        conv = np.atleast_1d(self.converged)
        if conv.all():
            return
        names, counts = np.unique(np.atleast_1d(self.status)[~conv], return_counts=True)
        reasons = [_FLOOR_REASONS[n].format(g_floor=g_floor) for n in names if n in _FLOOR_REASONS]
        warnings.warn(
            f"IECM ({self.method}): {int((~conv).sum())} of {conv.size} frame(s) did not converge "
            f"(status: {', '.join(f'{n} {c}' for n, c in zip(names.tolist(), counts.tolist()))})"
            + "".join(f"; {r}" for r in reasons) + "; pass return_info=True to inspect them",
            RuntimeWarning,
            stacklevel=_caller_stacklevel() if stacklevel is None else stacklevel,
        )

    @property
    def all_converged(self) -> bool:
        return bool(np.all(self.converged))

    def summary(self) -> str:
        n = np.size(self.converged)
        return (
            f"{self.method}: {int(np.sum(self.converged))}/{n} frames converged, "
            f"iterations mean {np.mean(self.iterations):.1f} max {np.max(self.iterations)}, "
            f"max residual {np.max(self.residual):.2e}, {self.wall_time_s:.3f} s on {self.threads} thread(s)"
        )

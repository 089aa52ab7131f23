"""IECM - Inverse of Equivalent Conductance Method: crosstalk removal (thesis §2.1.4, §2.3).

Arrays in, arrays out: conductances in S, frames (R, C) or stacks (T, R, C), cells
flattened row-major (a = i*C + p) in Jacobians.

:func:`solve` with its recommended methods ``"newton"`` and ``"active_set"`` removes crosstalk;
:mod:`psmat.iecm.reference` holds the reference methods (the thesis' fixed point and least
squares, the Fischer-Burmeister bounded Newton), which ``solve`` also runs by name.
"""

from . import reference
from ._forward import forward, hadamard_product, jacobian
from ._info import SolveInfo
from ._solve import METHODS, RECOMMENDED, solve
from ._stream import Stream
from ._uncertainty import inverse_jacobian, monte_carlo_uncertainty, propagate_uncertainty

__all__ = [
    "forward",
    "jacobian",
    "hadamard_product",
    "solve",
    "SolveInfo",
    "METHODS",
    "RECOMMENDED",
    "reference",
    "Stream",
    "propagate_uncertainty",
    "monte_carlo_uncertainty",
    "inverse_jacobian",
]

"""IECM - Inverse of Equivalent Conductance Method: crosstalk removal (thesis §2.1.4, §2.3).

Arrays in, arrays out: conductances in S, frames (R, C) or stacks (T, R, C), cells
flattened row-major (a = i*C + p) in Jacobians.
"""

from .forward import forward, hadamard_product, jacobian
from .solve import METHODS, SolveInfo, solve
from .stream import Stream
from .uncertainty import inverse_jacobian, monte_carlo_uncertainty, propagate_uncertainty

__all__ = [
    "forward",
    "jacobian",
    "hadamard_product",
    "solve",
    "SolveInfo",
    "METHODS",
    "Stream",
    "propagate_uncertainty",
    "monte_carlo_uncertainty",
    "inverse_jacobian",
]

"""Whether a force platform's CoP moves as far as the mat's (docs/spec.md §7, "Platform spread").

The mat and the platform measure one body's sway: once aligned, their CoP traces spread about as
far (the standard distance of the trace from its mean, both axes together). A platform file read
in another unit than it was written in (mm taken as cm: 10 times; m as cm: 1/100) spreads a
power of ten away from the mat, and its metrics, Eu and the summary would be false while the
alignment, a correlation, stays good. Measured in simulation (the thesis-size study, 126 trials,
the mats unknown to the processing): the platform over PROP, 0.96-1.38; over SCHC, 0.91-1.42.
:data:`SPREAD_MISMATCH` flags a ratio beyond 4 either way: a unit slip (× 10, × 100, × 1000), not a
mat that sees the sway a little smaller.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from .. import _checks
from ..units import LENGTH_UNITS_CM, cm_per_unit

__all__ = ["SPREAD_MISMATCH", "SpreadCheck", "check_spread", "spread_question"]

#: the platform's spread over the mat's beyond which (or below whose inverse) the platform file is
#: taken to be in another unit than it was read in, or not this trial's
SPREAD_MISMATCH = 4.0

#: the units offered as what a file was written in, one name each
_UNITS = ("mm", "cm", "m", "in")


@dataclass(frozen=True)
class SpreadCheck:
    """Result of :func:`check_spread`.

    Attributes
    ----------
    ratio : float
        The platform's spread over the mat's (no unit; about 1 for one body's sway).
    read_as : str
        The unit the platform's numbers were read in.
    fits : str or None
        The unit (mm, cm, m, in) other than ``read_as`` under which the ratio would be within a factor
        1.6 of 1, when one is; None otherwise.
    """

    ratio: float
    read_as: str
    fits: str | None

    @property
    def off(self) -> bool:
        """The ratio lies beyond :data:`SPREAD_MISMATCH` either way (a NaN ratio is not off: nothing to say)."""
        return bool(self.ratio > SPREAD_MISMATCH or self.ratio < 1.0 / SPREAD_MISMATCH)


def _spread(c: np.ndarray) -> float:
    c = c[np.all(np.isfinite(c), axis=1)]
    return float(np.sqrt(np.sum(np.var(c, axis=0)))) if len(c) >= 2 else math.nan


def check_spread(cop_ref_cm: ArrayLike, cop_cm: ArrayLike, read_as: str = "cm") -> SpreadCheck:
    """How far the platform's CoP spreads against the mat's, over the same aligned window.

    Parameters
    ----------
    cop_ref_cm : array_like, (N, 2)
        The platform's CoP (cm as read; M-L, A-P), inside the aligned window; rows with NaN left out.
    cop_cm : array_like, (M, 2)
        The mat's CoP (cm) over the same window.
    read_as : str
        The unit the platform's numbers were read in (``ForcePlateRecording.meta["unit"]``).

    Returns
    -------
    SpreadCheck
        ``ratio`` = spread(platform) / spread(mat), spread = sqrt(var(M-L) + var(A-P)).
    """
    ref = _checks.real_array(cop_ref_cm, "cop_ref_cm", unit="cm", allow_nan=True)
    mat = _checks.real_array(cop_cm, "cop_cm", unit="cm", allow_nan=True)
    for name, a in (("cop_ref_cm", ref), ("cop_cm", mat)):
        if a.ndim != 2 or a.shape[1] != 2:
            raise ValueError(f"{name} must have shape (N, 2), got {a.shape}")
    s_mat = _spread(mat)
    ratio = _spread(ref) / s_mat if s_mat > 0 else math.nan
    fits = None
    if math.isfinite(ratio) and ratio > 0:
        written = cm_per_unit(read_as) / ratio  # cm per unit of what the numbers would be in for a ratio of 1
        near = [u for u in _UNITS if abs(math.log(LENGTH_UNITS_CM[u] / written)) < math.log(1.6)]
        fits = next((u for u in near if LENGTH_UNITS_CM[u] != cm_per_unit(read_as)), None)
    return SpreadCheck(ratio, read_as, fits)


def spread_question(name: str, check: SpreadCheck, cop_from: str = "the columns") -> str:
    """What to ask of the platform file ``name`` whose spread is off (``cop_from``: its
    ``ForcePlateRecording.meta["cop_from"]``): its unit, or, for a CoP from forces and moments, their units."""
    if cop_from != "the columns":
        return (f"are {name}'s forces in N and its moments in the unit their header names (N·m unless N·cm or "
                "N·mm), and is it this session's platform file?")
    if check.fits:
        return (f"is {name} in {check.fits}, read as {check.read_as}? (name the unit in its CoP columns' header, "
                f"e.g. x [{check.fits}])")
    return f"is {name}'s unit ({check.read_as}) right, and is it this session's platform file?"

"""Posture (thesis chapter 4, docs/spec.md §8): the spine's shape from the back IMUs.

:func:`spine_points` is eq. 4.4 (chained circular arcs, sensor 1 at the origin);
:func:`psmat.posture.plots.plot_spine` draws the spine over time (Fig. 4.8).
"""

from .spine import N_SENSORS, SPACING_MM, spine_points

__all__ = ["spine_points", "N_SENSORS", "SPACING_MM"]

"""Regions of a pressure image (docs/spec.md §7 "Regions"): feet, seat, or the user's own masks.

* :func:`foot_masks` — left and right foot (split along M-L at the widest empty gap; left is the
  smaller ``x``), and each foot's rearfoot, midfoot and forefoot (thirds of its length along A-P,
  rearfoot at the smaller ``y``);
* :func:`seat_masks` — left and right ischial regions, sacrum and thighs of a seated person;
* :func:`region_table` — per region and frame: force (N), peak and mean pressure (kPa), contact
  area (cm²), CoP (cm); per trial: pressure–time and force–time integrals (:class:`RegionResults`,
  :class:`Region`);
* seat indices: :func:`peak_pressure_index_kpa` (:class:`PeakPressureIndex`),
  :func:`dispersion_index_pct`, :func:`coefficient_of_variation`.

Masks are dicts of name -> (R, C) bool arrays; a user's own dict is accepted wherever masks are.
Coordinates are the geometry's (:class:`psmat.profile.Geometry`), the subject facing ``+y``.
Each lives in a private module of this package; the names below are the package's API.
"""

from ._common import DEFAULT_THRESHOLD_KPA
from ._indices import PeakPressureIndex, coefficient_of_variation, dispersion_index_pct, peak_pressure_index_kpa
from ._masks import FOOT_REGIONS, SEAT_REGIONS, foot_masks, seat_masks
from ._table import Region, RegionResults, region_table

__all__ = ["foot_masks", "seat_masks", "FOOT_REGIONS", "SEAT_REGIONS", "region_table", "Region", "RegionResults",
           "peak_pressure_index_kpa", "PeakPressureIndex", "dispersion_index_pct", "coefficient_of_variation",
           "DEFAULT_THRESHOLD_KPA"]

"""Balance (thesis chapter 3, docs/spec.md §7): centre of pressure and the thesis' metrics.

* :func:`cop` — the centre of pressure of pressure images, on the cell centres of a device
  profile's geometry (:class:`psmat.profile.Geometry`; by default the thesis' mat, cell (i, p)
  at :func:`cell_centres_cm`);
* :func:`eu` — the thesis' distance between two CoP traces (eq. 3.1);
* :func:`sway` — the posturography metrics of a trace (:class:`Sway`);
* :func:`descriptors` — the 72 posturography descriptors of Quijoux et al. (2021), preset
  ``quijoux2021`` (SWARII to 25 Hz, 10 Hz zero-phase low-pass), keyed by the paper's names, and
  the unit of each (:func:`descriptor_unit`);
* :func:`ispgr` — the ISPGR acquisition recommendation (at least 25 s, at least 50 Hz);
* :func:`preprocess` — a trace through that preset's resampling and low-pass, not centred (the
  study's one preprocessing for mat and platform); :func:`describe_preset` says it in words;
* :func:`conditions` — the conditions a session's markers cut a trial into (:class:`Condition`),
  :func:`load_events_csv`, :func:`romberg_role` and :func:`romberg` (the quotient eyes closed / open);
  :func:`frame_clock` (markers from the host clock to the frame clock), :func:`off_the_clock` (markers
  on another clock than the recording's), :func:`condition_spans`
  (the conditions inside an analysed window) and :func:`inside` (the samples of one);
* :func:`align` — the time alignment of the mat with a force platform (:class:`Alignment`),
  built on :func:`search_lag`, psmat's one cross-correlation search; :func:`check_spread` — whether the
  platform's CoP moves as far as the mat's (a platform file read in another unit: :class:`SpreadCheck`);
* :func:`scale_factor` — the SCHC factor of eq. 3.3; :func:`scale_factors` — the full mat's and
  its emulated 8×8 mats' at once;
* :func:`equilibrate` — a per-cell gain map learned from a standing trial (beyond the thesis:
  the SCHC-EQ variant);
* :func:`subgrids` — the emulated coarser mat (thesis §3.2.1, the 8×8 variants);
* :func:`variant_traces` — the thesis' processing variants (Tables 3.2, 3.4) as recipes on
  the products of the one chain (:mod:`psmat.process`), and their names (:func:`describe`).

Each lives in a private module of this package (``_cop.py``, ``_sway.py``, ...); the names
below are the package's API.
"""

from ._align import (PLATFORM_AXES, POOR_ALIGNMENT_R, Alignment, align, find_platform_axes, orient_platform,
                     pearson_at_lag, resample_standardised, search_lag)
from ._cop import cell_centres_cm, cop
from ._conditions import (NEAR_S, UNMARKED, Condition, condition_spans, conditions, frame_clock, inside,
                          load_events_csv, off_the_clock, romberg, romberg_role)
from ._descriptor_units import descriptor_unit
from ._descriptors import descriptors
from ._emulate import Subgrid, subgrid_cops, subgrids
from ._equilibrate import Equilibration, equilibrate
from ._eu import eu
from ._ispgr import ISPGR_MIN_HZ, ISPGR_MIN_S, ispgr
from ._preprocess import describe_preset, preprocess
from ._scale import mean_force_n, scale_factor, scale_factors
from ._spread import SPREAD_MISMATCH, SpreadCheck, check_spread, spread_question
from ._sway import Sway, mean_frequency, prediction_ellipse_area, sway
from ._variants import (BASE_VARIANTS, EXTRA_VARIANTS, KNOWN_VARIANTS, VARIANTS, VariantName, VariantTrace, describe,
                        legend_label, variant_traces)

__all__ = ["cop", "cell_centres_cm", "eu", "sway", "Sway", "descriptors", "descriptor_unit", "ispgr", "ISPGR_MIN_S", "ISPGR_MIN_HZ", "preprocess",
           "prediction_ellipse_area", "mean_frequency",
           "align", "Alignment", "POOR_ALIGNMENT_R", "PLATFORM_AXES", "orient_platform", "find_platform_axes", "search_lag", "pearson_at_lag", "resample_standardised", "scale_factor", "scale_factors",
           "mean_force_n", "equilibrate", "Equilibration", "Subgrid", "subgrids", "subgrid_cops", "BASE_VARIANTS",
           "VARIANTS", "EXTRA_VARIANTS", "KNOWN_VARIANTS", "VariantName", "describe", "legend_label", "VariantTrace",
           "variant_traces", "Condition", "conditions", "load_events_csv", "romberg_role", "romberg", "frame_clock",
           "condition_spans", "inside", "UNMARKED", "describe_preset", "off_the_clock", "NEAR_S",
           "check_spread", "SpreadCheck", "SPREAD_MISMATCH", "spread_question"]

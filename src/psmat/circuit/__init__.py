"""The measurement chain (docs/spec.md §2): counts <-> equivalent conductance through the
readout circuit, a box's calibration (R_adc, R_mux) as data, and its estimate from open- and
short-circuit recordings.

* :class:`Circuit` — the chain both ways (``counts``, ``conductance``, ``voltage``), its flags
  ``OK``, ``SHORT``, ``OPEN``; ``Circuit().calibrated(cal)`` applies a calibration.
* :class:`Calibration` — a box's R_adc and R_mux with their statistics, saved as JSON.
* :func:`estimate_r_adc`, :func:`estimate_r_mux`, :func:`from_open_circuit`,
  :func:`from_short_circuit`, :func:`from_recordings` — their estimates.
"""

from ._calibration import Calibration, OpenCircuitStats, ShortCircuitStats
from ._circuit import FIRST_PROTOTYPE_R_ADC, IMPROVED_PROTOTYPE_R_ADC, OK, OPEN, SHORT, Circuit
from ._adc_width import MIN_ADC_BITS, narrower_adc
from ._estimate import estimate_r_adc, estimate_r_mux, from_open_circuit, from_recordings, from_short_circuit

__all__ = [
    "Circuit", "OK", "SHORT", "OPEN", "FIRST_PROTOTYPE_R_ADC", "IMPROVED_PROTOTYPE_R_ADC",
    "Calibration", "OpenCircuitStats", "ShortCircuitStats",
    "estimate_r_adc", "estimate_r_mux", "from_open_circuit", "from_short_circuit", "from_recordings",
    "narrower_adc", "MIN_ADC_BITS",
]

"""Pressure calibration of a mat (docs/spec.md §4 "Pressure calibration"): from relative to absolute kPa.

The nominal sensor model (thesis Table 2.11) was fitted on small pneumatic samples; a large
mat's cells differ from them and from each other (the thesis found its mat 1.3–4× more
conductive, §3.2.2), so the kPa the nominal model gives look absolute but are not.

* :class:`PressureCalibration` — a mat's calibration as data: a fitted sensor model, per-cell
  gains, a global scale, each dated; :meth:`~PressureCalibration.describe` says in one line what
  made the kPa (:func:`describe` also for no calibration). The chain (:class:`psmat.process.Processor`)
  applies it; ``psmat calibrate`` stores it in the calibration file under ``"pressure"``.
* :func:`equilibrate` — per-cell gains from uniform loads of known level (:class:`EquilibrationResult`).
* :func:`known_load` — a global factor from a known load (eq. 3.3 generalised).

The inputs are cell conductances after IECM (S, (T, R, C)): this package does not run the
chain (:mod:`psmat.process` runs it and applies the calibration).
"""

from ._calibration import PressureCalibration, describe, utc_now
from ._equilibrate import EquilibrationResult, equilibrate
from ._known_load import known_load

__all__ = ["PressureCalibration", "describe", "utc_now", "EquilibrationResult", "equilibrate", "known_load"]

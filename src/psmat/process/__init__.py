"""From ADC counts to pressure and centre of pressure: the mat's one processing chain.

counts ─ :meth:`Circuit.conductance` (docs/spec.md §2) → G ─ :func:`psmat.iecm.solve` (crosstalk
removed to a relative residual of :data:`IECM_RTOL`, docs/spec.md §3) → g ─ :meth:`MPICreep.inverse`
(hysteresis and creep compensated, docs/spec.md §4) → pressure ─ :func:`psmat.balance.cop`
(docs/spec.md §7) → CoP.

* :class:`Processor` is the chain on a stream: frames are pushed in chunks as they arrive and
  the state carried between chunks (the IECM warm start and preconditioner, the sensor
  model's operator state, the time since the last usable frame), so chunked pushes give the
  numbers of one push; the live view (:mod:`psmat.live`) pushes the frames it shows.
* :func:`process_counts` is one push of a whole recording held in memory.
* :func:`process_loaded` is the one way a recorded session goes through the chain: its frame
  clock (:func:`session_clock`: each frame's own period, so the sensor model steps over a lost
  frame by its real interval), its circuit (:func:`session_circuit`: the stored calibration
  first), its valid flags. :func:`process_session` runs it on a session file and stores G, g,
  pressure (kPa) and CoP beside the raw counts with the parameters that made them
  (docs/spec.md §6); a balance study (:func:`psmat.study.process_trial`) and the posture study
  run it on the sessions they load.
* :func:`session_pressure` is a session's pressure images in kPa whatever made them (a mat's
  session through :func:`process_loaded`, an imported ``"pressure"`` session as stored), with one
  line saying how (:class:`PressureRecord`); :func:`session_pressure_calibration` is the mat's
  pressure calibration the chain uses for a session.
* :func:`adc_line` says when a session's counts fit a narrower ADC than its circuit's (a 10-bit
  board under a 12-bit profile: every empty cell would read as a loaded one).

Readings the chain cannot use are handled one way everywhere, never turned into silent
infinities:

* an **open** reading (at or above the open-circuit count: an unloaded cell whose resistance
  is beyond what the ADC resolves) is the **open floor** in every product: the smallest
  conductance the circuit can report (:func:`open_floor`, ``Circuit`` at the largest
  non-open count). IECM needs a positive G there, and the same G gives the raw CoP, so the
  raw CoP is the CoP of the stored G; the bias is at most the floor (about 8e-8 S with the
  default circuit) per open cell, against about 1e-3 S on a loaded cell;
* a **short** reading, or a frame that failed its check on the wire (``valid`` False),
  makes the whole frame **missing**: NaN in every product, the time base kept. The sensor
  model does not see it; the next usable frame is stepped with the whole time since the
  previous usable one (its period plus the missing frames'), because the sensor creeps on
  while a frame is lost (eq. 2.23 with the pressure held).
"""

from ..units import PSI_KPA
from ._adc import adc_hint, adc_line
from ._chain import IECM_RTOL, Processed, Processor, open_floor, process_counts
from ._clock import SessionClock, session_clock
from ._pressure import PressureRecord, session_pressure
from ._session import process_loaded, process_session, session_circuit, session_pressure_calibration

__all__ = ["IECM_RTOL", "Processed", "Processor", "process_counts", "process_loaded", "process_session",
           "session_circuit", "session_pressure", "session_pressure_calibration", "PressureRecord", "session_clock",
           "SessionClock", "open_floor", "PSI_KPA", "adc_line", "adc_hint"]

"""Simulated studies (docs/spec.md §6 layout, §7 "Honest simulation", §8 "Data"): study folders written
through the digital twin (:mod:`psmat.twin`) with mats, boxes and clocks the processing does not know.

What the simulator knows and a lab does not goes to ``DIR/truth/``, which nothing but the evaluation
of the simulation reads; the studies (:mod:`psmat.study`, :mod:`psmat.posture`) read the rest as
they would a lab's, and never import the twin.

* :func:`simulate_study` — a balance study: real sway (the BDS force-platform trajectories) on the
  standing twin, three trials per volunteer with a force platform beside the mat (``_balance``,
  its trials in ``_balance_trials``);
* :func:`simulate_posture_study` — a posture study: the seated twin following the thesis'
  protocol once a day, the cushion's mat and the spine IMUs on one host clock (``_posture``).

What both share, written once: each subject's own mat and DAQ box, calibrated as ``psmat calibrate``
would, the host clock and the mat's frames written chunk by chunk (``_lab``, draws in ``_draws``),
and the truth files, the same bytes for the same seed (``_truth``).
"""

from ._balance import TRIALS, simulate_study
from ._lab import NOISE_V, PITCH_CM
from ._posture import IMU_RATE_HZ, TRUTH_README, simulate_posture_study

__all__ = ["simulate_study", "TRIALS", "simulate_posture_study", "IMU_RATE_HZ", "TRUTH_README", "PITCH_CM",
           "NOISE_V"]

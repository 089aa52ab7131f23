"""The seated twin (docs/spec.md §8 "Data"): one posture trajectory drives the cushion and the spine IMUs.

A :class:`SeatedSession` (:func:`seated_session`) is a person of thesis Table 4.2 following the
posture protocol for one session. Its posture gives, at any instants, the cushion's pressure
(:meth:`SeatedSession.pressure`, a :class:`~psmat.twin.PressureScene` in psi for
:class:`~psmat.twin.MatPhysics`) and the five IMUs' true readings
(:meth:`SeatedSession.true_angles`), to which :func:`imu_readings` adds the device's drift and
noise; :func:`imu_packets` sends them through the IMU firmware core.

Private modules, one concept each:

* ``_subject`` — who sits (:func:`draw_seated_subject`) and what changes from day to day
  (:func:`draw_seated_day`); every number with its source;
* ``_protocol`` — the thesis' protocol as a posture over time (:func:`posture_trajectory`);
* ``_body`` — the back's pitch along the spine and the moment balance that loads the cushion
  (:func:`back_pitch_deg`, :func:`sensor_sites`, :func:`seat_targets`);
* ``_seat`` — the seat on the mat and its load shared between tuberosities, thighs and sacrum;
* ``_scenes`` — a seat's frames (:func:`seat_scene`) and the twin's ``"sitting"`` scene (:func:`sitting`);
* ``_imu`` — the five BNO055 on the back: true angles, drift, noise, 1/16° steps;
* ``_wire`` — the bytes the back device sends (:func:`imu_packets`, :func:`imu_identity`);
* ``_session`` — :class:`SeatedSession`, the one trajectory behind both streams.
"""

from ._body import HAT_SHARE, SeatTargets, back_pitch_deg, hat_offset_cm, seat_targets, sensor_sites
from ._imu import DRIFT_SD_DEG, DRIFT_TAU_S, EULER_LSB_DEG, ImuDevice, draw_imu_device, imu_readings, true_angles
from ._protocol import GRID_HZ, Phase, PostureState, PostureTrajectory, posture_trajectory, protocol_phases
from ._scenes import seat_scene, sitting
from ._seat import SeatLayout, SeatLoad, render_seat, seat_layout, share_load
from ._session import SeatedSession, seated_session
from ._subject import (KNOTS_V, TABLE_4_2, UPRIGHT_PITCH_DEG, SeatedDay, SeatedSubject, draw_seated_day,
                       draw_seated_subject)
from ._wire import imu_identity, imu_packets

__all__ = [
    # a session
    "SeatedSession", "seated_session",
    # who sits, and the day
    "SeatedSubject", "SeatedDay", "draw_seated_subject", "draw_seated_day", "TABLE_4_2", "KNOTS_V",
    "UPRIGHT_PITCH_DEG",
    # the protocol
    "Phase", "PostureState", "PostureTrajectory", "protocol_phases", "posture_trajectory", "GRID_HZ",
    # the body and the cushion
    "back_pitch_deg", "sensor_sites", "hat_offset_cm", "SeatTargets", "seat_targets", "HAT_SHARE",
    "SeatLayout", "SeatLoad", "seat_layout", "share_load", "render_seat", "seat_scene", "sitting",
    # the spine IMUs and their device
    "ImuDevice", "draw_imu_device", "true_angles", "imu_readings", "EULER_LSB_DEG", "DRIFT_SD_DEG", "DRIFT_TAU_S",
    "imu_packets", "imu_identity",
]

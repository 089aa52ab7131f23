"""The spine IMUs of the seated twin (thesis §4.2, docs/spec.md §5 and §8): what five BNO055 read on a back.

Each sensor reports Euler angles (heading, roll, pitch) in degrees, the layout of
:data:`psmat.protocol.IMU_SHAPE`. At its site ``v`` on the back (:func:`~psmat.twin.seated._body.sensor_sites`):

* **pitch** = the back's pitch there (:func:`~psmat.twin.seated._body.back_pitch_deg`) + the
  sensor's mounting offset;
* **roll** = the trunk's sideways lean × (0.5 + 0.5 v) (the lean grows up the back; our choice)
  + the mounting offset;
* **heading** = the room's heading + the seat's turn on the cushion + the mounting offset,
  in [0, 360).

These are the true readings (:func:`true_angles`). What the device sends (:func:`imu_readings`)
adds to each angle a slow drift — an Ornstein–Uhlenbeck process from 0 at power-on with a
stationary SD of 0.25° and a 120 s time constant in pitch and roll (the BNO055's fusion
references them to gravity, so the error stays bounded instead of growing as a gyroscope's
integral), 2° and 300 s in heading (the magnetometer's reference is weaker indoors) — and white
noise of 0.1–0.3° SD per sensor (drawn once per device), then rounds to the BNO055's Euler
resolution, 1/16° (BNO055 datasheet, Euler data: 1° = 16 LSB). Our choices where not cited.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.signal import lfilter

from ...spine import N_SENSORS
from ._protocol import PostureState
from ._body import back_pitch_deg, sensor_sites
from ._subject import SeatedDay, SeatedSubject

__all__ = ["ImuDevice", "draw_imu_device", "true_angles", "imu_readings", "EULER_LSB_DEG", "DRIFT_SD_DEG",
           "DRIFT_TAU_S"]

#: The BNO055's Euler angle resolution, degrees per LSB.
EULER_LSB_DEG = 1.0 / 16.0
#: Stationary SD (degrees) and time constant (s) of the drift of (heading, roll, pitch).
DRIFT_SD_DEG = (2.0, 0.25, 0.25)
DRIFT_TAU_S = (300.0, 120.0, 120.0)
#: Range of the white noise SD per sensor, degrees.
NOISE_SD_DEG = (0.1, 0.3)


@dataclass(frozen=True)
class ImuDevice:
    """The back device: its serial, each sensor's noise SD (degrees), its clock's error on the sample period."""

    serial: str
    noise_deg: tuple[float, ...]
    clock_error: float

    def as_dict(self) -> dict[str, Any]:
        d = asdict(self)
        d.update(drift_sd_deg=list(DRIFT_SD_DEG), drift_tau_s=list(DRIFT_TAU_S), euler_lsb_deg=EULER_LSB_DEG)
        d["noise_deg"] = list(self.noise_deg)
        return d


def draw_imu_device(rng: np.random.Generator, serial: str) -> ImuDevice:
    """Noise SD per sensor uniform in 0.1–0.3°; the clock off by 2 ppm–1e-3 (log-uniform, either sign: an
    RC oscillator at worst, as the balance study's boxes, :mod:`psmat.synth`)."""
    noise = tuple(float(x) for x in rng.uniform(*NOISE_SD_DEG, N_SENSORS))
    err = float(np.exp(rng.uniform(np.log(2e-6), np.log(1e-3)))) * (1.0 if rng.random() < 0.5 else -1.0)
    return ImuDevice(serial, noise, err)


def true_angles(subject: SeatedSubject, day: SeatedDay, state: PostureState) -> NDArray[np.float64]:
    """The five sensors' true (noise- and drift-free) readings (T, 5, 3): heading, roll, pitch in degrees."""
    v = sensor_sites(subject, day)
    n = state.lean.size
    out = np.empty((n, N_SENSORS, 3))
    out[:, :, 2] = back_pitch_deg(subject, state, v) + day.mount_deg[None, :, 2]
    out[:, :, 1] = state.lateral_deg[:, None] * (0.5 + 0.5 * v)[None, :] + day.mount_deg[None, :, 1]
    out[:, :, 0] = np.mod(day.room_heading_deg + day.seat_rotation_deg + day.mount_deg[None, :, 0]
                          + np.zeros((n, 1)), 360.0)
    return out


def imu_readings(true: NDArray[np.float64], rate_hz: float, device: ImuDevice,
                 rng: np.random.Generator) -> tuple[NDArray[np.float32], NDArray[np.float64]]:
    """What the device reads for true angles (T, 5, 3) sampled at ``rate_hz``: drift, noise, 1/16° steps.

    Returns
    -------
    angles : ndarray, (T, 5, 3) float32
        Degrees, heading wrapped to [0, 360).
    drift : ndarray, (T, 5, 3)
        The drift added (degrees).
    """
    n = true.shape[0]
    drift = np.empty_like(true)
    for c in range(3):
        a = np.exp(-1.0 / (rate_hz * DRIFT_TAU_S[c]))
        xi = rng.standard_normal((n, N_SENSORS)) * (DRIFT_SD_DEG[c] * np.sqrt(1.0 - a * a))
        drift[:, :, c] = lfilter([1.0], [1.0, -a], xi, axis=0)  # x_k = a·x_{k−1} + ξ_k, from x_{−1} = 0
    noise = rng.standard_normal(true.shape) * np.asarray(device.noise_deg)[None, :, None]
    out = np.round((true + drift + noise) / EULER_LSB_DEG) * EULER_LSB_DEG
    out[:, :, 0] = np.mod(out[:, :, 0], 360.0)
    return out.astype(np.float32), drift

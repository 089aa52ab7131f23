"""What the honest simulations draw per subject (docs/spec.md §7 "Honest simulation", §8): the mat and
the DAQ box (both studies, :func:`psmat.synth._lab.equip`) and a balance study's volunteer. Each
choice and its source is stated in :mod:`psmat.synth._balance`; the numbers live here.

Everything is drawn from a :class:`numpy.random.Generator` handed in by the caller, so a
subject's draws depend only on the study seed and the subject's index.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..circuit import Calibration, Circuit, from_recordings
from ..sensor import THESIS_TABLE_2_11, MPICreep

__all__ = ["Person", "Box", "MatDraw", "draw_person", "draw_box", "draw_mat", "calibrate_box"]

#: Thesis Table 3.1 (first experiment, 42 volunteers): share of men and, per sex, mean and SD
#: of height (cm), weight (kg) and age (years).
TABLE_3_1 = {
    "men": 29 / 42,
    "M": {"height_cm": (178.0, 7.0), "weight_kg": (81.36, 14.21), "age": (33.55, 12.47)},
    "F": {"height_cm": (164.0, 6.0), "weight_kg": (58.54, 7.21), "age": (26.00, 11.91)},
}
#: Limits of the drawn body data (healthy adults standing on a 32 cm mat).
LIMITS = {"height_cm": (150.0, 200.0), "weight_kg": (45.0, 130.0), "age": (18, 70)}
#: Foot length and width as fractions of stature (Winter, Biomechanics and Motor Control of
#: Human Movement, Fig. 4.1, after Drillis & Contini 1966).
FOOT_LENGTH_PER_HEIGHT = 0.152
FOOT_WIDTH_PER_HEIGHT = 0.055

#: The large mat is 1.3–4× more conductive than the pneumatic fit (thesis §3.2.2, eq. 3.3 with
#: f brute-forced in [0.25, 0.75]): every conductance term is scaled by 1/f, f drawn here.
F_RANGE = (0.25, 0.75)
#: Log-normal spread of the other parameters around the pneumatic fit (our choice: the fit of
#: one small array does not hold cell for cell on another, thesis §3.2.2).
SPREAD = {"conductance": 0.10, "tau": 0.10, "creep_rate": 0.20}
#: Cell-to-cell gain (log-normal SD): up to the CV of Velostat in the fast cyclic test, thesis
#: Table 2.5 (CV² = 0.108 → CV = 0.33, which also holds the pulse-to-pulse part).
VARIABILITY = (0.15, 0.33)
#: Each box's R_mux (Ω): "estimated for each box independently (typical ... 145 Ω)", thesis
#: §2.2.1; drawn log-uniform around it. Channel mismatch (SD per row and per column line, Ω):
#: "all the channels have the same value for practical purposes" (thesis §2.1.4) — a few Ω.
R_MUX_RANGE = (100.0, 210.0)
R_MUX_CHANNEL_SD = 2.5
#: The ADC's input resistance of the improved prototype, 6.9 MΩ (docs/spec.md §2), ±25 % per box.
R_ADC_RANGE = (6.9e6 * 0.8, 6.9e6 * 1.25)
#: Error of the box's clock on the frame period (crystal to RC oscillator), log-uniform, either sign.
CLOCK_ERROR = (2e-6, 1e-3)
#: Frames lost on the wire per frame, drawn per box ("a few" in a 60 s session at 100 Hz).
LOSS_RATE = (0.0, 2e-4)
#: ``psmat calibrate`` defaults: 1 s per step, the four corner pairs shorted, CAL_HOLD (v2).
CALIBRATION_SECONDS = 1.0
#: A wire shorting a row to a column (S): the digital twin's calibration fixture.
WIRE_S = 1e6


@dataclass(frozen=True)
class Person:
    """A volunteer: sex ``"M"``/``"F"``, age (years), height (cm), weight (kg, as in subjects.csv)."""

    sex: str
    age: int
    height_cm: float
    weight_kg: float

    @property
    def foot_length_cm(self) -> float:
        return FOOT_LENGTH_PER_HEIGHT * self.height_cm

    @property
    def foot_width_cm(self) -> float:
        return FOOT_WIDTH_PER_HEIGHT * self.height_cm

    def as_dict(self) -> dict[str, Any]:
        return {"sex": self.sex, "age": self.age, "height_cm": self.height_cm, "weight_kg": self.weight_kg,
                "foot_length_cm": self.foot_length_cm, "foot_width_cm": self.foot_width_cm}


@dataclass(frozen=True)
class MatDraw:
    """A volunteer's mat: its sensor model, cell-to-cell spread and the factor that scaled it."""

    sensor: MPICreep
    conductance_scale: float  # 1/f: how much more conductive than the pneumatic fit
    variability: float  # log-normal SD of the cell gains

    def as_dict(self) -> dict[str, Any]:
        p = self.sensor.params
        return {"sensor": {k: list(v) if isinstance(v, tuple) else v for k, v in p.items()},
                "conductance_scale": self.conductance_scale, "f_expected": 1.0 / self.conductance_scale,
                "variability": self.variability}


@dataclass(frozen=True, eq=False)
class Box:
    """A volunteer's DAQ box: serial, true R_mux per pair (Ω), R_adc (Ω), clock and losses."""

    serial: str
    r_mux: NDArray[np.float64]  # (R, C) Ω, both mux channels of each pair in series
    r_adc: float
    clock_error: float  # true frame period = nominal · (1 + clock_error)
    counter_start_us: int  # the MCU's µs counter at the first frame of the first session
    loss_rate: float

    def circuit(self) -> Circuit:
        """The box's true measurement chain (docs/spec.md §2 defaults otherwise)."""
        return Circuit(r_mux=self.r_mux, r_adc=self.r_adc)

    def as_dict(self) -> dict[str, Any]:
        return {"serial": self.serial, "r_mux_ohm_median": float(np.median(self.r_mux)),
                "r_mux_ohm_spread": float(np.std(self.r_mux)), "r_adc_ohm": self.r_adc,
                "clock_error": self.clock_error, "counter_start_us": self.counter_start_us,
                "loss_rate": self.loss_rate}


def _normal(rng: np.random.Generator, mean_sd: tuple[float, float], lo: float, hi: float) -> float:
    return float(np.clip(rng.normal(*mean_sd), lo, hi))


def draw_person(rng: np.random.Generator) -> Person:
    """Sex, then height, weight and age from that sex's row of thesis Table 3.1 (clipped to :data:`LIMITS`)."""
    sex = "M" if rng.random() < TABLE_3_1["men"] else "F"
    row = TABLE_3_1[sex]
    height = round(_normal(rng, row["height_cm"], *LIMITS["height_cm"]), 1)
    weight = round(_normal(rng, row["weight_kg"], *LIMITS["weight_kg"]), 1)
    age = int(round(_normal(rng, row["age"], *LIMITS["age"])))
    return Person(sex, age, height, weight)


def draw_mat(rng: np.random.Generator) -> MatDraw:
    """The pneumatic fit (Table 2.11) made ``1/f`` times more conductive, with a spread on every parameter.

    The polynomial ``a1, a2, a3`` keeps its shape (one factor), ``rho`` and each ``w_i`` get
    their own; draws whose model is not monotone on [0, p_max] are drawn again.
    """
    base = THESIS_TABLE_2_11
    while True:
        f = float(rng.uniform(*F_RANGE))
        k = 1.0 / f
        lg = lambda sd: float(np.exp(sd * rng.standard_normal()))  # noqa: E731 - one log-normal factor
        poly = k * lg(SPREAD["conductance"])
        p = {
            "rho": base["rho"] * k * lg(SPREAD["conductance"]),
            "tau": base["tau"] * lg(SPREAD["tau"]),
            "a1": base["a1"] * poly, "a2": base["a2"] * poly, "a3": base["a3"] * poly,
            "l": tuple(v * lg(SPREAD["creep_rate"]) for v in base["l"]),
            "w": tuple(v * k * lg(SPREAD["conductance"]) for v in base["w"]),
        }
        sensor = MPICreep(**p)
        variability = float(rng.uniform(*VARIABILITY))
        if not sensor.invertibility_problem():
            return MatDraw(sensor, k, variability)


def draw_box(rng: np.random.Generator, serial: str, shape: tuple[int, int]) -> Box:
    """R_mux (log-uniform, plus a per-line mismatch), R_adc, the clock's error and start, the loss rate."""
    lo, hi = R_MUX_RANGE
    base = float(np.exp(rng.uniform(math.log(lo), math.log(hi))))
    rows = rng.normal(0.0, R_MUX_CHANNEL_SD, shape[0])
    cols = rng.normal(0.0, R_MUX_CHANNEL_SD, shape[1])
    r_mux = base + rows[:, None] + cols[None, :]
    r_adc = float(rng.uniform(*R_ADC_RANGE))
    e_lo, e_hi = CLOCK_ERROR
    err = float(np.exp(rng.uniform(math.log(e_lo), math.log(e_hi)))) * (1.0 if rng.random() < 0.5 else -1.0)
    counter = int(rng.integers(20_000_000, 900_000_000))  # 20 s .. 15 min after power-on
    loss = float(rng.uniform(*LOSS_RATE))
    return Box(serial, r_mux, r_adc, err, counter, loss)


def calibrate_box(box: Box, shape: tuple[int, int], rate_hz: float, noise_v: float, rng: np.random.Generator,
                  date: str) -> Calibration:
    """What ``psmat calibrate`` would give for this box: the real estimator on simulated recordings.

    Open circuit: every cell open for :data:`CALIBRATION_SECONDS`; then each corner pair shorted
    by a wire with the box in CAL_HOLD (every reading of the frame samples that pair), through
    the box's true chain with ``noise_v`` on the ADC node (:func:`psmat.circuit.from_recordings`).
    """
    R, C = shape
    n = max(2, int(round(CALIBRATION_SECONDS * rate_hz)))
    true = box.circuit()
    open_counts = true.counts(np.zeros((n, R, C)), noise_v=noise_v, rng=rng)
    pairs = sorted({(0, 0), (0, C - 1), (R - 1, 0), (R - 1, C - 1)})
    shorts = {}
    for i, p in pairs:
        held = Circuit(r_mux=float(box.r_mux[i, p]), r_adc=box.r_adc)
        shorts[(i, p)] = held.counts(np.full(n * R * C, WIRE_S), noise_v=noise_v, rng=rng)
    notes = (f"simulated: psmat calibrate, {len(pairs)} shorted pair(s), {CALIBRATION_SECONDS:g} s per step "
             "(psmat.synth)")
    return from_recordings(box.serial, open_counts, shorts, Circuit(), shape=shape, date=date, notes=notes)

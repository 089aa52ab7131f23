"""What both simulated studies share (docs/spec.md §6, §7, §8): the study folder, each subject's own
mat and box, the host clock, and the mat's frames written chunk by chunk.

* :func:`new_root` — a simulated study is written into a new (or empty) folder, never over one;
* :func:`write_subjects` — ``DIR/subjects.csv``;
* :func:`equip` — a subject's mat (sensor model, cell spread) and DAQ box (R_mux, R_adc, clock,
  losses), the box calibrated as ``psmat calibrate`` would (``DIR/calibration/<serial>.json``), the
  mat's physics through the box's true chain (:class:`MatKit`; its truth by :meth:`MatKit.save_truth`);
* :func:`host_times` — when each sample reaches the host (USB latency, never backwards);
* :class:`MatTally` and :func:`write_mat_chunk` — a chunk of pressure frames through the mat into
  the session, lost frames kept as the reader keeps them, and what the pressure did.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Protocol

import numpy as np
from numpy.typing import NDArray

from ..circuit import Calibration
from ..profile import load_profile
from ..twin import MatPhysics, PressureScene
from ._draws import Box, MatDraw, calibrate_box, draw_box, draw_mat
from ._truth import save_npz_stable, truth_json

__all__ = ["PITCH_CM", "NOISE_V", "new_root", "write_subjects", "MatKit", "equip", "host_times", "MatTally",
           "write_mat_chunk"]

#: The simulated lab's mats: the thesis' (docs/spec.md §1), recorded with its profile as ``psmat record`` does.
MAT_PROFILE = "psm16"
#: Cell pitch of the simulated mats (cm): the profile's, 16 × 16 cells on 32 cm.
PITCH_CM = float(load_profile(MAT_PROFILE).pitch_cm)
#: ADC-node noise (V): docs/spec.md §10 "noisy", thesis Table 2.4.
NOISE_V = 1e-3


def new_root(root: str | os.PathLike[str], what: str) -> Path:
    """``root`` if it does not exist or is an empty folder, else FileExistsError (a study is never overwritten)."""
    out = Path(root)
    if out.exists() and (not out.is_dir() or any(out.iterdir())):
        raise FileExistsError(f"{out} exists and is not an empty folder; {what} needs a new one")
    return out


class _Body(Protocol):
    weight_kg: float
    height_cm: float
    age: int
    sex: str


def write_subjects(out: Path, ids: list[str], people: list[_Body]) -> None:
    """``out/subjects.csv``: subject, weight (kg, 0.1), height (cm, 0.1), age, sex (docs/spec.md §6)."""
    rows = "".join(f"{i},{p.weight_kg:.1f},{p.height_cm:.1f},{p.age},{p.sex}\n" for i, p in zip(ids, people))
    (out / "subjects.csv").write_text("subject,weight_kg,height_cm,age,sex\n" + rows, encoding="utf-8")


@dataclass(frozen=True, eq=False)
class MatKit:
    """A subject's mat and box: what was drawn, the calibration a lab found, the mat's physics.

    Attributes
    ----------
    draw : MatDraw
        The mat's sensor model and cell spread.
    box : Box
        The DAQ box: R_mux, R_adc, its clock's error, the loss rate.
    calibration : Calibration
        What ``psmat calibrate`` gave for the box (written to ``DIR/calibration/<serial>.json``).
    mat : MatPhysics
        Pressure → counts through the box's true chain, at the box's true frame period.
    device : dict
        The box as its IDENTIFY reply describes it (what ``psmat record`` stores).
    profile : dict
        The mat's device profile (:data:`MAT_PROFILE` at the mat's shape), as ``psmat record`` stores it.
    """

    draw: MatDraw
    box: Box
    calibration: Calibration
    mat: MatPhysics
    device: dict[str, Any]
    profile: dict[str, Any]

    def truth(self, subject: str, person: dict[str, Any]) -> dict[str, Any]:
        """The subject's truth: person, mat, box and the calibration found (``truth/<folder>/<id>.json``)."""
        return {"subject": subject, "person": person,
                "mat": {**self.draw.as_dict(), "g_rest_s": self.mat.g_rest, "noise_v": NOISE_V, "bits": 12,
                        "pitch_cm": PITCH_CM},
                "box": self.box.as_dict(), "clock_rate": 1.0 / (1.0 + self.box.clock_error),
                "calibration_found": {"r_mux_ohm": self.calibration.r_mux, "r_adc_ohm": self.calibration.r_adc}}

    def save_truth(self, folder: Path, subject: str, truth: dict[str, Any]) -> None:
        """``folder/<subject>.json`` (``truth``) and ``.npz`` (``gain`` (R, C) and ``r_mux_ohm`` (R, C) per cell)."""
        (folder / f"{subject}.json").write_text(truth_json(truth), encoding="utf-8")
        save_npz_stable(folder / f"{subject}.npz", {"gain": self.mat.gain, "r_mux_ohm": self.box.r_mux})


def equip(out: Path, serial: str, rng_mat: np.random.Generator, rng_box: np.random.Generator,
          shape: tuple[int, int], rate_hz: float, date: str) -> MatKit:
    """Draw a subject's mat (``rng_mat``) and box (``rng_box``), calibrate the box as ``psmat calibrate``
    would on ``date`` (its file in ``out/calibration/``), and build the mat's physics.

    ``rng_box`` goes on to seed the mat's noise; the caller may keep drawing from it.
    """
    draw = draw_mat(rng_mat)
    box = draw_box(rng_box, serial, shape)
    cal = calibrate_box(box, shape, rate_hz, NOISE_V, rng_box, date)
    cal.save(out / "calibration" / f"{box.serial}.json")
    mat = MatPhysics(shape, dt=(1.0 / rate_hz) * (1.0 + box.clock_error), sensor=draw.sensor,
                     variability=draw.variability, circuit=box.circuit(), noise_v=NOISE_V,
                     seed=int(rng_box.integers(2**63)))
    device = {"device": "psm", "fw": "0.1.0", "rows": shape[0], "cols": shape[1],
              "rate": int(rate_hz) if float(rate_hz).is_integer() else rate_hz, "proto": 2, "serial": box.serial,
              "r_o": 2200, "v_ref": 3.3, "bits": 12, "pitch_cm": PITCH_CM}
    return MatKit(draw, box, cal, mat, device, load_profile(MAT_PROFILE).with_shape(shape).to_dict())


def host_times(t_s: NDArray[np.float64], host0_s: float, rng: np.random.Generator) -> NDArray[np.float64]:
    """Arrival on the host clock (s) of samples taken at ``t_s`` after ``host0_s``: 1 ms + exponential
    1 ms of USB latency, never backwards."""
    return np.maximum.accumulate(host0_s + t_s + 1e-3 + rng.exponential(1e-3, t_s.size))


@dataclass
class MatTally:
    """What a session's pressure did, over its chunks (the truth of a session)."""

    pressure_sum_psi: NDArray[np.float64]
    clipped_frames: int = 0  # frames whose CoP target the steering could not reach
    saturated: int = 0  # cell values above the sensor's p_max
    force_on_mat_min: float = 1.0  # least share of the force that fell on the mat

    @classmethod
    def empty(cls, shape: tuple[int, int]) -> "MatTally":
        return cls(np.zeros(shape))

    def add(self, scene: PressureScene, p_max: float) -> None:
        self.pressure_sum_psi += scene.pressure_psi.sum(axis=0)
        self.clipped_frames += int(scene.meta["n_clipped"])
        self.saturated += int(np.count_nonzero(scene.pressure_psi > p_max))
        self.force_on_mat_min = min(self.force_on_mat_min, float(np.min(scene.meta["force_on_mat_fraction"])))

    def saturated_fraction(self, frames: int) -> float:
        return self.saturated / (frames * self.pressure_sum_psi.size)


def write_mat_chunk(writer: Any, mat: MatPhysics, scene: PressureScene, sl: slice, host_s: NDArray[np.float64],
                    lost: NDArray[np.bool_], k: NDArray[np.int64], device_us: NDArray[np.int64],
                    tally: MatTally) -> None:
    """Frames ``sl`` of a session: ``scene``'s pressure through the mat, appended to ``writer``
    (:class:`psmat.io.SessionWriter`) with their host times, sequence numbers ``k`` and device times.

    A lost frame is kept as the reader keeps a frame that failed its check: counts 0, ``valid``
    False, no sequence number or device time (-1).
    """
    counts = mat.counts(scene.pressure_psi)
    ok = ~lost[sl]
    counts[~ok] = 0
    writer.append(counts, host_s[sl], ok, seq=np.where(ok, k[sl], -1), device_time_us=np.where(ok, device_us[sl], -1))
    tally.add(scene, mat.sensor.p_max)

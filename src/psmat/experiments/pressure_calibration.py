"""Measured in simulation: what the pressure calibration (``psmat calibrate equilibrate`` then
``psmat calibrate known-load``, docs/spec.md §4 "Pressure calibration") does to the kPa of a mat
the processing does not know.

Each case (a material × a seed × a sensitivity) is a twin mat (:class:`psmat.twin.MatPhysics`,
16×16 cells of 2 cm, 50 Hz): the material's sensor model (below) with per-cell log-normal gains
of SD ``--variability`` in log, drawn from the seed, on a global conductance factor
``--sensitivity`` (the thesis' large mat was 1.3–4× more conductive than its pneumatic samples,
§3.2.2). It is recorded as a lab
would record it, session files of ADC counts only (:class:`psmat.io.SessionWriter`; the truth
stays in memory): a uniform load at each of ``--levels-kpa`` (14 s, on at 1 s over 0.5 s), a
person of 70 kg standing still (:func:`psmat.twin.quiet_standing`, 12 s after 1 s unloaded,
the person's seed = the case's + 1), and a test recording of another person, 850 N on one leg
(:func:`psmat.twin.single_leg_sway`, ``--seconds`` after 1 s unloaded, seed = the case's + 2).

The calibration is made by the functions the ``psmat calibrate`` steps call
(:func:`psmat.workflows.calibrate_pressure.run_equilibrate`, then ``run_known_load`` with
70 kg × standard gravity) into a calibration file; the test recording is processed as ``psmat
process`` does (:func:`psmat.process.process_session`) without it and with it. The floor is the
same chain told the twin's truth (a calibration file whose pressure part is the inverse of the
twin's gains and, for a material other than ``nominal``, the twin's sensor model: a reference no
lab has); it is the chain's own error (ADC noise through IECM, the sensor model's saturation
under the heel).

Materials (``--material``): the twin's sensor model (:class:`psmat.sensor.MPICreep`, eq.
2.15–2.24). The processing does not know it: it runs the nominal model (thesis Table 2.11)
throughout, as a lab without a pneumatic fit would. The perturbations were chosen from the
thesis' material data (§2.4.3) before this experiment was run on them, not tuned to its results:

* ``nominal`` — Table 2.11 itself. The twin then differs from the processing by gains only,
  so a gain calibration can be exact by construction.
* ``stiffer`` — the polynomial's curvature terms a2, a3 (eq. 2.17) × 0.5; a1, ρ, τ and the
  creep as Table 2.11. The curve saturates less (a sheet whose contact keeps growing under high
  loads): g rises from about 1.015× the nominal's at 10 kPa to 1.18× at 150 kPa.
* ``softer`` — a2, a3 × 1.5: the curve saturates more, from about 0.985× at 10 kPa to 0.82× at
  150 kPa. ±50 % on the curvature moves the ratio g(150 kPa)/g(10 kPa) by about ±17 %: some
  1.5 times Velostat's cell-and-repetition variability at 5 and 15 psi (CV ≈ 0.1, Table 2.5),
  and less than the thesis found between materials (the other two sheets' hysteresis ~50 %
  above Velostat's, Table 2.10). a3 is scaled with a2 because a2 × 1.5 alone would make the
  model's slope negative near 26 psi (not monotone on [0, p_max]); both models pass
  :meth:`psmat.sensor.MPICreep.invertibility_problem`.
* ``creepier`` — creep weights w × 2 (EeonTex, the creepiest sheet of Table 2.6, creeps up to
  2× as fast as Velostat: 2.85e-5 vs 1.45e-5 s⁻¹ at 15 psi) and the first creep rate l1 × 20
  (time constant 20 min → 61 s): creep on the time scale of these recordings, which the fit on
  25-min steps could not resolve (the fit was worst in the first repetitions, §2.5.2).

The run's header gives each material's ``g_material(p) / g_nominal(p)`` at 10, 50 and 150 kPa:
the conductance 10 s after a 0.5 s ramp from rest to p (as the uniform loads go on), at 50 Hz.
Each case also reports the equilibration's per-cell spread across the levels (``max/min − 1``
of a cell's gains, as the equilibration step returns it in its
:class:`psmat.pressure.EquilibrationResult`; median over the cells): with a pure gain difference
it holds only the noise of the gains; a curve of another shape adds how much its ratio to the
nominal changes between the levels — the sign a lab has that the shape is off.

Errors against the twin's truth, over the frames at t >= 3 s of the test recording (2 s after
the load comes on) and the cells the truth loads above 10 kPa: the median of
``|p / p_true − 1|`` over cells and frames, and ``|mean ΣpA / mean Σp_true·A − 1|`` (total force).

The first material named runs every ``--seeds`` × ``--sensitivity``; each further one a single
case (the first seed, sensitivity ``--material-sensitivity``). Run ``python -m psmat.experiments
pressure_calibration [--material nominal stiffer softer creepier] [--seeds 1 2 3] [--sensitivity
1.5 2.5 4] [--material-sensitivity 2.5] [--variability 0.3] [--levels-kpa 10 20] [--seconds 8]``.
"""

from __future__ import annotations

import argparse
import dataclasses
import tempfile
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..units import kpa_from_psi, n_from_kg
from ._common import format_table

__all__ = ["RATE_HZ", "SHAPE", "SEEDS", "SENSITIVITIES", "LEVELS_KPA", "MATERIALS", "MATERIAL_SENSITIVITY",
           "RATIO_KPA", "material_sensor", "curve_ratio", "Lab", "write_session", "with_lead_in", "write_lab",
           "pressure_errors", "PressureCase", "PressureCalibrationResult", "pressure_calibration_case",
           "pressure_calibration_study", "build_parser", "main"]

RATE_HZ = 50.0  # the twin mat's frame rate (Hz)
SHAPE = (16, 16)  # rows × columns of the twin mat (the default mat: 2 cm pitch, 4 cm² cells)
LEAD_S = 1.0  # the mat unloaded before the load goes on (s)
SETTLE_S = 3.0  # errors from this time on (s, from the recording's start)
LOADED_KPA = 10.0  # errors on the cells the truth loads above this (kPa)
SEEDS = (1, 2, 3)
SENSITIVITIES = (1.5, 2.5, 4.0)
VARIABILITY = 0.3
LEVELS_KPA = (10.0, 20.0)
STANDING_KG = 70.0  # the calibration person's known mass (kg)
TEST_LOAD_N = 850.0  # the test person's weight (N)
UNIFORM_S = 14.0  # each uniform-load recording (s; the load on at LEAD_S)
STANDING_S = 12.0  # the standing recording after the lead-in (s)
TEST_S = 8.0  # the test recording after the lead-in (s)
MATERIAL_SENSITIVITY = 2.5  # the sensitivity of the single case of each further material
RATIO_KPA = (10.0, 50.0, 150.0)  # where the header compares each material's curve with the nominal (kPa)
RAMP_S, HOLD_S = 0.5, 10.0  # the curve comparison's ramp from rest and hold (s)

#: The twin's sensor materials (module docstring): name → factors on thesis Table 2.11's parameters
#: (a creep parameter: one factor per operator).
MATERIALS: dict[str, dict[str, float | tuple[float, ...]]] = {
    "nominal": {},
    "stiffer": {"a2": 0.5, "a3": 0.5},
    "softer": {"a2": 1.5, "a3": 1.5},
    "creepier": {"w": (2.0, 2.0), "l": (20.0, 1.0)},
}


def material_sensor(material: str):
    """The sensor model (:class:`psmat.sensor.MPICreep`) of ``material`` (a key of :data:`MATERIALS`):
    thesis Table 2.11 with the material's factors; ValueError for an unknown name or a model that is
    not invertible."""
    from ..sensor import THESIS_TABLE_2_11, MPICreep

    if material not in MATERIALS:
        raise ValueError(f"unknown material {material!r}: one of {', '.join(MATERIALS)}")
    prm = dict(THESIS_TABLE_2_11)
    for k, f in MATERIALS[material].items():
        prm[k] = tuple(np.asarray(prm[k]) * np.asarray(f)) if isinstance(f, tuple) else prm[k] * f
    model = MPICreep(**prm)
    why = model.invertibility_problem()
    if why:
        raise ValueError(f"material {material!r}: its sensor model is not invertible ({why})")
    return model


def curve_ratio(material: str, p_kpa: Sequence[float] = RATIO_KPA, rate_hz: float = RATE_HZ) -> list[float]:
    """``g_material(p) / g_nominal(p)`` (dimensionless) at each ``p_kpa`` (kPa): the conductance
    :data:`HOLD_S` s after a :data:`RAMP_S` s ramp from rest to p, sampled at ``rate_hz`` Hz."""
    from ..sensor import MPICreep
    from ..units import psi_from_kpa

    def g_end(model, p_psi: float) -> float:
        n = int(round(RAMP_S * rate_hz))
        p = np.r_[np.linspace(0.0, p_psi, n + 1)[1:], np.full(int(round(HOLD_S * rate_hz)), p_psi)]
        return float(model.direct(p, 1.0 / rate_hz)[-1])

    nominal, model = MPICreep.thesis(), material_sensor(material)
    return [g_end(model, psi_from_kpa(v)) / g_end(nominal, psi_from_kpa(v)) for v in p_kpa]


@dataclass(frozen=True)
class Lab:
    """The session files of one simulated lab, and the truth the files do not hold.

    Attributes
    ----------
    folder : Path
        Where the files are.
    uniform : tuple of Path
        One session file per uniform load, in the order of ``levels_kpa``.
    levels_kpa : tuple of float
        The uniform loads' levels (kPa).
    standing : Path
        The session file of the person of known mass standing still.
    standing_kg : float
        That person's mass (kg).
    test : Path
        The session file of the test recording (another person on one leg).
    truth_kpa : ndarray, shape (T, R, C)
        The test recording's true pressure per frame and cell (kPa; the sensor's saturation
        included).
    true_gains : ndarray, shape (R, C)
        The per-cell gains that undo the twin's (``PressureCalibration.gains``: 1 / the twin's
        conductance factor per cell, dimensionless).
    rate_hz : float
        The frame rate of every recording (Hz).
    sensor : MPICreep or None
        The twin's sensor model, which ``true_gains`` are relative to (None: thesis Table 2.11).
    """

    folder: Path
    uniform: tuple[Path, ...]
    levels_kpa: tuple[float, ...]
    standing: Path
    standing_kg: float
    test: Path
    truth_kpa: NDArray[np.float64]
    true_gains: NDArray[np.float64]
    rate_hz: float = RATE_HZ
    sensor: Any = None


def write_session(mat, path: str | Path, pressure_psi: NDArray[np.float64],
                  rate_hz: float = RATE_HZ) -> NDArray[np.float64]:
    """Write the twin ``mat``'s ADC counts for ``pressure_psi`` (T, R, C) as a session file, the mat
    rested first, frames every 1/``rate_hz`` s (Hz); returns the true pressure (T, R, C) in psi
    (saturated at the sensor's p_max). The file holds counts and times only, no truth."""
    from ..io import SessionWriter

    mat.reset()
    counts, truth = mat.counts(pressure_psi, return_truth=True)
    k = np.arange(len(counts))
    shape = tuple(int(v) for v in mat.shape)
    with SessionWriter(path, shape, {"rows": shape[0], "cols": shape[1], "serial": "TWIN-P"}) as w:
        w.append(counts, 1.7e9 + k / rate_hz, np.ones(len(k), bool), seq=k,
                 device_time_us=np.round(k / rate_hz * 1e6).astype(np.int64))
    return truth.pressure_psi


def with_lead_in(pressure_psi: NDArray[np.float64], rate_hz: float = RATE_HZ,
                 lead_s: float = LEAD_S) -> NDArray[np.float64]:
    """``pressure_psi`` (T, R, C) after ``lead_s`` s of an unloaded mat at ``rate_hz`` Hz."""
    return np.concatenate([np.zeros((int(round(lead_s * rate_hz)),) + pressure_psi.shape[1:]), pressure_psi])


def write_lab(folder: str | Path, *, seed: int = 1, sensitivity: float = 2.5, variability: float = VARIABILITY,
              levels_kpa: Sequence[float] = LEVELS_KPA, standing_seed: int | None = None,
              test_seed: int | None = None, standing_kg: float = STANDING_KG, test_load_n: float = TEST_LOAD_N,
              uniform_s: float = UNIFORM_S, standing_s: float = STANDING_S, test_s: float = TEST_S,
              rate_hz: float = RATE_HZ, material: str = "nominal") -> Lab:
    """A lab's recordings of a twin mat the processing does not know, as session files in ``folder``.

    The mat: :class:`psmat.twin.MatPhysics` of :data:`SHAPE` with the sensor model of ``material``
    (:func:`material_sensor`) and cell gains ``sensitivity · exp(variability · N(0, 1))`` drawn
    from ``seed``. The files:
    ``uniform_<level>kpa.h5`` (``uniform_s`` s each, the load on at 1 s), ``standing.h5`` (a
    person of ``standing_kg`` kg standing still for ``standing_s`` s after 1 s unloaded, person
    seed ``standing_seed``, default ``seed + 1``) and ``test.h5`` (a person of ``test_load_n`` N
    on the left leg for ``test_s`` s after 1 s unloaded, seed ``test_seed``, default ``seed + 2``),
    at ``rate_hz`` Hz.
    """
    from ..twin import MatPhysics, quiet_standing, single_leg_sway, uniform_load

    d = Path(folder)
    d.mkdir(parents=True, exist_ok=True)
    sensor = material_sensor(material)
    mat = MatPhysics(SHAPE, dt=1.0 / rate_hz, sensor=sensor, variability=variability, sensitivity=sensitivity,
                     seed=seed)
    levels = tuple(float(v) for v in levels_kpa)
    uniform = []
    for level in levels:
        path = d / f"uniform_{level:g}kpa.h5"
        write_session(mat, path, uniform_load(uniform_s, rate_hz, level, SHAPE, onset_s=LEAD_S).pressure_psi, rate_hz)
        uniform.append(path)
    standing = quiet_standing(standing_s, rate_hz, SHAPE, weight_n=n_from_kg(standing_kg),
                              seed=seed + 1 if standing_seed is None else standing_seed)
    write_session(mat, d / "standing.h5", with_lead_in(standing.pressure_psi, rate_hz), rate_hz)
    test = single_leg_sway(test_s, rate_hz, SHAPE, weight_n=test_load_n,
                           seed=seed + 2 if test_seed is None else test_seed)
    truth_psi = write_session(mat, d / "test.h5", with_lead_in(test.pressure_psi, rate_hz), rate_hz)
    return Lab(d, tuple(uniform), levels, d / "standing.h5", float(standing_kg), d / "test.h5",
               kpa_from_psi(truth_psi), 1.0 / mat.gain, float(rate_hz), sensor)


def pressure_errors(p_kpa: NDArray[np.float64], truth_kpa: NDArray[np.float64], rate_hz: float = RATE_HZ,
                    settle_s: float = SETTLE_S, loaded_kpa: float = LOADED_KPA) -> tuple[float, float]:
    """(median of ``|p / p_true − 1|`` over the cells the truth loads above ``loaded_kpa`` kPa,
    ``|mean total force / true mean total force − 1|``), both dimensionless, over the frames at
    t >= ``settle_s`` s (frame k at k / ``rate_hz``). ``p_kpa`` and ``truth_kpa``: (T, R, C) kPa,
    frame for frame (NaN frames in ``p_kpa`` left out of the force; a NaN on a loaded cell makes
    the median NaN)."""
    t = np.arange(len(truth_kpa)) / rate_hz
    keep = t >= settle_s
    p, q = np.asarray(p_kpa)[keep], np.asarray(truth_kpa)[keep]
    loaded = q > loaded_kpa
    cell = float(np.median(np.abs(p[loaded] / q[loaded] - 1.0)))
    force = float(np.nanmean(p.sum(axis=(1, 2))) / np.mean(q.sum(axis=(1, 2))) - 1.0)
    return cell, abs(force)


@dataclass
class PressureCase:
    """One case: the errors (median cell, total force; dimensionless) of the test recording
    uncalibrated (``before``), calibrated by the steps (``after``) and with the twin's true gains
    and sensor model (``floor``); ``described`` the calibrated processing's
    ``params["pressure_calibration"]``; ``material`` the twin's (:data:`MATERIALS`); ``spread`` the
    median over cells of the equilibration's per-cell spread across the levels (dimensionless)."""

    seed: int
    sensitivity: float
    before: tuple[float, float]
    after: tuple[float, float]
    floor: tuple[float, float]
    described: str
    material: str = "nominal"
    spread: float = float("nan")


def _span(values: NDArray[np.float64], fmt: str) -> str:
    """``min–max`` of ``values`` in format ``fmt``; one value when they print the same."""
    lo, hi = format(float(np.min(values)), fmt), format(float(np.max(values)), fmt)
    return lo if lo == hi else f"{lo}–{hi}"


@dataclass
class PressureCalibrationResult:
    """All cases, with their table."""

    variability: float
    levels_kpa: tuple[float, ...]
    seconds: float
    cases: list[PressureCase] = field(default_factory=list)

    def table(self) -> str:
        """Per case: the errors before → after (factor), the floor and the equilibration's spread;
        then the range over each material's cases."""
        head = ("material", "seed", "sensitivity", "cell error before → after", "factor",
                "force error before → after", "floor: cell, force", "spread (median)")
        rows = [(c.material, c.seed, f"{c.sensitivity:g}×", f"{c.before[0]:.1%} → {c.after[0]:.1%}",
                 f"×{c.before[0] / c.after[0]:.0f}", f"{c.before[1]:.1%} → {c.after[1]:.1%}",
                 f"{c.floor[0]:.1%}, {c.floor[1]:.1%}", f"{c.spread:.2%}") for c in self.cases]
        lines = [format_table(head, rows)]
        summary = []
        for m in dict.fromkeys(c.material for c in self.cases):
            a = np.array([(*c.before, *c.after, *c.floor, c.spread) for c in self.cases if c.material == m])
            factor = a[:, 0] / a[:, 2]
            n = f"{len(a)} case{'s' * (len(a) != 1)}"
            summary.append(f"{m} ({n}): cell error after {_span(a[:, 2], '.1%')} (floor {_span(a[:, 4], '.1%')}), "
                           f"{_span(factor, '.0f')}× lower than before; force error after {_span(a[:, 3], '.1%')}; "
                           f"spread {_span(a[:, 6], '.2%')}.")
        if summary:
            lines.append("\n".join(summary))
        return "\n\n".join(lines)


def pressure_calibration_case(seed: int, sensitivity: float, variability: float = VARIABILITY,
                              levels_kpa: Sequence[float] = LEVELS_KPA, seconds: float = TEST_S,
                              folder: str | Path | None = None, material: str = "nominal") -> PressureCase:
    """Write a lab of ``material`` (:func:`write_lab`) in a temporary folder (under ``folder``),
    calibrate as the ``psmat calibrate`` steps do, process the test recording (``seconds`` s after
    the lead-in) without and with the calibration and with the twin's true gains and sensor model;
    the errors, and the median per-cell spread the equilibration step reported."""
    from ..circuit import Calibration
    from ..pressure import PressureCalibration
    from ..process import process_session
    from ..workflows.calibrate_pressure import run_equilibrate, run_known_load

    with tempfile.TemporaryDirectory(prefix="psmat-pcal-", dir=folder) as tmp:
        lab = write_lab(tmp, seed=seed, sensitivity=sensitivity, variability=variability, levels_kpa=levels_kpa,
                        test_s=seconds, material=material)
        cal = lab.folder / "cal.json"
        eq, _ = run_equilibrate([str(p) for p in lab.uniform], list(lab.levels_kpa), cal)
        run_known_load(str(lab.standing), n_from_kg(lab.standing_kg), cal)
        true = lab.folder / "true_gains.json"
        dataclasses.replace(Calibration.load(cal), mat_calibration=PressureCalibration(
            sensor=None if material == "nominal" else lab.sensor, gains=lab.true_gains).to_dict()
        ).save(true, overwrite=True)
        out = {name: process_session(lab.test, calibration=c, save=False, threads=1, progress=False)
               for name, c in (("before", None), ("after", cal), ("floor", true))}
    err = {name: pressure_errors(o.pressure_kpa, lab.truth_kpa, lab.rate_hz) for name, o in out.items()}
    spread = eq.spread[~eq.flagged]
    return PressureCase(seed, float(sensitivity), err["before"], err["after"], err["floor"],
                        str(out["after"].params.get("pressure_calibration", "")), material,
                        float(np.median(spread)) if spread.size else float("nan"))


def pressure_calibration_study(seeds: Sequence[int] = SEEDS, sensitivities: Sequence[float] = SENSITIVITIES,
                               variability: float = VARIABILITY, levels_kpa: Sequence[float] = LEVELS_KPA,
                               seconds: float = TEST_S, progress: bool = False,
                               materials: Sequence[str] = tuple(MATERIALS),
                               material_sensitivity: float = MATERIAL_SENSITIVITY) -> PressureCalibrationResult:
    """:func:`pressure_calibration_case` for every seed × sensitivity of ``materials[0]``, and for
    the first seed at ``material_sensitivity`` of each further material."""
    result = PressureCalibrationResult(float(variability), tuple(float(v) for v in levels_kpa), float(seconds))
    if not seeds or not materials:
        return result
    plan = [(materials[0], seed, k) for seed in seeds for k in sensitivities]
    plan += [(m, seeds[0], material_sensitivity) for m in materials[1:]]
    for m, seed, k in plan:
        c = pressure_calibration_case(seed, k, variability, levels_kpa, seconds, material=m)
        result.cases.append(c)
        if progress:
            print(f"{m}, seed {seed}, sensitivity {k:g}: cell error {c.before[0]:.1%} → {c.after[0]:.1%}, "
                  f"force error {c.before[1]:.1%} → {c.after[1]:.1%}, spread {c.spread:.2%}", flush=True)
    return result


def build_parser(prog: str = "python -m psmat.experiments pressure_calibration") -> argparse.ArgumentParser:
    """The experiment's options (its help: this module's docstring, every default and unit)."""
    from .._help import HelpFormatter, plain

    ap = argparse.ArgumentParser(prog=prog, description=plain(__doc__), formatter_class=HelpFormatter)
    ap.add_argument("--material", nargs="+", choices=list(MATERIALS), default=list(MATERIALS),
                    help="the twin's sensor materials: the first over every seed x sensitivity, each further one "
                         "at the first seed and --material-sensitivity")
    ap.add_argument("--material-sensitivity", type=float, default=MATERIAL_SENSITIVITY,
                    help="the global conductance factor of the further materials' case (> 0)")
    ap.add_argument("--seeds", type=int, nargs="+", default=list(SEEDS),
                    help="seeds of the twin mat's cell gains and noise (the people's: the seed + 1, + 2)")
    ap.add_argument("--sensitivity", type=float, nargs="+", default=list(SENSITIVITIES),
                    help="the twin mat's global conductance factor against the nominal sensor model (> 0)")
    ap.add_argument("--variability", type=float, default=VARIABILITY,
                    help="SD of the log of the twin's per-cell gains (>= 0)")
    ap.add_argument("--levels-kpa", type=float, nargs="+", default=list(LEVELS_KPA),
                    help="the uniform loads' levels, one recording each (kPa)")
    ap.add_argument("--seconds", type=float, default=TEST_S,
                    help="length of the test recording after its 1 s lead-in (s, > 2: errors from t = 3 s)")
    return ap


def main(argv: Sequence[str] | None = None, prog: str = "python -m psmat.experiments pressure_calibration") -> int:
    """Print the table (``--material``, ``--seeds``, ``--sensitivity``, ``--material-sensitivity``,
    ``--variability``, ``--levels-kpa``, ``--seconds``); exit status 0."""
    ap = build_parser(prog)
    a = ap.parse_args(argv)
    if not all(k > 0 and np.isfinite(k) for k in a.sensitivity):
        ap.error(f"--sensitivity: factors > 0, got {a.sensitivity}")
    if not (a.material_sensitivity > 0 and np.isfinite(a.material_sensitivity)):
        ap.error(f"--material-sensitivity: a factor > 0, got {a.material_sensitivity:g}")
    materials = list(dict.fromkeys(a.material))
    if not (a.variability >= 0 and np.isfinite(a.variability)):
        ap.error(f"--variability: an SD >= 0, got {a.variability}")
    if not all(v > 0 and np.isfinite(v) for v in a.levels_kpa):
        ap.error(f"--levels-kpa: levels > 0 kPa, got {a.levels_kpa}")
    if not (a.seconds > SETTLE_S - LEAD_S and np.isfinite(a.seconds)):
        ap.error(f"--seconds: more than {SETTLE_S - LEAD_S:g} s (the errors start at t = {SETTLE_S:g} s), "
                 f"got {a.seconds:g}")
    try:
        ratios = {m: curve_ratio(m) for m in materials}
        r = pressure_calibration_study(a.seeds, a.sensitivity, a.variability, a.levels_kpa, a.seconds,
                                       progress=True, materials=materials,
                                       material_sensitivity=a.material_sensitivity)
    except ValueError as exc:  # a level the sensor model cannot reach, a calibration step refused
        ap.exit(1, f"{prog}: {exc}\n")
    levels = ", ".join(f"{v:g}" for v in r.levels_kpa)
    print(f"\nPressure calibration (simulation: 16x16 twin mats, cell gains {r.variability:g} SD in log; "
          f"psmat calibrate equilibrate at {levels} kPa, then known-load 70 kg standing; test: 850 N on one leg, "
          f"{r.seconds:g} s at 50 Hz): median |p/p_true - 1| on cells > 10 kPa and total-force error, "
          "uncalibrated → calibrated; floor: the chain told the twin's true gains and sensor model; spread: "
          "the equilibration's per-cell max/min - 1 of the gains across the levels, median over cells")
    at = ", ".join(f"{v:g}" for v in RATIO_KPA)
    print(f"Materials: g_material(p) / g_nominal(p) at {at} kPa ({HOLD_S:g} s after a {RAMP_S:g} s ramp from rest):")
    for m, ratio in ratios.items():
        changed = ", ".join(f"{k} x{'/'.join(f'{x:g}' for x in np.atleast_1d(f))}" for k, f in MATERIALS[m].items())
        print(f"  {m:9s} {', '.join(f'{v:.3f}' for v in ratio)}   (thesis Table 2.11"
              f"{'; ' + changed if changed else ''})")
    print(r.table())
    return 0

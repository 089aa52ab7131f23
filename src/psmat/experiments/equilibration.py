"""Measured in simulation, beyond the thesis: SCHC-EQ (the per-cell equilibration of
:func:`psmat.balance.equilibrate`) against SCHC on trials whose mat the processing does not know.

Each case is built as ``tests/integration/test_study_trial.py`` builds one: a BDS force-platform trajectory
drives :func:`psmat.twin.trajectory_sway` (two feet, the recorded Fz) through a
:class:`psmat.twin.MatPhysics` twice as conductive as the nominal sensor model, with 15 %
log-normal cell gains (drawn from the case's seed), 1 mV noise and 12 bits, on its own clock;
the platform file is the recording at 100 Hz on the platform's clock. The session is processed
by :func:`psmat.study.process_trial` (the one chain, alignment with the platform, Eu and
σ); the method never sees the gains. The BDS trials and seeds differ from those the method's
choices (the marginal-likelihood ridge, 0.5 s blocks, the conductance-side gain) were made on
(BDS 10, 15, 20, 22; seeds 98, 99).

The gain-induced CoP error is measured against the same trial through the same mat without
gains (``variability=0``, same seed: the same noise): the RMS distance per frame between a
variant's CoP and the gain-free mat's SCHC CoP, absolute ("abs", a static bias included) and
with both means removed ("dyn", what Eu sees). The learned map is scored against the truth
(read here only) as the load-weighted RMS of ``log a_learned − log a_true`` over the loaded
cells, both centred (before: the map of ones).

Run ``python -m psmat.experiments equilibration [--trials 1 4 8 13 17 24] [--seeds 1 2]
[--seconds 25]``.
"""

from __future__ import annotations

import argparse
import tempfile
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..balance import cop, equilibrate, variant_traces
from ..sensor import THESIS_TABLE_2_11, MPICreep, inverse_over_gaps
from ..units import STANDARD_GRAVITY_M_S2, n_from_kg
from ._common import format_table

__all__ = ["TRIALS", "SEEDS", "EquilibrationCase", "EquilibrationResult", "equilibration_case",
           "equilibration_study", "main"]

TRIALS = (1, 4, 8, 13, 17, 24)  # BDS: both subjects, eyes open/closed, firm/foam
SEEDS = (1, 2)


def _mat_model(k: float) -> MPICreep:
    """The nominal model k times more conductive (every conductance term scaled)."""
    p = dict(THESIS_TABLE_2_11)
    for name in ("rho", "a1", "a2", "a3"):
        p[name] = p[name] * k
    p["w"] = tuple(v * k for v in p["w"])
    return MPICreep(**p)


def _rms(a: np.ndarray, b: np.ndarray, centred: bool) -> float:
    ok = np.all(np.isfinite(a) & np.isfinite(b), axis=1)
    a, b = a[ok], b[ok]
    if centred:
        a, b = a - a.mean(axis=0), b - b.mean(axis=0)
    return float(np.sqrt(np.mean(np.sum((a - b) ** 2, axis=1))))


@dataclass
class EquilibrationCase:
    """One simulated trial: ``metrics[variant]`` holds process_trial's eu_cm, sd_ml_cm, sd_ap_cm
    (and FP's sd); ``bias[variant]`` the gain-induced CoP error (abs, dyn) in cm; ``map_err``
    the learned map's error (before, after); ``dof`` the equilibration's identified directions;
    ``status`` process_trial's."""

    trial: int
    seed: int
    metrics: dict[str, dict[str, float]]
    bias: dict[str, tuple[float, float]]
    map_err: tuple[float, float]
    dof: float
    status: str


@dataclass
class EquilibrationResult:
    """All cases, with a per-case table and a summary."""

    seconds: float
    cases: list[EquilibrationCase] = field(default_factory=list)

    def table(self) -> str:
        """Per case: Eu and σ against FP, the gain-induced CoP error and the map's error; then means."""
        head = ("BDS", "seed", "dof", "log-gain err", "σML FP", "σAP FP", "Eu SCHC → EQ (mm)", "σML SCHC → EQ",
                "σAP SCHC → EQ", "gain bias abs (mm)", "gain bias dyn (mm)")
        rows, agg = [], []
        for c in self.cases:
            m, b = c.metrics, c.bias
            rows.append((c.trial, c.seed, f"{c.dof:.1f}", f"{c.map_err[0]:.3f} → {c.map_err[1]:.3f}",
                         f"{m['FP']['sd_ml_cm']:.3f}", f"{m['FP']['sd_ap_cm']:.3f}",
                         f"{10 * m['SCHC']['eu_cm']:.4f} → {10 * m['SCHC-EQ']['eu_cm']:.4f}",
                         f"{m['SCHC']['sd_ml_cm']:.3f} → {m['SCHC-EQ']['sd_ml_cm']:.3f}",
                         f"{m['SCHC']['sd_ap_cm']:.3f} → {m['SCHC-EQ']['sd_ap_cm']:.3f}",
                         f"{10 * b['SCHC'][0]:.3f} → {10 * b['SCHC-EQ'][0]:.3f}",
                         f"{10 * b['SCHC'][1]:.3f} → {10 * b['SCHC-EQ'][1]:.3f}"))
            off = {(v, ax): abs(m[v][f"sd_{ax}_cm"] / m["FP"][f"sd_{ax}_cm"] - 1)  # σ's relative miss
                   for v in ("SCHC", "SCHC-EQ") for ax in ("ml", "ap")}
            agg.append((m["SCHC"]["eu_cm"], m["SCHC-EQ"]["eu_cm"], off["SCHC", "ml"], off["SCHC-EQ", "ml"],
                        off["SCHC", "ap"], off["SCHC-EQ", "ap"], b["SCHC"][0], b["SCHC-EQ"][0], b["SCHC"][1],
                        b["SCHC-EQ"][1], *c.map_err))
        lines = [format_table(head, rows)]
        if agg:
            a = np.array(agg)
            n = len(a)

            def pair(k: int, what: str, scale: float = 1.0, unit: str = "") -> str:
                return (f"{what} {scale * a[:, k].mean():.4g} → {scale * a[:, k + 1].mean():.4g}{unit} "
                        f"(lower in {int(np.sum(a[:, k + 1] < a[:, k]))}/{n})")

            lines.append("Means over the cases, SCHC → SCHC-EQ: " + "; ".join([
                pair(0, "Eu", 10, " mm"), pair(2, "|σML/σML_FP − 1|"), pair(4, "|σAP/σAP_FP − 1|"),
                pair(6, "gain bias abs", 10, " mm"), pair(8, "gain bias dyn", 10, " mm"),
                pair(10, "log-gain error")]))
        return "\n\n".join(lines)


def equilibration_case(trial: int, seed: int, seconds: float = 25.0, rate_hz: float = 50.0,
                       folder: str | Path | None = None) -> EquilibrationCase:
    """Simulate BDS ``trial`` through a mat with gains from ``seed`` and measure SCHC against SCHC-EQ."""
    from .. import twin
    from ..io import SessionWriter, bds_trial
    from ..process import Processor
    from ..study import process_trial

    rec = bds_trial(trial)
    keep = rec.t <= rec.t[0] + seconds
    t, ml, ap, fz = rec.t[keep], rec.cop_ml_cm[keep], rec.cop_ap_cm[keep], rec.fz_n[keep]
    scene = twin.trajectory_sway(t, ml, ap, fz, rate_hz)
    pressure = np.minimum(scene.pressure_psi, 32.0)
    dt = 1.0 / rate_hz
    mats = {v: twin.MatPhysics((16, 16), dt=dt, sensor=_mat_model(2.0), variability=v, seed=seed) for v in (0.15, 0.0)}
    counts = {v: m.counts(pressure) for v, m in mats.items()}
    weight_kg = float(np.mean(fz)) / STANDARD_GRAVITY_M_S2
    with tempfile.TemporaryDirectory(prefix="psmat-eq-", dir=folder) as tmp:
        session, plate = Path(tmp) / "S01_trial.h5", Path(tmp) / "S01_trial.csv"
        with SessionWriter(session, (16, 16), {"rows": 16, "cols": 16}, metadata={"subject": "S01", "trial": "t"}) as w:
            w.append(counts[0.15], 500.0 + np.arange(len(pressure)) * dt, np.ones(len(pressure), bool))
        np.savetxt(plate, np.c_[t, ml, ap, fz], delimiter=",", header="time,x,y,Fz", comments="")
        rows = process_trial(session, plate, "S01", f"BDS{trial:05d}", weight_kg,
                             {"variants": ["PROP", "SCHC", "SCHC-EQ"]})  # the study aligns on PROP
    metrics = {r["variant"]: {k: float(r[k]) for k in ("eu_cm", "sd_ml_cm", "sd_ap_cm")} for r in rows}
    status = "; ".join(sorted({r["status"] for r in rows}))
    # the gain-induced error: the same frames through the chain, with and without the gains
    products = {}
    for v, c in counts.items():
        with Processor((16, 16), threads=1) as proc:
            out = proc.push(c, np.full(len(c), dt), progress=False)
        products[v] = (out.G, out.g)
    weight_n = n_from_kg(weight_kg)
    ref = variant_traces(*products[0.0], dt, weight_n=weight_n, names=("SCHC",))["SCHC"].cop_cm[0]
    G, g = products[0.15]
    schc = variant_traces(G, g, dt, weight_n=weight_n, names=("SCHC",))["SCHC"].cop_cm[0]
    eq = equilibrate(g, dt, weight_n)
    eq_cop = cop(inverse_over_gaps(MPICreep.thesis(), eq.apply(g), dt))
    bias = {name: (_rms(c, ref, False), _rms(c, ref, True)) for name, c in (("SCHC", schc), ("SCHC-EQ", eq_cop))}
    loaded = eq.loaded
    wts = np.nanmean(g, axis=0)[loaded]
    wts = wts / wts.sum()
    truth = np.log(mats[0.15].gain[loaded])
    learned = np.log(eq.gain[loaded])
    centre = lambda x: x - np.sum(wts * x)  # noqa: E731
    map_err = (float(np.sqrt(np.sum(wts * centre(truth) ** 2))),
               float(np.sqrt(np.sum(wts * (centre(learned) - centre(truth)) ** 2))))
    return EquilibrationCase(trial, seed, metrics, bias, map_err, eq.dof, status)


def equilibration_study(trials: Sequence[int] = TRIALS, seeds: Sequence[int] = SEEDS, seconds: float = 25.0,
                        progress: bool = False) -> EquilibrationResult:
    """Every trial × seed of :func:`equilibration_case`."""
    result = EquilibrationResult(seconds)
    for trial in trials:
        for seed in seeds:
            c = equilibration_case(trial, seed, seconds)
            result.cases.append(c)
            if progress:
                print(f"BDS{trial:05d} seed {seed}: Eu {10 * c.metrics['SCHC']['eu_cm']:.4f} → "
                      f"{10 * c.metrics['SCHC-EQ']['eu_cm']:.4f} mm ({c.status})", flush=True)
    return result


def build_parser(prog: str = "python -m psmat.experiments equilibration") -> argparse.ArgumentParser:
    """The experiment's options (its help: this module's docstring, every default and unit)."""
    from .._help import HelpFormatter, plain

    ap = argparse.ArgumentParser(prog=prog, description=plain(__doc__), formatter_class=HelpFormatter)
    ap.add_argument("--trials", type=int, nargs="+", default=list(TRIALS),
                    help="trial numbers of the BDS data set (force-platform recordings of human sway shipped "
                         "with psmat)")
    ap.add_argument("--seeds", type=int, nargs="+", default=list(SEEDS), help="seeds of the cell gains and noise")
    ap.add_argument("--seconds", type=float, default=25.0, help="length of each trial (s)")
    return ap


def main(argv: Sequence[str] | None = None, prog: str = "python -m psmat.experiments equilibration") -> int:
    """Print the table (``--trials``, ``--seeds``, ``--seconds``); exit status 0."""
    a = build_parser(prog).parse_args(argv)
    r = equilibration_study(a.trials, a.seeds, a.seconds, progress=True)
    print(f"\nSCHC-EQ against SCHC (simulation: BDS trials {a.trials} x seeds {a.seeds}, {a.seconds:g} s at 50 Hz, "
          "a mat 2x as conductive as the nominal model with 15 % cell gains); Eu (eq. 3.1) and σ against FP "
          "from process_trial, before → after")
    print(r.table())
    return 0

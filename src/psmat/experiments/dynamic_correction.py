"""Issue 12 item 4b measured in simulation: the dynamic correction of :mod:`psmat.study.dynamic`
on volunteers it was not fitted on, against the base variant it corrects.

Each simulated volunteer stands on a mat the processing does not know (SPEC §7 "honest
simulation": conductance ``k ∈ [1.3, 4]`` times the nominal sensor model's, its hysteresis decay
and creep weights drawn away from it, 15 % cell-to-cell gains, its own frame rate in
[40, 60] Hz and clock) for three trials driven by BDS force-platform trajectories (Santos &
Duarte 2016), the platform on its own 100 Hz clock:

* ``right-leg`` / ``left-leg``: the trajectory doubled (single-legged sway is larger, thesis
  §3.2) about a point 5 cm towards that foot (most of the load on it);
* ``rotation``: the trajectory plus slow circles (thesis §3.2: "about half cycle per second",
  here 0.5 Hz, 3 cm M-L by 2 cm A-P).

The mat's CoP goes through the one chain (:class:`psmat.process.Processor`) and the variants
PROP and SCHC, is aligned with the platform (:func:`psmat.balance.align` on PROP, as
:func:`psmat.study.trial.process_trial`), and the aligned traces are corrected by
:func:`psmat.study.dynamic.dynamic_rows` under each model, scope and fold scheme.

Run ``python -m psmat.experiments.dynamic_correction [--volunteers 8] [--seconds 30] [--seed 0]``.
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .. import twin
from ..balance import align, eu, sway
from ..balance.variants import variant_traces
from ..io import bds_trial
from ..process import Processor
from ..sensor import THESIS_TABLE_2_11, MPICreep
from ..study.dynamic import dynamic_rows
from ._common import format_table

__all__ = ["TRIALS", "simulated_traces", "DynamicResult", "dynamic_correction", "main"]

TRIALS = ("right-leg", "left-leg", "rotation")
BASES = ("SCHC", "PROP")
Key = tuple[str, str]


def _mat_sensor(rng: np.random.Generator) -> MPICreep:
    """A volunteer's mat: k ∈ [1.3, 4] times as conductive as the nominal model (SPEC §7), its
    hysteresis decay ×[0.8, 1.25] and creep weights ×[0.5, 2]."""
    p = dict(THESIS_TABLE_2_11)
    k = rng.uniform(1.3, 4.0)
    for name in ("rho", "a1", "a2", "a3"):
        p[name] = p[name] * k
    p["tau"] = p["tau"] * np.exp(rng.uniform(np.log(0.8), np.log(1.25)))
    p["w"] = tuple(v * k * np.exp(rng.uniform(np.log(0.5), np.log(2.0))) for v in p["w"])
    return MPICreep(**p)


def _trajectory(trial: str, bds: int, seconds: float) -> tuple[np.ndarray, ...]:
    """Platform times (s), the trial's M-L and A-P displacement from the mat centre (cm), Fz (N)."""
    rec = bds_trial(bds)
    keep = rec.t <= rec.t[0] + seconds
    t, fz = rec.t[keep], rec.fz_n[keep]
    ml, ap = rec.cop_ml_cm[keep] - rec.cop_ml_cm[keep].mean(), rec.cop_ap_cm[keep] - rec.cop_ap_cm[keep].mean()
    if trial == "rotation":
        phase = 2.0 * np.pi * 0.5 * (t - t[0])
        return t, ml + 3.0 * np.cos(phase), ap + 2.0 * np.sin(phase), fz
    side = 5.0 if trial == "right-leg" else -5.0  # M-L positive = the subject's right (twin.trajectory_sway)
    return t, 2.0 * ml + side, 2.0 * ap, fz


def _one(trial: str, bds: int, seconds: float, rng: np.random.Generator) -> dict[str, np.ndarray]:
    """The aligned traces {"t_s", "FP", "PROP", "SCHC"} of one simulated session."""
    t, ml, ap, fz = _trajectory(trial, bds, seconds)
    rate = rng.uniform(40.0, 60.0)
    scene = twin.trajectory_sway(t, ml, ap, fz, rate, centre=False)
    mat = twin.MatPhysics((16, 16), dt=1.0 / rate, sensor=_mat_sensor(rng), variability=0.15,
                          seed=int(rng.integers(2**31)))
    counts = mat.counts(scene.pressure)
    t_mat = rng.uniform(0.0, 1000.0) + np.arange(len(counts)) / rate  # the mat's own clock
    periods = np.full(len(counts), 1.0 / rate)
    sensor = MPICreep.thesis()  # the processing knows the nominal model only
    with Processor((16, 16), sensor=sensor, threads=1) as proc:
        out = proc.push(counts, periods, progress=False)
    traces = variant_traces(out.G, out.g, periods, weight_n=float(np.mean(fz)), sensor=sensor, names=BASES)
    t_fp = t + rng.uniform(0.0, 1000.0)  # the platform's own clock
    c_fp = np.column_stack([ml, ap])
    a = align(t_fp, c_fp, t_mat, traces["PROP"].cop_cm[0])
    ts = t_mat + a.lag_s
    ok = (ts >= t_fp[0]) & (ts <= t_fp[-1])
    res = {"t_s": ts[ok], "FP": np.column_stack([np.interp(ts[ok], t_fp, c_fp[:, k]) for k in range(2)])}
    res.update({v: traces[v].cop_cm[0][ok] for v in BASES})
    return res


def simulated_traces(volunteers: int, seconds: float, seed: int) -> tuple[list[dict[str, Any]], dict[Key, dict]]:
    """Rows (status only) and aligned traces of ``volunteers`` × the three trials (BDS trials dealt in turn)."""
    rng = np.random.default_rng(seed)
    rows: list[dict[str, Any]] = []
    traces: dict[Key, dict] = {}
    for v in range(volunteers):
        subject = f"V{v + 1:02d}"
        for j, trial in enumerate(TRIALS):
            traces[(subject, trial)] = _one(trial, (3 * v + j) % 24 + 1, seconds, rng)
            rows += [{"subject": subject, "trial": trial, "variant": n, "status": "ok"} for n in ("FP",) + BASES]
    return rows, traces


def _ratios(trace: dict, cop: np.ndarray) -> tuple[float, float, float, float]:
    """σ_ML, σ_AP and velocity of ``cop`` over the platform's, and its Eu (cm) against it, on the trace's window."""
    fs = 1.0 / float(np.median(np.diff(trace["t_s"])))
    m, f = sway(cop, fs), sway(trace["FP"], fs)
    a, b = cop - cop.mean(axis=0), trace["FP"] - trace["FP"].mean(axis=0)
    return m.sd_ml_cm / f.sd_ml_cm, m.sd_ap_cm / f.sd_ap_cm, m.velocity_cm_s / f.velocity_cm_s, eu(a, b)


#: The schemes compared: a label and the keyword arguments of :func:`dynamic_rows` (the first is its default).
SCHEMES: tuple[tuple[str, dict[str, Any]], ...] = (
    ("FIR ±0.1 s, pooled, LOVO", {}),
    ("gain, pooled, LOVO", {"model": "gain"}),
    ("TF (1,1), pooled, LOVO", {"model": "tf"}),
    ("FIR ±0.05 s, pooled, LOVO", {"fir_half_s": 0.05}),
    ("FIR ±0.2 s, pooled, LOVO", {"fir_half_s": 0.2}),
    ("FIR ±0.1 s, ridge 1e-1", {"ridge": 0.1}),
    ("FIR ±0.1 s, per trial, LOVO", {"by_trial": True}),
    ("gain, per trial, LOVO", {"model": "gain", "by_trial": True}),
    ("FIR ±0.1 s, pooled, 2-fold", {"folds": 2}),
)


@dataclass
class DynamicResult:
    """The comparison on held-out volunteers.

    ``selection``: per base and scheme (all trials), the means of σ_ML, σ_AP and velocity ratios
    (mat / FP) and Eu before → after, and the share of sessions whose Eu went down;
    ``detail``: per base and trial under the default scheme, the same with the SD across
    volunteers and the share of volunteers whose mat spreads less than the platform (Table 3.5).
    """

    volunteers: int
    seconds: float
    seed: int
    selection: list[tuple[Any, ...]] = field(default_factory=list)
    detail: list[tuple[Any, ...]] = field(default_factory=list)

    def table(self) -> str:
        """Both tables, Markdown."""
        head1 = ("base", "scheme", "σML ratio", "σAP ratio", "velocity ratio", "Eu (mm)", "Eu lower")
        head2 = ("base", "trial", "σML ratio", "σAP ratio", "spreads less ML / AP", "Eu (mm)")
        return format_table(head1, self.selection) + "\n\n" + format_table(head2, self.detail)


def _arrow(a: np.ndarray, b: np.ndarray, digits: int = 3, sd: bool = False) -> str:
    if sd:
        return f"{a.mean():.{digits}f}±{a.std():.{digits}f} → {b.mean():.{digits}f}±{b.std():.{digits}f}"
    return f"{a.mean():.{digits}f} → {b.mean():.{digits}f}"


def dynamic_correction(volunteers: int = 8, seconds: float = 30.0, seed: int = 0) -> DynamicResult:
    """Simulate, then correct SCHC and PROP under each of :data:`SCHEMES` on held-out volunteers."""
    rows, traces = simulated_traces(volunteers, seconds, seed)
    result = DynamicResult(volunteers, seconds, seed)
    for base in BASES:
        before = {k: _ratios(tr, tr[base]) for k, tr in traces.items()}
        for label, kwargs in SCHEMES:
            _, fixed = dynamic_rows(rows, traces, base=base, **kwargs)
            keys = sorted(fixed)
            b = np.array([before[k] for k in keys])
            d = np.array([_ratios(traces[k], fixed[k][f"{base}-DYN"]) for k in keys])
            result.selection.append((base, label, *(_arrow(b[:, j], d[:, j]) for j in range(3)),
                                     _arrow(10 * b[:, 3], 10 * d[:, 3], 4), f"{100 * np.mean(d[:, 3] < b[:, 3]):.0f} %"))
            if kwargs:
                continue
            for trial in TRIALS:
                sel = [j for j, k in enumerate(keys) if k[1] == trial]
                bt, dt = b[sel], d[sel]
                less = f"{100 * np.mean(bt[:, 0] < 1):.0f}/{100 * np.mean(bt[:, 1] < 1):.0f} → " \
                       f"{100 * np.mean(dt[:, 0] < 1):.0f}/{100 * np.mean(dt[:, 1] < 1):.0f} %"
                result.detail.append((base, trial, _arrow(bt[:, 0], dt[:, 0], sd=True), _arrow(bt[:, 1], dt[:, 1], sd=True),
                                      less, _arrow(10 * bt[:, 3], 10 * dt[:, 3], 4)))
    return result


def main(argv: Sequence[str] | None = None) -> None:
    """Print the tables (``--volunteers``, ``--seconds``, ``--seed``)."""
    ap = argparse.ArgumentParser(prog="python -m psmat.experiments.dynamic_correction", description=__doc__.split("\n")[0])
    ap.add_argument("--volunteers", type=int, default=8)
    ap.add_argument("--seconds", type=float, default=30.0)
    ap.add_argument("--seed", type=int, default=0)
    a = ap.parse_args(argv)
    r = dynamic_correction(a.volunteers, a.seconds, a.seed)
    print(f"Dynamic correction on held-out volunteers (simulation: {r.volunteers} volunteers x 3 trials x "
          f"{r.seconds:g} s, seed {r.seed}); ratios mat/FP and Eu (eq. 3.1) as means over sessions, before -> after")
    print(r.table())


if __name__ == "__main__":
    main()

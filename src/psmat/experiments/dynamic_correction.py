"""Measured in simulation, beyond the thesis: the dynamic correction of :mod:`psmat.study` (``_dynamic.py``)
on volunteers it was not fitted on, against the base variant it corrects.

The study is the honest simulation of docs/spec.md §7 (:func:`psmat.synth.simulate_study`:
each volunteer's mat, box and clock unknown to the processing, BDS sway in the thesis' three
trials, the platform at 100 Hz on its own clock), each session processed as ``psmat study
run`` does (:func:`psmat.study.process_trial` with ``traces=True``: the one chain, PROP
and SCHC, aligned with the platform), then corrected by
:func:`psmat.study.dynamic_rows` under each model, scope and fold scheme of
:data:`SCHEMES`.

Run ``python -m psmat.experiments dynamic_correction [--volunteers 8] [--seconds 30] [--seed 0]
[--rate 100]``.
"""

from __future__ import annotations

import argparse
import tempfile
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..balance import eu, sway
from ..study import dynamic_rows
from ..study import find_study
from ..study import process_trial
from ._common import format_table

__all__ = ["TRIALS", "SCHEMES", "simulated_traces", "DynamicResult", "dynamic_correction", "main"]

TRIALS = ("right-leg", "left-leg", "rotation")
BASES = ("SCHC", "PROP")
Key = tuple[str, str]


def simulated_traces(volunteers: int, seconds: float, seed: int, rate_hz: float = 100.0
                     ) -> tuple[list[dict[str, Any]], dict[Key, dict]]:
    """Metrics rows and aligned traces (PROP and SCHC) of a simulated study, as the study runner makes them."""
    from ..synth import simulate_study

    rows: list[dict[str, Any]] = []
    traces: dict[Key, dict] = {}
    with tempfile.TemporaryDirectory(prefix="psmat-dyn-") as tmp:
        layout = find_study(simulate_study(tmp, volunteers=volunteers, duration_s=seconds, seed=seed, rate_hz=rate_hz))
        for item in layout.items:
            who = layout.subjects.get(item.subject or "")
            r, tr = process_trial(item.session, item.forceplate, str(item.subject), str(item.trial),
                                  None if who is None else who.weight_kg, {"variants": list(BASES)}, traces=True)
            rows += r
            if tr:
                traces[(str(item.subject), str(item.trial))] = tr
    return rows, traces


def _ratios(trace: dict, cop: np.ndarray) -> tuple[float, float, float, float]:
    """σ_ML, σ_AP and velocity of ``cop`` over the platform's, and its Eu (cm) against it, on the
    trace's window (a lost frame's NaN filled linearly, as the study's metrics do)."""
    t = trace["t_s"]
    ok = np.all(np.isfinite(cop), axis=1)
    cop = np.column_stack([np.interp(t, t[ok], cop[ok, k]) for k in range(2)])
    fs = 1.0 / float(np.median(np.diff(t)))
    m, f = sway(cop, fs), sway(trace["FP"], fs)
    a, b = cop - cop.mean(axis=0), trace["FP"] - trace["FP"].mean(axis=0)
    return m.sd_ml_cm / f.sd_ml_cm, m.sd_ap_cm / f.sd_ap_cm, m.velocity_cm_s / f.velocity_cm_s, eu(a, b)


#: The schemes compared: a label and the keyword arguments of :func:`dynamic_rows` (the first is its default).
SCHEMES: tuple[tuple[str, dict[str, Any]], ...] = (
    ("FIR ±0.1 s, per trial, LOVO", {}),
    ("FIR ±0.1 s, pooled, LOVO", {"by_trial": False}),
    ("gain, per trial, LOVO", {"model": "gain"}),
    ("gain, pooled, LOVO", {"model": "gain", "by_trial": False}),
    ("TF (1,1), per trial, LOVO", {"model": "tf"}),
    ("FIR ±0.05 s, per trial, LOVO", {"fir_half_s": 0.05}),
    ("FIR ±0.2 s, per trial, LOVO", {"fir_half_s": 0.2}),
    ("FIR ±0.1 s, ridge 1e-1", {"ridge": 0.1}),
    ("FIR ±0.1 s, per trial, 2-fold", {"folds": 2}),
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
    skipped: list[str] = field(default_factory=list)  # "base subject trial: status" of the sessions left out

    def table(self) -> str:
        """Both tables, Markdown."""
        head1 = ("base", "scheme", "σML ratio", "σAP ratio", "velocity ratio", "Eu (mm)", "Eu lower")
        head2 = ("base", "trial", "σML ratio", "σAP ratio", "spreads less ML / AP", "Eu (mm)")
        left = "".join(f"\n- {s}" for s in self.skipped) or " none"
        return (format_table(head1, self.selection) + "\n\n" + format_table(head2, self.detail)
                + "\n\nSessions not corrected (default scheme):" + left)


def _arrow(a: np.ndarray, b: np.ndarray, digits: int = 3, sd: bool = False) -> str:
    if sd:
        return f"{a.mean():.{digits}f}±{a.std():.{digits}f} → {b.mean():.{digits}f}±{b.std():.{digits}f}"
    return f"{a.mean():.{digits}f} → {b.mean():.{digits}f}"


def dynamic_correction(volunteers: int = 8, seconds: float = 30.0, seed: int = 0, rate_hz: float = 100.0
                       ) -> DynamicResult:
    """Simulate, then correct SCHC and PROP under each of :data:`SCHEMES` on held-out volunteers."""
    rows, traces = simulated_traces(volunteers, seconds, seed, rate_hz)
    result = DynamicResult(volunteers, seconds, seed)
    for base in BASES:
        before: dict[Key, tuple[float, ...]] = {}
        for label, kwargs in SCHEMES:
            new, fixed = dynamic_rows(rows, traces, base=base, **kwargs)
            keys = sorted(fixed)
            b = np.array([before.setdefault(k, _ratios(traces[k], traces[k][base])) for k in keys])
            d = np.array([_ratios(traces[k], fixed[k][f"{base}-DYN"]) for k in keys])
            result.selection.append((base, label, *(_arrow(b[:, j], d[:, j]) for j in range(3)),
                                     _arrow(10 * b[:, 3], 10 * d[:, 3], 4), f"{100 * np.mean(d[:, 3] < b[:, 3]):.0f} %"))
            if kwargs:
                continue
            result.skipped += [f"{base} {r['subject']} {r['trial']}: {r['status']}" for r in new if r["status"] != "ok"]
            for trial in TRIALS:
                sel = [j for j, k in enumerate(keys) if k[1] == trial]
                bt, dt = b[sel], d[sel]
                less = f"{100 * np.mean(bt[:, 0] < 1):.0f}/{100 * np.mean(bt[:, 1] < 1):.0f} → " \
                       f"{100 * np.mean(dt[:, 0] < 1):.0f}/{100 * np.mean(dt[:, 1] < 1):.0f} %"
                result.detail.append((base, trial, _arrow(bt[:, 0], dt[:, 0], sd=True), _arrow(bt[:, 1], dt[:, 1], sd=True),
                                      less, _arrow(10 * bt[:, 3], 10 * dt[:, 3], 4)))
    return result


def build_parser(prog: str = "python -m psmat.experiments dynamic_correction") -> argparse.ArgumentParser:
    """The experiment's options (its help: this module's docstring, every default and unit)."""
    from .._help import HelpFormatter, plain

    ap = argparse.ArgumentParser(prog=prog, description=plain(__doc__), formatter_class=HelpFormatter)
    ap.add_argument("--volunteers", type=int, default=8, help="volunteers of the simulated study, 3 trials each")
    ap.add_argument("--seconds", type=float, default=30.0, help="length of each trial (s)")
    ap.add_argument("--seed", type=int, default=0, help="seed of the simulated study")
    ap.add_argument("--rate", type=float, default=100.0, help="the mat's frame rate (Hz)")
    return ap


def main(argv: Sequence[str] | None = None, prog: str = "python -m psmat.experiments dynamic_correction") -> int:
    """Print the tables (``--volunteers``, ``--seconds``, ``--seed``, ``--rate``); exit status 0."""
    a = build_parser(prog).parse_args(argv)
    r = dynamic_correction(a.volunteers, a.seconds, a.seed, a.rate)
    print(f"Dynamic correction on held-out volunteers (simulation: {r.volunteers} volunteers x 3 trials x "
          f"{r.seconds:g} s, seed {r.seed}); ratios mat/FP and Eu (eq. 3.1) as means over sessions, before -> after")
    print(r.table())
    return 0

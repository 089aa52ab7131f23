"""A small simulated balance study for the study tests: two volunteers' right-leg and left-leg
trials at 50 Hz, the rotation trials and the simulator's hidden quantities (``truth/``) removed."""

from __future__ import annotations

import shutil
from pathlib import Path

from psmat.synth import simulate_study

#: the volunteers of :func:`two_trial_study`
SUBJECTS = ("V01", "V02")


def two_trial_study(folder: Path, duration_s: float, seed: int) -> Path:
    """Simulate the study into ``folder`` (``duration_s`` s a trial) and return its root."""
    root = simulate_study(folder, volunteers=len(SUBJECTS), duration_s=duration_s, seed=seed, rate_hz=50.0)
    shutil.rmtree(root / "truth")
    for sid in SUBJECTS:
        (root / "sessions" / f"{sid}_rotation.h5").unlink()
        (root / "forceplate" / f"{sid}_rotation.csv").unlink()
    return root


def first_run(root: Path, params: dict) -> bytes:
    """Run the study of :func:`two_trial_study` once in this process (every session computed, no
    problem) and return its ``metrics.csv`` bytes, the reference its tests compare against."""
    from psmat.study import run_study

    report = run_study(root, workers=1, progress=False, params=params)
    assert (report.computed, report.failed, report.problems) == (2 * len(SUBJECTS), 0, []), report
    return (root / "results" / "metrics.csv").read_bytes()

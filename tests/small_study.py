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

"""The BDS force-platform trials ship with psmat, and a scene that cannot be made is an error.

Without them a pip user could not run ``psmat demo`` or ``psmat study simulate``; with a missing
trial the twin must say so in one line, never serve another scene under the trial's name.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from psmat.io import bds_dir, bds_files, bds_trials_table
from psmat.twin import make_scene


def test_every_shipped_trial_loads_with_its_published_measures(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("PSMAT_BDS_DIR", raising=False)
    table = {row["Trial"]: row for row in bds_trials_table()}
    names = [f.name.removesuffix(".txt.xz") for f in bds_files()]
    assert len(names) == 24 and set(names) == set(table)
    # 60 s at 100 Hz each (the data set's description), every value finite
    d = np.loadtxt(bds_dir() / "BDS00024.txt.xz", skiprows=1)
    assert d.shape == (6000, 9) and np.isfinite(d).all()
    assert np.allclose(np.diff(d[:, 0]), 0.01, atol=1e-6)


def test_sway_scene_follows_the_named_trial_or_fails(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("PSMAT_BDS_DIR", raising=False)
    scene = make_scene("sway", 2.0, 50.0, bds_trial=3)
    assert scene.meta["source"] == "BDS00003"
    monkeypatch.setenv("PSMAT_BDS_DIR", str(tmp_path))  # a folder without that trial
    with pytest.raises(FileNotFoundError, match="BDS00003"):
        make_scene("sway", 2.0, 50.0, bds_trial=3)


@pytest.mark.parametrize("argv", [["simulate", "--bds-trial", "7"], ["demo", "--twin", "--seconds", "1"]],
                         ids=["simulate", "demo"])
def test_commands_say_in_one_line_that_the_trial_is_missing(argv: list[str], tmp_path: Path) -> None:
    env = dict(os.environ, PSMAT_BDS_DIR=str(tmp_path))
    out = subprocess.run([sys.executable, "-m", "psmat", *argv], cwd=tmp_path, env=env, capture_output=True,
                         text=True, timeout=120)
    assert out.returncode == 1, out.stderr
    lines = out.stderr.strip().splitlines()
    assert len(lines) == 1 and "BDS" in lines[0] and "not found" in lines[0], out.stderr
    assert not list(tmp_path.glob("*.h5")) and not list(tmp_path.glob("*.png"))  # nothing written

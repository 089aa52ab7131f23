"""``psmat demo --crosstalk`` on the twin's frame (one synthetic world, one coordinate convention)."""

from __future__ import annotations

import re
import subprocess
import sys

import pytest

from psmat import twin
from psmat.balance import cop
from psmat.workflows.crosstalk_demo import run_crosstalk_demo


def test_crosstalk_demo_removes_the_ghost(tmp_path):
    pytest.importorskip("matplotlib")
    res = run_crosstalk_demo(tmp_path / "demo.png", noise_v=1e-3, seed=0)
    assert (tmp_path / "demo.png").stat().st_size > 0
    # crosstalk spreads conductance outside the feet; IECM takes most of it back (thesis §2.3)
    assert res["ghost_fraction_iecm"] < 0.25 * res["ghost_fraction_raw"]
    assert res["cop_error_iecm_cm"] < 0.1 * res["cop_error_raw_cm"]
    # loaded cells come back to within a few times the propagated uncertainty (eq. 2.11)
    assert res["loaded_cells_median_rel_error"] < 2 * res["loaded_cells_median_rel_uncertainty"]


def test_the_demo_frame_stands_at_the_mat_centre():
    # one convention (cell (i, p) at (p·pitch, i·pitch), docs/spec.md §7): a still, symmetric person
    # on the twin's mat has the CoP of its conductances at the mat's centre, ((C-1)/2, (R-1)/2)·pitch
    g = twin.swaying_feet(1, (16, 16), sway_cm=(0.0, 0.0), variability=0.0)[0]
    x, _ = cop(g - 1e-7, twin.mat_pitch_cm((16, 16)))
    assert x == pytest.approx(15.0, abs=1e-9)


def test_cli_prints_the_figures(tmp_path):
    pytest.importorskip("matplotlib")
    out = tmp_path / "d.png"
    proc = subprocess.run([sys.executable, "-m", "psmat", "demo", "--crosstalk", "--out", str(out)],
                          capture_output=True, text=True, timeout=300, cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert "after IECM" in proc.stdout and out.exists()
    ghost = re.search(r"ghost .*: ([0-9.]+) % raw -> ([0-9.]+) % after IECM", proc.stdout)
    assert ghost, proc.stdout
    assert float(ghost[2]) < float(ghost[1])

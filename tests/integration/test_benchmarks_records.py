"""The measurement records of ``benchmarks/`` (run from a checkout, not shipped in the wheel) still run."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def test_the_pdas_prototype_finds_bounded_newton_s_bound_cells(tmp_path: Path) -> None:
    # the bounded problem of docs/spec.md §3 has one solution (dG/dg is a P-matrix), so two
    # solvers written apart, the NumPy PDAS prototype and psmat's Fischer-Burmeister
    # bounded_newton, must put the same cells of the same noisy frames at the bound
    proc = subprocess.run([sys.executable, str(ROOT / "benchmarks" / "iecm_noisy_pdas.py"), "--frames", "6"],
                          capture_output=True, text=True, timeout=300, cwd=tmp_path, check=False)
    assert proc.returncode == 0, proc.stderr
    found = re.search(r"PDAS iterations mean [\d.]+ max (\d+); bound cells differing from bounded_newton: (\d+)",
                      proc.stdout)
    assert found, proc.stdout
    assert int(found.group(1)) < 60  # every frame converged before the prototype's cap
    assert int(found.group(2)) == 0

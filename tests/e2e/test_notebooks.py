"""The notebooks in notebooks/: stored with their outputs, and they still run top to bottom.

The stored notebooks carry the outputs of one run at their small size (``FULL = False``, refreshed by
``python tools/run_notebooks.py``): figures inline as PNG, no stderr stream, no warning, each file
below 300 kB. Each notebook is also executed here with nbclient on a python3 kernel against the
installed package, in a temporary working directory, with figures going to a temporary
PSMAT_FIGURES: it must raise nothing, print no warning, save its figures there and nowhere else,
and produce output in the same cells, of the same kinds, as the stored copy (so the stored outputs
are not stale). The run here sets PSMAT_NOTEBOOK_SMOKE=1: a notebook whose pipeline takes long
(balance_study) reads it where it sets its sizes and runs every cell on less data than its stored
run (the numbers differ, the kinds of output do not; tests/e2e/test_study_run.py checks the numbers).
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest

nbformat = pytest.importorskip("nbformat")
nbclient = pytest.importorskip("nbclient")

ROOT = Path(__file__).resolve().parents[2]
NOTEBOOKS = sorted((ROOT / "notebooks").glob("*.ipynb"))
MAX_BYTES = 300_000


def code_cells(nb) -> list:
    return [c for c in nb.cells if c.cell_type == "code"]


def output_kinds(cell) -> list[tuple[str, ...]]:
    """What a cell shows, without the values: ("stream", "stdout"), ("display_data", "image/png", ...)."""
    kinds = set()
    for out in cell.outputs:
        if out.output_type == "stream":
            kinds.add(("stream", out.name))
        elif out.output_type in ("display_data", "execute_result"):
            kinds.add(("display", *sorted(out.data)))
        else:
            kinds.add((out.output_type,))
    return sorted(kinds)


def warnings_in(nb) -> list[str]:
    """Every stderr stream, error and output text that mentions a warning, as 'cell k: ...'."""
    found = []
    for k, cell in enumerate(code_cells(nb)):
        for out in cell.outputs:
            if out.output_type == "stream":
                text = out.text
                if out.name == "stderr":
                    found.append(f"code cell {k}: stderr {text[:300]!r}")
                    continue
            elif out.output_type == "error":
                found.append(f"code cell {k}: {out.ename}: {out.evalue}")
                continue
            else:
                text = out.get("data", {}).get("text/plain", "")
            if "warning" in text.lower():
                found.append(f"code cell {k}: {text[:300]!r}")
    return found


def test_notebooks_exist():
    names = {p.name for p in NOTEBOOKS}
    assert {"qzpm_tables.ipynb", "uncertainty_random.ipynb", "uncertainty_maps.ipynb", "table_2_4.ipynb",
            "resistor_board.ipynb", "balance_study.ipynb", "posture.ipynb"} <= names


@pytest.mark.parametrize("path", NOTEBOOKS, ids=[p.stem for p in NOTEBOOKS])
def test_stored_outputs(path):
    size = path.stat().st_size
    assert size < MAX_BYTES, f"{path.name}: {size} bytes stored, the limit is {MAX_BYTES}"
    nb = nbformat.read(path, as_version=4)
    code = code_cells(nb)
    assert code and code[0].source.strip().startswith("FULL = False"), "the first code cell must be FULL = False"
    # one run, top to bottom: execution counts 1, 2, 3, ... over the code cells
    assert [c.execution_count for c in code] == list(range(1, len(code) + 1)), f"{path.name}: not stored from one run"
    pngs = [o for c in code for o in c.outputs if "image/png" in o.get("data", {})]
    assert pngs, f"{path.name}: no figure stored inline"
    assert warnings_in(nb) == []


@pytest.mark.slow
@pytest.mark.parametrize("path", NOTEBOOKS, ids=[p.stem for p in NOTEBOOKS])
def test_notebook_runs(path, tmp_path):
    stored = nbformat.read(path, as_version=4)
    nb = nbformat.read(path, as_version=4)
    for cell in code_cells(nb):
        cell.outputs, cell.execution_count = [], None
    work, figures = tmp_path / "work", tmp_path / "figures"
    work.mkdir()
    env = dict(os.environ)
    env["PSMAT_FIGURES"] = str(figures)
    env["PSMAT_NOTEBOOK_SMOKE"] = "1"  # the least data that runs every cell (module docstring)
    # glibc's malloc keeps freed large blocks instead of unmapping each one: the posture notebook's
    # torch tensors otherwise page-faulted ~3 million times, ~20 s of system time (other C libraries
    # ignore these variables)
    env.setdefault("MALLOC_MMAP_THRESHOLD_", str(1 << 30))
    env.setdefault("MALLOC_TRIM_THRESHOLD_", str(1 << 30))
    env.setdefault("JUPYTER_PLATFORM_DIRS", "1")  # jupyter_core's own folders, without its deprecation notice
    # run in work/, outside the checkout: the kernel imports the installed package, like every
    # other test (not ../src, which holds no compiled extension in a fresh checkout)
    client = nbclient.NotebookClient(nb, timeout=300, kernel_name="python3",
                                     resources={"metadata": {"path": str(work)}})
    client.execute(env=env)  # raises CellExecutionError on any error

    assert list(figures.glob("*.png")), "the notebook saved no figure to PSMAT_FIGURES"
    assert sorted(p.name for p in work.iterdir()) == [], "the notebook wrote outside PSMAT_FIGURES"
    assert warnings_in(nb) == [], "the run printed a warning"
    ran = [output_kinds(c) for c in code_cells(nb)]
    kept = [output_kinds(c) for c in code_cells(stored)]
    assert ran == kept, (f"{path.name}: the stored outputs differ in kind from a run's; "
                         "refresh them with python tools/run_notebooks.py")

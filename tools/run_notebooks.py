"""Refresh the stored outputs of the notebooks in ``notebooks/`` (a developer tool, not shipped).

Usage, from the repository root, with psmat installed (``pip install -e .``)::

    python tools/run_notebooks.py                       # every notebooks/*.ipynb
    python tools/run_notebooks.py notebooks/posture.ipynb

Each notebook is read fresh from disk, executed top to bottom with nbclient on a ``python3``
kernel at its small size (the first code cell must be ``FULL = False``), in its own folder, with
``PYTHONHASHSEED=0`` (the notebooks seed their own random draws) and with its figures going to a
temporary ``PSMAT_FIGURES`` that is deleted afterwards. The executed notebook is kept only if

* no cell raised,
* no output is a stderr stream or contains the word "Warning",
* the result is below ``--max-kb`` (300 kB by default),
* the file on disk was not edited while it ran (its bytes are compared);

then volatile metadata (execution timings, kernel ids, the interpreter's version) is stripped and the
file is replaced atomically (written beside it, then renamed over it). Otherwise the stored file is
left untouched and the tool exits with status 1 after the remaining notebooks.
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import sys
import tempfile
import time
from pathlib import Path

import nbformat
from nbclient import NotebookClient
from traitlets.config import Config

ROOT = Path(__file__).resolve().parents[1]
NOTEBOOKS = ROOT / "notebooks"
MAX_KB = 300.0
CELL_TIMEOUT_S = 600


def output_problems(nb: nbformat.NotebookNode) -> list[str]:
    """Outputs a stored notebook must not carry: stderr streams, errors, any text with "Warning"."""
    found = []
    for k, cell in enumerate(nb.cells):
        for out in cell.get("outputs", []):
            if out.output_type == "stream" and out.name == "stderr":
                found.append(f"cell {k}: stderr: {out.text.strip()[:200]!r}")
            elif out.output_type == "error":
                found.append(f"cell {k}: {out.ename}: {out.evalue}")
            else:
                text = out.get("text", "") if out.output_type == "stream" else out.get("data", {}).get("text/plain", "")
                text = "".join(text) if isinstance(text, list) else text
                if "warning" in text.lower():
                    found.append(f"cell {k}: warning in output: {text.strip()[:200]!r}")
    return found


def strip_volatile(nb: nbformat.NotebookNode) -> None:
    """Remove what changes from run to run without the results changing (in place)."""
    nb.metadata.pop("widgets", None)
    nb.metadata["language_info"] = {"name": "python"}
    for cell in nb.cells:
        for key in ("execution", "collapsed", "scrolled", "ExecuteTime"):
            cell.metadata.pop(key, None)


def refresh(path: Path, max_kb: float, timeout: int) -> tuple[bool, str]:
    """Execute the notebook ``path`` and store it with its outputs, if the run qualifies.

    Parameters
    ----------
    path : Path
        The notebook; read here, from disk, not from any copy held elsewhere.
    max_kb : float
        Largest notebook that is stored, kB (1000 bytes).
    timeout : int
        Longest a cell may run, s.

    Returns
    -------
    tuple of (bool, str)
        Whether the file was replaced, and one line (or a list of warnings) saying why or why not.
    """
    stored = path.read_bytes()
    nb = nbformat.reads(stored.decode("utf-8"), as_version=4)
    code = [c for c in nb.cells if c.cell_type == "code"]
    if not code or not code[0].source.strip().startswith("FULL = False"):
        return False, "first code cell is not `FULL = False` (the small size); not run"
    scratch = Path(tempfile.mkdtemp(prefix="psmat-notebooks-"))
    env = dict(os.environ, PSMAT_FIGURES=str(scratch / "figures"), PYTHONHASHSEED="0", JUPYTER_PLATFORM_DIRS="1")
    env.pop("PSMAT_NOTEBOOK_SMOKE", None)  # the stored outputs are of the small size, never the tests' smoke size
    # the kernel on local sockets where there are some (no plain-TCP warning), their files in scratch
    ipc = {"KernelManager": {"transport": "ipc", "ip": str(scratch / "kernel")}}
    sockets = Config(ipc if os.name == "posix" else {})
    client = NotebookClient(nb, kernel_name="python3", timeout=timeout, record_timing=False, coalesce_streams=True,
                            config=sockets, resources={"metadata": {"path": str(path.parent)}})
    t0 = time.perf_counter()
    try:
        client.execute(env=env)
    except Exception as exc:  # CellExecutionError, timeouts, a dead kernel: keep the stored file
        lines = re.sub(r"\x1b\[[0-9;]*m", "", str(exc)).strip().splitlines() or [""]  # no terminal colours
        return False, f"failed, not stored: {type(exc).__name__}: {lines[-1][:300]}"
    finally:
        shutil.rmtree(scratch, ignore_errors=True)
    seconds = time.perf_counter() - t0
    problems = output_problems(nb)
    if problems:
        return False, "not stored, its outputs carry warnings:\n    " + "\n    ".join(problems)
    strip_volatile(nb)
    text = nbformat.writes(nb) + "\n"
    kb = len(text.encode()) / 1000
    if kb > max_kb:
        return False, f"not stored: {kb:.0f} kB > {max_kb:.0f} kB (fewer or smaller figures, shorter prints)"
    if path.read_bytes() != stored:
        return False, "not stored: the file was edited while it ran; run it again"
    fd, tmp = tempfile.mkstemp(prefix=f".{path.stem}-", suffix=".ipynb.tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "w", encoding="utf-8", newline="\n") as fh:
            fh.write(text)
            fh.flush()
            os.fsync(fh.fileno())
        os.chmod(tmp, path.stat().st_mode & 0o777)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return True, f"stored ({seconds:.0f} s, {kb:.0f} kB)"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("notebooks", nargs="*", type=Path, help="notebooks to refresh (default: notebooks/*.ipynb)")
    ap.add_argument("--max-kb", type=float, default=MAX_KB, help="largest stored notebook, kB (default 300)")
    ap.add_argument("--timeout", type=int, default=CELL_TIMEOUT_S, help="seconds per cell (default 600)")
    args = ap.parse_args(argv)
    paths = [p.resolve() for p in args.notebooks] or sorted(NOTEBOOKS.glob("*.ipynb"))
    missing = [str(p) for p in paths if not p.is_file()]
    if missing:
        print(f"error: no such notebook: {', '.join(missing)}", file=sys.stderr)
        return 2
    ok = True
    for path in paths:
        print(f"{path.name}: running …", flush=True)
        stored, what = refresh(path, args.max_kb, args.timeout)
        print(f"{path.name}: {what}", flush=True)
        ok &= stored
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())

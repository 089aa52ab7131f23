"""The order a study run hands its sessions out (``psmat.study._order``): the most expected work
first, estimated from a few frames of each file — by hand on a session written here with a known
number of loaded cells, and ranked on a simulated study as its sessions' own times rank them."""

from __future__ import annotations

import csv
import os
from pathlib import Path

import numpy as np
import pytest

from psmat.circuit import Circuit
from psmat.io import SessionWriter, load_session
from psmat.process import session_circuit
from psmat.study import find_study, run_study
from psmat.study._order import FIXED_SHARE, LOADED_S, expected_work, most_work_first
from psmat.study._hashes import FileHashes
from psmat.study._run import _tasks, _checked_params
from psmat.synth import simulate_study

DEVICE = {"device": "psm", "serial": "T1", "r_o": 2200.0, "v_ref": 3.3, "bits": 12, "rows": 16, "cols": 16}


def _session(path: Path, loaded: int, frames: int = 600) -> Path:
    """A 16×16 session whose every frame has ``loaded`` cells at 2e-3 S (500 Ω) and the rest at
    1e-7 S (10 MΩ), as counts of the session's own circuit."""
    G = np.full((16, 16), 1e-7)
    G.flat[:loaded] = 2e-3
    with SessionWriter(path, (16, 16), DEVICE, chunk_frames=64) as w:
        w.append(np.zeros((1, 16, 16), np.uint16), 0.0, True)
    circuit = session_circuit(load_session(path))
    counts = np.broadcast_to(circuit.counts(G), (frames, 16, 16))
    path.unlink()
    with SessionWriter(path, (16, 16), DEVICE, chunk_frames=64) as w:
        w.append(counts, np.arange(frames) / 100.0, np.ones(frames, bool))
    return path


def test_the_expected_work_is_frames_times_cells_times_the_fixed_share_plus_the_loaded_share(tmp_path) -> None:
    for loaded, frames in ((0, 600), (40, 600), (40, 1200), (256, 300)):
        path = _session(tmp_path / f"s{loaded}_{frames}.h5", loaded, frames)
        circuit = session_circuit(load_session(path, frames=False))
        # the 2e-3 S cells read far above LOADED_S and the 1e-7 S cells far below it (or open: NaN)
        high, low = circuit.conductance(circuit.counts(np.array([2e-3, 1e-7])))
        assert high > 10 * LOADED_S and not low > LOADED_S / 10
        assert expected_work(path, circuit) == pytest.approx(frames * 256 * (FIXED_SHARE + loaded / 256), rel=1e-12)
    assert expected_work(tmp_path / "missing.h5", Circuit()) is None


def test_sessions_that_cannot_be_estimated_go_first_then_the_most_work(tmp_path) -> None:
    root = tmp_path / "study"
    simulate_study(root, volunteers=2, duration_s=4.0, seed=3, rate_hz=50.0)
    layout = find_study(root)
    with FileHashes([], threads=1) as hashes:  # nothing hashed ahead: each file when its key asks
        tasks = _tasks(layout, _checked_params(None), "test", hashes)
    circuits = {i.stem: i.circuit for i in layout.items}
    assert all(c is not None for c in circuits.values())
    order = [t.stem for t in most_work_first(tasks, circuits)]
    work = {t.stem: expected_work(t.session, circuits[t.stem]) for t in tasks}
    assert order == sorted(work, key=work.get, reverse=True)
    # two feet load more cells than one: each volunteer's rotation trial before their one-leg trials
    for v in ("V01", "V02"):
        assert work[f"{v}_rotation"] > max(work[f"{v}_left-leg"], work[f"{v}_right-leg"])
    # without its circuit, or with its file gone, a session is not estimated: first, largest file first
    os.truncate(root / "sessions" / "V02_left-leg.h5", 4096)
    order = [t.stem for t in most_work_first(tasks, {**circuits, "V01_right-leg": None})]
    assert order[:2] == ["V01_right-leg", "V02_left-leg"]

"""``psmat view S.h5``: a recorded session replayed in the live view (headless, MPLBACKEND=Agg).

The session is recorded by ``psmat record --simulate`` (the twin through a pty); what the view
reports is compared with the file as :func:`psmat.io.load_session` reads it.
"""

from __future__ import annotations

import hashlib
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from psmat.io import SessionWriter, journal_path, load_session

WAIT_S = 300


def _psmat(*args: str | Path, cwd: Path | None = None) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "psmat", *map(str, args)], capture_output=True, text=True, cwd=cwd,
                          timeout=WAIT_S, env={**os.environ, "MPLBACKEND": "Agg"})


def _one_line(proc: subprocess.CompletedProcess, *words: str) -> None:
    lines = proc.stderr.strip().splitlines()
    assert proc.returncode == 1 and len(lines) == 1 and lines[0].startswith("psmat view: "), proc.stderr
    for w in words:
        assert w in lines[0], lines[0]


@pytest.fixture(scope="module")
def recorded(tmp_path_factory) -> Path:
    """A twin session of 1 s (read-only)."""
    folder = tmp_path_factory.mktemp("replay")
    proc = _psmat("record", "--simulate", "--seconds", "1", "-o", "S.h5", cwd=folder)
    assert proc.returncode == 0, proc.stderr
    return folder / "S.h5"


def test_view_replays_a_recorded_session(recorded, tmp_path) -> None:
    s = load_session(recorded)
    digest = hashlib.sha256(recorded.read_bytes()).hexdigest()
    assert s.n_frames > 0 and s.profile is not None
    proc = _psmat("view", recorded, "--speed", "20", "--seconds", "2", "--save", "out.png", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    out = proc.stdout
    assert f"replay of S.h5 at 20×: {s.n_frames} frames" in out and "profile psm16" in out, out
    # 1 s recorded, replayed at 20x within the 2 s: every frame of the file reaches the view
    assert f"{s.n_frames} frames received" in out and f"{int((~s.valid).sum())} invalid, 0 lost" in out, out
    png = tmp_path / "out.png"
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert hashlib.sha256(recorded.read_bytes()).hexdigest() == digest  # read only


WRITER = textwrap.dedent(
    """
    import os, sys
    import numpy as np
    from psmat.io import SessionWriter

    w = SessionWriter(sys.argv[1], (16, 16), {"serial": "KILLED01"}, background=False)
    for k in range(20):
        w.append(np.full((16, 16), k, np.uint16), 0.01 * k, True, seq=k, device_time_us=10_000 * k)
    w.flush()
    os._exit(0)  # ended without closing: the journal alone
    """
)


def test_a_recording_not_closed_is_not_replayed_but_named_for_repair(tmp_path) -> None:
    path = tmp_path / "k.h5"
    proc = subprocess.run([sys.executable, "-c", WRITER, str(path)], capture_output=True, text=True, timeout=WAIT_S)
    assert proc.returncode == 0, proc.stderr
    assert not path.exists() and journal_path(path).is_file()
    _one_line(_psmat("view", path, "--seconds", "1", "--save", tmp_path / "v.png"), f"psmat repair {path}")
    assert not (tmp_path / "v.png").exists()


def test_replay_refusals_are_one_line(recorded, tmp_path) -> None:
    png = tmp_path / "v.png"
    _one_line(_psmat("view", recorded, "--shape", "8x8", "--seconds", "1", "--save", png), "--shape", "session")
    _one_line(_psmat("view", recorded, "--profile", "psm8", "--seconds", "1", "--save", png), "--profile psm8",
              "16x16")
    _one_line(_psmat("view", "--simulate", "--speed", "2", "--seconds", "1", "--save", png), "--speed",
              "session file")
    _one_line(_psmat("view", recorded, "--speed", "0", "--seconds", "1", "--save", png), "--speed", "> 0")
    text = tmp_path / "notes.txt"
    text.write_text("not a session\n")
    _one_line(_psmat("view", text, "--seconds", "1", "--save", png), "neither a serial port nor a session file")
    imu = tmp_path / "imu.h5"
    with SessionWriter(imu, (5, 3), device={"serial": "IMU1"}, kind="imu") as w:
        w.append(np.zeros((4, 5, 3), np.float32), 0.01 * np.arange(4), np.ones(4, bool))
    _one_line(_psmat("view", imu, "--seconds", "1", "--save", png), "imu frames", f"psmat info {imu}")
    assert not png.exists()

"""The Arduino sketch of the do-it-yourself mat (firmware/arduino), run on the host.

firmware/arduino/psmat_csv_16x16/psmat_csv_16x16.ino is compiled with g++ against a small
Arduino stand-in (tests/data/arduino_shim): its analogRead returns, for the row and column
channels the sketch put on the multiplexers' select lines (the wiring of
firmware/arduino/README.md), that cell's count from a known (16, 16) array. Its serial output,
decoded by psmat's csv reader, must be that array frame after frame: a wrong bit order on the
select lines, a row or column scanned out of order, a read before the lines settled or a
wrong separator all fail it.
"""

from __future__ import annotations

import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from psmat.protocol import CsvDecoder

ROOT = Path(__file__).resolve().parents[2]
SKETCH = ROOT / "firmware" / "arduino" / "psmat_csv_16x16" / "psmat_csv_16x16.ino"
SHIM = ROOT / "tests" / "data" / "arduino_shim"
LOOPS = 5

pytestmark = pytest.mark.skipif(shutil.which("g++") is None, reason="needs g++ to compile the sketch")


@pytest.fixture(scope="module")
def shim_exe(tmp_path_factory: pytest.TempPathFactory) -> Path:
    exe = tmp_path_factory.mktemp("arduino") / "sketch"
    cmd = ["g++", "-std=c++17", "-O1", "-Wall", "-Werror", f"-I{SHIM}", "-include", "Arduino.h",
           "-x", "c++", str(SKETCH), "-x", "none", str(SHIM / "arduino_shim.cpp"), "-o", str(exe)]
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    return exe


def _run(exe: Path, mat: np.ndarray, tmp_path: Path) -> tuple[bytes, str]:
    path = tmp_path / "mat.txt"
    path.write_text("\n".join(" ".join(str(v) for v in row) for row in mat))
    done = subprocess.run([str(exe), str(path), str(LOOPS)], capture_output=True, timeout=60)
    assert done.returncode == 0, done.stderr.decode()
    return done.stdout, done.stderr.decode()


def test_the_sketch_prints_the_cells_it_addressed(shim_exe: Path, tmp_path: Path) -> None:
    # 256 different counts in 0 ... 1023: any cell read in place of another shows
    mat = np.random.default_rng(16).permutation(1024)[:256].reshape(16, 16)
    out, err = _run(shim_exe, mat, tmp_path)
    assert out.startswith(b"#") and out.endswith(b"\r\n")        # a header, then Serial.println lines
    dec = CsvDecoder((16, 16), bits=10)
    frames = dec.feed(out) + dec.finish()
    assert len(frames) == LOOPS and all(f.valid for f in frames)
    assert dec.invalid == 0 and dec.skipped == len(out.split(b"\n", 1)[0]) + 1   # only the header skipped
    for f in frames:
        np.testing.assert_array_equal(f.data, mat)
    assert "baud=115200" in err


def test_full_scale_and_zero_counts(shim_exe: Path, tmp_path: Path) -> None:
    # open cells read 1023 (X pulled to 5 V through R_o), a short reads 0: the ends of 10 bits
    mat = np.full((16, 16), 1023)
    mat[3, 11] = 0
    out, _ = _run(shim_exe, mat, tmp_path)
    dec = CsvDecoder((16, 16), bits=10)
    frames = dec.feed(out) + dec.finish()
    assert all(f.valid for f in frames) and len(frames) == LOOPS
    np.testing.assert_array_equal(frames[-1].data, mat)


def test_the_frame_period_is_paced(shim_exe: Path, tmp_path: Path) -> None:
    # simulated time (shim clock, not wall-clock): 5 loops of at least 100 ms each
    _, err = _run(shim_exe, np.zeros((16, 16), int), tmp_path)
    us = float(re.search(r"us=(\d+)", err).group(1))
    assert us >= LOOPS * 100_000

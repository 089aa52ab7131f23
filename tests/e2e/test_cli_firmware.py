"""``psmat firmware build`` and ``psmat firmware run`` (docs/spec.md §5 "Firmware executed") as a person
types them: the PSM image built, then executed in the emulator on a mat of known counts; the bytes it
sent decode to frames equal to the mat (v2, and v1 after --protocol 1); a bad mat is one line."""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from psmat.protocol import Reply, Status, V1Decoder, decode_v2

#: the repository's firmware sources (the images are built from them, whether psmat is installed or not)
FIRMWARE = Path(__file__).resolve().parents[2] / "firmware"

pytest.importorskip("unicorn")
pytest.importorskip("elftools")

#: every count different, so that a swapped row or column shows
MAT = np.random.default_rng(5).permutation(4096)[:256].reshape(16, 16).astype(np.uint16)


def _psmat(args: list[str], cwd: Path) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, "PYTHONWARNINGS": "ignore"}
    # a hang guard, not a timing
    return subprocess.run([sys.executable, "-m", "psmat", *args], cwd=cwd, env=env, capture_output=True, text=True,
                          timeout=300, check=False)


@pytest.fixture(scope="module")
def work(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A folder with the images built by ``psmat firmware build --out D`` and the mat m.npy."""
    folder = tmp_path_factory.mktemp("fw")
    if shutil.which("make") is None or shutil.which("arm-none-eabi-gcc") is None:
        proc = _psmat(["firmware", "build", "--out", "D", "--source", str(FIRMWARE)], folder)
        assert proc.returncode == 1 and len(proc.stderr.strip().splitlines()) == 1, proc.stderr
        pytest.skip(proc.stderr.strip())
    proc = _psmat(["firmware", "build", "--out", "D", "--source", str(FIRMWARE)], folder)
    assert proc.returncode == 0, proc.stderr
    lines = dict(line.split(": ", 1) for line in proc.stdout.strip().splitlines())
    assert (folder / lines["psm"]).resolve() == (folder / "D" / "stm32-uart" / "psm.elf").resolve()
    assert (folder / lines["imu"]).resolve() == (folder / "D" / "stm32-uart" / "imu.elf").resolve()
    assert (folder / "D" / "stm32-uart" / "psm.elf").is_file() and (folder / "D" / "stm32-uart" / "imu.elf").is_file()
    np.save(folder / "m.npy", MAT)
    return folder


def test_run_writes_v2_frames_equal_to_the_mat_and_the_stats(work: Path) -> None:
    proc = _psmat(["firmware", "run", "D/stm32-uart/psm.elf", "--mat", "m.npy", "--frames", "3", "--out", "b.bin",
                   "--stats"], work)
    assert proc.returncode == 0, proc.stderr
    got = decode_v2((work / "b.bin").read_bytes())
    assert len(got["frames"]) >= 3 and got["valid"].all() and got["dropped"] == 0
    for frame in got["frames"]:
        np.testing.assert_array_equal(frame, MAT)
    assert list(got["seq"][:3]) == [0, 1, 2]
    stats = proc.stdout.strip().splitlines()[-1]
    m = re.search(r"instructions per frame (\d+).*frame period ([\d.]+) µs.* ([\d.]+) s emulated, ([\d.]+) s CPU",
                  stats)
    assert m, stats
    assert int(m.group(1)) > 0
    # the device's timestamps, 100 Hz by default: 10 000 µs apart (within the interrupt's jitter)
    assert abs(float(m.group(2)) - 10_000) <= 1, stats
    assert np.all(np.abs(np.diff(got["t_us"]) - 10_000) <= 1)
    # 3 frames at 10 ms intervals, the last one 5.3 ms on the link: more than 25 ms of emulated time
    assert float(m.group(3)) > 0.025
    # an existing output is refused without --overwrite
    again = _psmat(["firmware", "run", "D/stm32-uart/psm.elf", "--mat", "m.npy", "--frames", "1", "--out", "b.bin"],
                   work)
    assert again.returncode == 1 and len(again.stderr.strip().splitlines()) == 1 and "--overwrite" in again.stderr


def test_protocol_1_gives_v1_frames_equal_to_the_mat(work: Path) -> None:
    proc = _psmat(["firmware", "run", "D/stm32-uart/psm.elf", "--mat", "m.npy", "--frames", "3", "--protocol", "1",
                   "--rate", "165", "--out", "b1.bin"], work)
    assert proc.returncode == 0, proc.stderr
    dec = V1Decoder((16, 16))
    events = dec.feed((work / "b1.bin").read_bytes()) + dec.finish()
    frames = [e for e in events if not isinstance(e, Reply)]
    replies = [e for e in events if isinstance(e, Reply)]
    assert len(frames) >= 3 and all(f.valid for f in frames)
    for f in frames:
        np.testing.assert_array_equal(f.data, MAT)
    # the two commands the host sent, each answered OK, before the first frame
    assert [(r.opcode, r.status) for r in replies] == [(3, Status.OK), (5, Status.OK)]
    assert max(r.offset for r in replies) < frames[0].offset


@pytest.mark.parametrize("bad, words", [
    (np.zeros((16, 16), dtype=np.float64), ["integers", "float64"]),
    (np.zeros((17, 4), dtype=np.uint16), ["16", "(17, 4)"]),
    (np.zeros(16, dtype=np.uint16), ["rows x columns", "(16,)"]),
    (np.full((4, 4), 4096, dtype=np.uint16), ["0 ... 4095", "4096"]),
])
def test_a_bad_mat_is_one_line(work: Path, bad: np.ndarray, words: list[str]) -> None:
    np.save(work / "bad.npy", bad)
    proc = _psmat(["firmware", "run", "D/stm32-uart/psm.elf", "--mat", "bad.npy", "--frames", "1", "--out",
                   "never.bin"], work)
    assert proc.returncode == 1
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("psmat firmware run: bad.npy"), proc.stderr
    assert all(w in lines[0] for w in words), lines[0]
    assert not (work / "never.bin").exists()


def test_an_image_that_is_not_an_elf_is_one_line(work: Path) -> None:
    proc = _psmat(["firmware", "run", "m.npy", "--mat", "m.npy", "--frames", "1", "--out", "never.bin"], work)
    assert proc.returncode == 1
    assert len(proc.stderr.strip().splitlines()) == 1 and "ELF" in proc.stderr, proc.stderr
    assert not (work / "never.bin").exists()

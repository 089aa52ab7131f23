"""Crash safety of psmat.io.SessionWriter: a writer killed with SIGKILL leaves a loadable file.

The writer runs in a subprocess that appends deterministic frames in a loop and logs, with
unbuffered writes to a progress file, how many frames each ``append`` and ``flush`` had
completed. It is killed at a random moment; the loaded session must hold an exact prefix of
what was written, at least every frame whose append had returned (the journal; the HDF5
file appears only when the writer closes).
"""

from __future__ import annotations

import os
import random
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest

from psmat.io import journal_path, load_session, repair_session
from conftest import child_preexec

WRITER = textwrap.dedent(
    """
    import os, sys
    import numpy as np
    from psmat.io import SessionWriter

    path, progress, kind, mode = sys.argv[1], sys.argv[2], sys.argv[3], sys.argv[4]
    shape = {"psm": (16, 16), "imu": (5, 3), "daq": (10,)}[kind]
    fd = os.open(progress, os.O_WRONLY | os.O_CREAT | os.O_APPEND)

    def frame(k):
        n = int(np.prod(shape))
        if kind == "imu":
            return ((k * 0.37 + np.arange(n) * 1.25) % 360.0 - 180.0).astype(np.float32).reshape(shape)
        return ((k * 7 + np.arange(n)) % 4096).astype(np.uint16).reshape(shape)

    w = SessionWriter(path, shape, device={"serial": "CRASH1", "rate": 165}, kind=kind,
                      metadata={"subject": "K"}, chunk_frames=32,
                      flush_frames=24 if mode == "loop" else 10**9,
                      flush_interval_s=0.05 if mode == "loop" else 1e6)
    k = 0
    os.write(fd, b"S 0\\n")
    while True:
        ks = np.arange(k, k + 3)
        w.append(np.stack([frame(i) for i in ks]), 1000.0 + ks * 0.006, ks % 7 != 3,
                 seq=ks + 100, device_time_us=ks * 6061)
        k += 3
        os.write(fd, b"A %d\\n" % k)
        if mode == "noflush" and k >= 60:
            os._exit(0)        # dies without flushing: only the journal has the frames
        if mode == "hold" and k >= 3000:
            os.write(fd, b"H %d\\n" % k)
            while True:        # waits, acknowledged frames unflushed, for its SIGKILL
                os.pause()
        if mode == "loop" and k % 30 == 0:
            w.flush()
            os.write(fd, b"F %d\\n" % k)
        if k % 90 == 0:
            w.set_counters(dropped_frames=k // 90)
    """
)


def expected(kind: str, n: int) -> dict[str, np.ndarray]:
    shape = {"psm": (16, 16), "imu": (5, 3), "daq": (10,)}[kind]
    m = int(np.prod(shape))
    ks = np.arange(n)
    if kind == "imu":
        fr = ((ks[:, None] * 0.37 + np.arange(m)[None, :] * 1.25) % 360.0 - 180.0).astype(np.float32)
    else:
        fr = ((ks[:, None] * 7 + np.arange(m)[None, :]) % 4096).astype(np.uint16)
    return {
        "frames": fr.reshape((n, *shape)),
        "t": 1000.0 + ks * 0.006,
        "valid": ks % 7 != 3,
        "seq": ks + 100,
        "dt": ks * 6061,
    }


def run_writer(tmp_path: Path, kind: str, mode: str, kill_after: float | None,
               kill_on: bytes = b"F ") -> tuple[Path, dict[str, int]]:
    path = tmp_path / f"rec_{kind}.h5"
    progress = tmp_path / f"progress_{kind}.txt"
    script = tmp_path / "writer.py"
    script.write_text(WRITER)
    env = dict(os.environ)  # the writer imports the installed package, like the tests
    errlog = tmp_path / f"stderr_{kind}.txt"
    with open(errlog, "wb") as err:
        proc = subprocess.Popen([sys.executable, str(script), str(path), str(progress), kind, mode], env=env,
                                stderr=err, preexec_fn=child_preexec())
    try:
        if kill_after is not None:
            deadline = time.monotonic() + 30
            while kill_on not in (progress.read_bytes() if progress.exists() else b""):
                assert proc.poll() is None, errlog.read_text()
                assert time.monotonic() < deadline, "writer made no progress"
                time.sleep(0.01)
            time.sleep(kill_after)
            proc.send_signal(signal.SIGKILL)
            proc.wait(10)
            assert proc.returncode == -signal.SIGKILL
        else:
            proc.wait(30)
            assert proc.returncode == 0, errlog.read_text()
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    last = {"A": 0, "F": 0}
    for line in progress.read_text().splitlines():
        parts = line.split()
        if len(parts) == 2 and parts[0] in last:
            last[parts[0]] = int(parts[1])
    return path, last


def check_prefix(s, kind: str, at_least: int) -> None:
    n = s.n_frames
    assert n >= at_least
    assert s.host_time_s.shape == s.valid.shape == (n,)
    assert s.seq is not None and s.seq.shape == (n,)
    assert s.device_time_us is not None and s.device_time_us.shape == (n,)
    e = expected(kind, n)
    np.testing.assert_array_equal(s.counts, e["frames"])
    assert s.counts.dtype == e["frames"].dtype
    np.testing.assert_array_equal(s.host_time_s, e["t"])
    np.testing.assert_array_equal(s.valid, e["valid"])
    np.testing.assert_array_equal(s.seq, e["seq"])
    np.testing.assert_array_equal(s.device_time_us, e["dt"])
    assert s.device["serial"] == "CRASH1" and s.metadata == {"subject": "K"}


def check_prefix_without(s, kind: str, n: int, lost: int) -> None:
    """``s`` holds frames 0..n-1 of the writer except frame ``lost``."""
    keep = np.arange(n) != lost
    e = expected(kind, n)
    np.testing.assert_array_equal(s.counts, e["frames"][keep])
    np.testing.assert_array_equal(s.host_time_s, e["t"][keep])
    np.testing.assert_array_equal(s.valid, e["valid"][keep])
    np.testing.assert_array_equal(s.seq, e["seq"][keep])
    np.testing.assert_array_equal(s.device_time_us, e["dt"][keep])
    note = " ".join(s.notes)
    assert "1 journal record" in note and f"frame(s) {lost} " in note


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_sigkill_mid_write_psm(tmp_path: Path, seed: int) -> None:
    delay = random.Random(seed).uniform(0.0, 0.6)
    path, last = run_writer(tmp_path, "psm", "loop", delay)
    assert journal_path(path).exists()  # not closed: the journal is still there

    assert not path.exists()  # the HDF5 file is written only by close()
    # the journal: every append that returned is there
    s = load_session(path)
    assert not s.complete and s.recovered
    check_prefix(s, "psm", last["A"])
    # the writer sets dropped_frames = k // 90 after frame k, k a multiple of 90: killed right
    # after frame 90 m it may or may not have written that counters record
    assert s.counters["dropped_frames"] in {(s.n_frames - 1) // 90, s.n_frames // 90}

    # repair makes it a complete, ordinary HDF5 file with the same data
    r = repair_session(path)
    assert r.complete and not journal_path(path).exists()
    check_prefix(r, "psm", s.n_frames)
    assert r.n_frames == s.n_frames
    import h5py

    with h5py.File(path, "r") as f:  # an ordinary HDF5 file, checksummed
        assert f["counts"].shape[0] == s.n_frames and f["counts"].fletcher32


def test_sigkill_mid_write_imu(tmp_path: Path) -> None:
    path, last = run_writer(tmp_path, "imu", "loop", random.Random(7).uniform(0.0, 0.4))
    s = load_session(path)
    check_prefix(s, "imu", last["A"])


def test_unflushed_frames_recovered_from_journal(tmp_path: Path) -> None:
    path, last = run_writer(tmp_path, "daq", "noflush", None)
    assert last["A"] == 60 and last["F"] == 0
    s = load_session(path)
    assert s.recovered and not s.complete and any("journal" in n for n in s.notes)
    check_prefix(s, "daq", 60)
    assert s.n_frames == 60

    # a torn last record (partial write) is dropped, the rest is kept
    j = journal_path(path)
    with open(j, "ab") as fh:
        fh.write(b"\x00\x01garbage")
    s2 = load_session(path)
    assert s2.n_frames == 60
    # a corrupted record costs that record only: the loader resyncs on the next one
    raw = bytearray(j.read_bytes())
    import json

    hlen = int.from_bytes(raw[8:12], "little")
    rsize = json.loads(raw[12 : 12 + hlen])["record_bytes"]
    off = 12 + hlen + 4 + 40 * rsize + 20  # inside record 40 (after the header and its CRC)
    raw[off] ^= 0xFF
    j.write_bytes(bytes(raw))
    s3 = load_session(path)
    assert s3.n_frames == 59
    check_prefix_without(s3, "daq", 60, lost=40)


def test_sigkill_then_a_flipped_journal_byte_costs_one_frame(tmp_path: Path) -> None:
    """docs/spec.md §6's integrity promise: SIGKILL after 3 000 acknowledged frames, one journal byte flipped."""
    path, last = run_writer(tmp_path, "psm", "hold", 0.0, kill_on=b"H ")
    assert last["A"] == 3000
    j = journal_path(path)
    raw = bytearray(j.read_bytes())
    import json

    hlen = int.from_bytes(raw[8:12], "little")
    rsize = json.loads(raw[12 : 12 + hlen])["record_bytes"]
    n_rec = (len(raw) - 12 - hlen) // rsize
    # records: frames 0..89, counters, frames 90..179, counters, ...: frame 1500 is record 1500 + 1500 // 90
    rec = 1500 + 1500 // 90
    start = len(raw) - n_rec * rsize + rec * rsize
    raw[start + rsize // 2] ^= 0x01
    j.write_bytes(bytes(raw))
    s = load_session(path)
    assert s.n_frames == 2999
    check_prefix_without(s, "psm", 3000, lost=1500)
    assert "incomplete last record" not in " ".join(s.notes)

"""``psmat record`` with several devices (docs/spec.md §8): the mat and the spine IMUs into one file.

Real pseudo-terminals served by :class:`psmat.twin.SerialTwin` (the real firmware core) at
their configured rates: the mat 100 Hz, the IMUs 10 Hz. Rates are judged from frame counts
over the time both streams cover, against tolerant bounds around the configured rates
(a loaded machine may make a twin miss ticks, never add frames); no wall-clock duration
is asserted.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from psmat.cli import main
from psmat.io import STREAMS_FORMAT_VERSION, journal_path, load_session
from psmat.twin import Faults, SerialTwin

from conftest import child_preexec

MAT_HZ, IMU_HZ = 100.0, 10.0  # the twins' default rates (SerialTwin)


def _one_line(err: str) -> str:
    lines = err.strip().splitlines()
    assert len(lines) == 1, lines
    return lines[0]


def _rate_over(t: np.ndarray, a: float, b: float) -> float:
    """Frames per second of host times ``t`` inside ``[a, b]``: intervals between the first and last one there."""
    k = t[(t >= a) & (t <= b)]
    assert k.size >= 3, (k.size, a, b)
    return (k.size - 1) / (k[-1] - k[0])


def test_simulated_mat_and_imus_share_one_file_and_one_clock(tmp_path: Path, capsys) -> None:
    out = tmp_path / "p.h5"
    before = time.time()
    assert main(["record", "--simulate", "--also", "imu", "--seconds", "2", "-o", str(out), "--subject", "P01"]) == 0
    after = time.time()
    s = load_session(out)
    assert s.complete and s.format_version == STREAMS_FORMAT_VERSION and list(s.streams) == ["imu"]
    imu = s.streams["imu"]
    assert s.kind == "psm" and s.frame_shape == (16, 16) and imu.kind == "imu" and imu.frame_shape == (5, 3)
    assert s.device["serial"] == "TWIN0001" and imu.device["serial"] == "TWIN0002"
    assert imu.metadata["subject"] == s.metadata["subject"] == "P01"
    for st in (s, imu):
        assert st.valid.all() and st.counters["dropped_frames"] == 0
        np.testing.assert_array_equal(st.seq, st.seq[0] + np.arange(st.n_frames))  # none lost between
        # one host clock: stamped while the command ran, never backwards
        assert before <= st.host_time_s[0] and st.host_time_s[-1] <= after and np.all(np.diff(st.host_time_s) >= 0)
    # the two streams overlap in host time; over the overlap each has its device's rate
    a = max(s.host_time_s[0], imu.host_time_s[0])
    b = min(s.host_time_s[-1], imu.host_time_s[-1])
    assert b > a
    assert 0.6 * MAT_HZ <= _rate_over(s.host_time_s, a, b) <= 1.4 * MAT_HZ
    assert 0.6 * IMU_HZ <= _rate_over(imu.host_time_s, a, b) <= 1.4 * IMU_HZ
    # the IMU twin's angles: finite degrees
    assert np.all(np.isfinite(imu.counts)) and np.all(np.abs(imu.counts) <= 360)
    lines = capsys.readouterr().out.strip().splitlines()
    assert lines[-2].startswith(f"{out}: {s.n_frames} frames recorded, 0 invalid")
    assert lines[-1].startswith(f"{out} [imu]: {imu.n_frames} frames recorded, 0 invalid")


def test_a_device_whose_port_vanishes_for_good_is_said_and_the_mat_goes_on(tmp_path: Path, capsys) -> None:
    out = tmp_path / "d.h5"
    gone_s = 1.0  # the IMU twin's cable is pulled after serving this long, the recording lasts 3 s
    with SerialTwin("psm") as mat, SerialTwin("imu", faults=Faults(disconnect_after_s=gone_s), serial="IMUTWIN1") as imu:
        status = main(["record", mat.port, "--also", f"imu={imu.port}", "--seconds", "3", "-o", str(out)])
    assert status == 1  # the IMU's port was still lost when the recording ended
    captured = capsys.readouterr()
    err = [ln for ln in captured.err.splitlines() if ln.startswith("psmat record:")]
    assert len(err) == 1 and f"{imu.port} is lost since " in err[0] and "psmat re-opens it" in err[0], captured.err
    s = load_session(out)
    st = s.streams["imu"]
    assert s.complete and st.n_frames > 0 and st.device["serial"] == "IMUTWIN1"
    # the IMU served gone_s of its frames at 10 Hz then vanished: at most that many (plus one in flight)
    assert st.n_frames <= gone_s * IMU_HZ + 1
    # the mat went on recording after the IMU's last frame (about 2 s of it; half a second at least)
    assert np.count_nonzero(s.host_time_s > st.host_time_s[-1]) > 0.5 * MAT_HZ
    assert f"{out} [imu]: {st.n_frames} frames recorded" in captured.out
    assert f"  {imu.port} was lost at " in captured.out and " and not found again before the recording ended: the " \
        "recording has no frames after that" in captured.out, captured.out


def test_ctrl_c_stops_every_device_and_completes_the_file(tmp_path: Path) -> None:
    out = tmp_path / "c.h5"
    psmat = str(Path(sys.executable).parent / "psmat")
    proc = subprocess.Popen([psmat, "record", "--simulate", "--also", "imu", "-o", str(out)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            preexec_fn=child_preexec())  # SIGINT not left ignored by a background shell
    try:
        ij = journal_path(out, "imu")
        deadline = time.monotonic() + 60  # a hang guard, not a duration
        body = record = None  # the journal's header size and record size, from its header
        while body is None or ij.stat().st_size < body + 3 * record:  # three IMU frames journalled
            assert proc.poll() is None, proc.communicate()
            assert time.monotonic() < deadline, "no IMU frames were journalled"
            raw = ij.read_bytes() if ij.exists() else b""
            hlen = int.from_bytes(raw[8:12], "little") if len(raw) >= 12 else None
            if hlen is not None and len(raw) >= 12 + hlen + 4:
                body, record = 12 + hlen + 4, int(json.loads(raw[12 : 12 + hlen])["record_bytes"])
            time.sleep(0.05)
        proc.send_signal(signal.SIGINT)
        stdout, stderr = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()  # closes the pipes too
    assert proc.returncode == 0, stderr
    s = load_session(out)
    assert s.complete and not s.recovered and s.n_frames > 0 and s.streams["imu"].n_frames >= 3
    assert not journal_path(out).exists() and not journal_path(out, "imu").exists()
    assert f"{out} [imu]: {s.streams['imu'].n_frames} frames recorded" in stdout


@pytest.mark.parametrize("argv, words", [
    (["--simulate", "--also", "imu=/dev/ttyACM1"], ["--simulate", "--also imu", "not a port"]),
    (["/dev/ttyNOPE", "--also", "imu"], ["--also imu needs", "PORT"]),
    (["--simulate", "--also", "eeg"], ["--also", "KIND=PORT", "psm, imu, daq"]),
    (["--simulate", "--also", "imu="], ["--also", "no port after imu="]),
    (["--simulate", "--also", "imu", "--also", "imu"], ["each kind once"]),
])
def test_a_bad_also_is_one_line_and_status_1(argv, words, tmp_path: Path, capsys) -> None:
    out = tmp_path / "x.h5"
    assert main(["record", *argv, "-o", str(out), "--seconds", "1"]) == 1
    captured = capsys.readouterr()
    line = _one_line(captured.err)
    assert line.startswith("psmat record: "), line
    for w in words:
        assert w in line, (w, line)
    assert list(tmp_path.iterdir()) == []


def test_a_stream_journal_left_behind_is_refused_without_overwrite(tmp_path: Path, capsys) -> None:
    out = tmp_path / "o.h5"
    left = journal_path(out, "imu")
    left.write_bytes(b"an interrupted take")
    assert main(["record", "--simulate", "--also", "imu", "-o", str(out), "--seconds", "1"]) == 1
    line = _one_line(capsys.readouterr().err)
    assert "o.h5.imu.journal" in line and "--overwrite" in line
    assert left.read_bytes() == b"an interrupted take" and sorted(os.listdir(tmp_path)) == [left.name]
    assert main(["record", "--simulate", "--also", "imu", "-o", str(out), "--seconds", "0.5", "--overwrite"]) == 0
    assert not left.exists() and load_session(out).streams["imu"].n_frames > 0


def test_info_csv_names_every_stream_file(tmp_path, capsys) -> None:
    from psmat.io import SessionWriter

    path = tmp_path / "s.h5"
    with SessionWriter(path, (2, 2), device={"serial": "M"}) as w:
        imu = w.add_stream("imu", kind="imu", shape=(5, 3), device={"serial": "I"})
        w.append(np.ones((3, 2, 2)), [0.0, 0.01, 0.02], [True] * 3)
        imu.append(np.full((1, 5, 3), 4.5), [0.005], [True])
    assert main(["info", str(path), "--csv", str(tmp_path / "s.csv")]) == 0
    out = capsys.readouterr().out
    line = next(x for x in out.splitlines() if x.startswith("CSV [imu]: "))
    printed = Path(line.split(": ", 1)[1])
    assert printed.is_file() and printed != tmp_path / "s.csv"
    assert "4.5" in printed.read_text()

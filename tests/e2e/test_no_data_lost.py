"""No psmat command loses a person's data: each case is a real ``python -m psmat`` process on real files.

* an output that exists is refused without ``--overwrite``, an output that is one of the
  command's inputs always, each with one line on stderr, exit status 1 and the file's bytes
  unchanged (``psmat._atomic``);
* a file that is replaced keeps its bytes until the new one is complete (``psmat record
  --overwrite`` killed mid-recording);
* SIGTERM and SIGHUP close a recording as Ctrl-C does: the session file is written from the
  journal and the journal removed (``psmat._signals``);
* ``psmat repair`` writes the finished file from a journal-only recording, every frame the
  writer appended, and every command that meets such a recording names it;
* a study run lists a journal-only session as a status row and goes on; a study run killed with
  SIGKILL leaves no worker process behind (``psmat._orphans``).

The frames a killed writer leaves are known because the writer process is ours: frame ``k``
holds the count ``k`` in every cell, so what ``psmat repair`` must recover is known without
reading the journal with the code under test.
"""

from __future__ import annotations

import csv
import hashlib
import os
import shutil
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import h5py
import numpy as np
import pytest

from psmat._atomic import OutputRefused, check_outputs, replacing
from psmat.io import journal_path, load_session

from conftest import child_preexec
from small_disk import small_disk

#: generous bound for a subprocess to reach a state or to end (s); never asserted as a duration
WAIT_S = 120.0


def _psmat(*args: str | Path, cwd: Path | None = None, timeout: float = WAIT_S) -> subprocess.CompletedProcess:
    env = {**os.environ, "MPLBACKEND": "Agg"}
    return subprocess.run([sys.executable, "-m", "psmat", *map(str, args)], capture_output=True, text=True,
                          cwd=cwd, timeout=timeout, env=env)


def _digest(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _refused(proc: subprocess.CompletedProcess, command: str, *words: str) -> None:
    """Exit status 1 and one line on stderr, naming the command and containing ``words``."""
    lines = proc.stderr.strip().splitlines()
    assert proc.returncode == 1, proc.stderr
    assert len(lines) == 1 and lines[0].startswith(f"psmat {command}"), proc.stderr
    for w in words:
        assert w in lines[0], lines[0]


def _no_temporaries(folder: Path) -> None:
    left = [p.name for p in folder.iterdir() if p.name.startswith(".tmp-") or p.name.endswith(".partial")]
    assert left == []


@pytest.fixture(scope="module")
def recorded(tmp_path_factory) -> Path:
    """A finished session from ``psmat record --simulate`` (read-only: copy it before use)."""
    path = tmp_path_factory.mktemp("rec") / "v.h5"
    proc = _psmat("record", "--simulate", "-o", path, "--seconds", "0.5", "--subject", "S01")
    assert proc.returncode == 0, proc.stderr
    return path


def _copy(src: Path, dst: Path) -> tuple[Path, str]:
    shutil.copyfile(src, dst)
    return dst, _digest(dst)


# ------------------------------------------------------------------ refusals: nothing touched
def test_info_never_exports_over_its_own_session(recorded, tmp_path) -> None:
    v, before = _copy(recorded, tmp_path / "v.h5")
    for extra in ([], ["--overwrite"]):  # an input is refused even with --overwrite
        proc = _psmat("info", v, "--csv", v, *extra)
        _refused(proc, "info", "v.h5", "input")
        assert _digest(v) == before
        assert proc.stdout == ""  # refused before the summary, not after
    # the same file under another name (a hard link) is the same file
    link = tmp_path / "link.h5"
    os.link(v, link)
    _refused(_psmat("info", v, "--csv", link, "--overwrite"), "info", "input")
    assert _digest(v) == before
    _no_temporaries(tmp_path)


def test_info_csv_replaces_an_existing_file_only_with_overwrite(recorded, tmp_path) -> None:
    v, _ = _copy(recorded, tmp_path / "v.h5")
    out = tmp_path / "out.csv"
    out.write_text("a person's notes\n")
    before = _digest(out)
    _refused(_psmat("info", v, "--csv", out), "info", "out.csv", "--overwrite")
    assert _digest(out) == before
    proc = _psmat("info", v, "--csv", out, "--overwrite")
    assert proc.returncode == 0, proc.stderr
    with open(out, newline="") as fh:
        rows = list(csv.reader(fh))
    s = load_session(v)
    assert rows[0][:3] == ["time_s", "valid", "seq"] and len(rows) == s.n_frames + 1
    _no_temporaries(tmp_path)


def test_demo_never_replaces_a_session_without_overwrite(recorded, tmp_path) -> None:
    existing, before = _copy(recorded, tmp_path / "existing.h5")
    _refused(_psmat("demo", "--twin", "--session", existing, "--out", tmp_path / "d.png"), "demo", "existing.h5",
             "--overwrite")
    assert _digest(existing) == before
    # the default session file in the working folder, and a port that is not there: the session is
    # refused before the port is tried; with --overwrite the port fails and the session is untouched
    default, before = _copy(recorded, tmp_path / "psmat_demo.h5")
    port = tmp_path / "ttyNOPE"
    _refused(_psmat("demo", "--port", port, cwd=tmp_path), "demo", "psmat_demo.h5", "--overwrite")
    assert _digest(default) == before
    proc = _psmat("demo", "--port", port, "--overwrite", cwd=tmp_path)
    _refused(proc, "demo", "ttyNOPE")
    assert _digest(default) == before
    assert not journal_path(default).exists() and not (tmp_path / "psmat_demo.png").exists()
    _no_temporaries(tmp_path)


def test_record_refuses_existing_files_and_its_inputs(recorded, tmp_path) -> None:
    existing, before = _copy(recorded, tmp_path / "existing.h5")
    _refused(_psmat("record", "--simulate", "-o", existing, "--seconds", "0.2"), "record", "--overwrite")
    assert _digest(existing) == before
    cal = tmp_path / "cal.json"
    assert _psmat("calibrate", "--simulate", "--seconds", "0.3", "--out", cal).returncode == 0
    cal_before = _digest(cal)
    _refused(_psmat("record", "--simulate", "-o", cal, "--calibration", cal, "--overwrite", "--seconds", "0.2"),
             "record", "input")
    assert _digest(cal) == cal_before
    _refused(_psmat("calibrate", "--simulate", "--seconds", "0.3", "--out", existing), "calibrate", "--overwrite")
    assert _digest(existing) == before


def test_view_and_bench_refuse_existing_files(recorded, tmp_path) -> None:
    shot, figures = tmp_path / "shot.png", tmp_path / "figures.json"
    shot.write_bytes(b"a person's screenshot")
    figures.write_bytes(b'{"owner": "a person"}')
    _refused(_psmat("view", "--simulate", "--seconds", "0.5", "--save", shot), "view", "--overwrite")
    assert shot.read_bytes() == b"a person's screenshot"
    for bench in ("study", "sensor", "iecm"):
        _refused(_psmat("bench", bench, "--json", figures), f"bench {bench}", "--overwrite")
    assert figures.read_bytes() == b'{"owner": "a person"}'
    existing, before = _copy(recorded, tmp_path / "existing.h5")
    # a session file given where a port belongs is replayed, read only
    proc = _psmat("view", existing, "--seconds", "0.5", "--save", tmp_path / "s.png")
    assert proc.returncode == 0 and "replay of existing.h5" in proc.stdout, proc.stderr
    assert _digest(existing) == before


def test_a_replacement_that_fails_leaves_the_file_as_it_was(tmp_path) -> None:
    """The one helper every output goes through (psmat._atomic): whole or not at all."""
    out = tmp_path / "table.csv"
    out.write_bytes(b"old,bytes\n")
    with pytest.raises(RuntimeError, match="half way"):
        with replacing(out) as tmp:
            tmp.write_bytes(b"new,bytes\nand half a li")
            raise RuntimeError("half way")
    assert out.read_bytes() == b"old,bytes\n"
    _no_temporaries(tmp_path)
    with replacing(out) as tmp:
        assert tmp.parent == tmp_path and tmp.suffix == ".csv" and tmp != out
        tmp.write_bytes(b"new,bytes\n")
        assert out.read_bytes() == b"old,bytes\n"  # not before the block ends
    assert out.read_bytes() == b"new,bytes\n"
    with pytest.raises(OutputRefused, match="folder"):
        check_outputs([tmp_path / "missing" / "x.csv"], overwrite=True)
    with pytest.raises(OutputRefused, match="folder"):
        check_outputs([tmp_path], overwrite=True)
    with pytest.raises(OutputRefused, match="twice"):  # one new file named as two outputs
        check_outputs([tmp_path / "x.png", tmp_path / "." / "x.png"])


# ------------------------------------------------------------------ killed and stopped recordings
def _start_record(out: Path, *extra: str) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "psmat", "record", "--simulate", "-o", str(out), *extra],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            preexec_fn=child_preexec() if os.name == "posix" else None)


def _stopped(proc: subprocess.Popen, sig: int) -> str:
    """Send ``sig`` and wait for the process to end; its stderr. A process that does not end is
    killed (and its pipes closed) before the test fails."""
    proc.send_signal(sig)
    try:
        return proc.communicate(timeout=WAIT_S)[1]
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()


def _wait_for_frames(proc: subprocess.Popen, journal: Path) -> None:
    """Until the journal has grown past its header twice (frames are being appended)."""
    deadline = time.monotonic() + WAIT_S
    sizes: list[int] = []
    while time.monotonic() < deadline and proc.poll() is None:
        if journal.is_file():
            size = journal.stat().st_size
            if not sizes or size > sizes[-1]:
                sizes.append(size)
            if len(sizes) >= 3:
                return
        time.sleep(0.05)
    proc.kill()
    raise AssertionError(f"the recording never appended frames: {proc.communicate()[1][-500:]}")


STOP_SIGNALS = [signal.SIGTERM] + ([signal.SIGHUP] if hasattr(signal, "SIGHUP") else [])


@pytest.mark.parametrize("sig", STOP_SIGNALS, ids=lambda s: signal.Signals(s).name)
def test_a_stop_signal_closes_a_recording_as_ctrl_c_does(sig, tmp_path) -> None:
    out = tmp_path / "s.h5"
    proc = _start_record(out, "--also", "imu")
    _wait_for_frames(proc, journal_path(out))
    err = _stopped(proc, sig)
    assert proc.returncode == 0, err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s.h5"]  # the journals gone, nothing else left
    s = load_session(out)
    assert s.complete and not s.recovered and s.n_frames > 0 and s.streams["imu"].n_frames > 0
    with h5py.File(out, "r") as f:  # an ordinary finished file, not a repaired one
        assert int(f.attrs["complete"]) == 1 and "repaired_utc" not in f.attrs


def test_a_stop_signal_closes_the_demos_recording(tmp_path) -> None:
    session = tmp_path / "d.h5"
    proc = subprocess.Popen([sys.executable, "-m", "psmat", "demo", "--twin", "--seconds", "120", "--session",
                             str(session), "--out", str(tmp_path / "d.png")], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, env={**os.environ, "MPLBACKEND": "Agg"},
                            preexec_fn=child_preexec() if os.name == "posix" else None)
    _wait_for_frames(proc, journal_path(session))
    err = _stopped(proc, signal.SIGTERM)
    assert proc.returncode == 128 + signal.SIGTERM and "stopped by SIGTERM" in err, err
    s = load_session(session)
    assert s.complete and s.n_frames > 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["d.h5"]


WRITER = textwrap.dedent(
    """
    import os, sys
    import numpy as np
    from psmat.io import SessionWriter

    path, n, subject, trial = sys.argv[1], int(sys.argv[2]), sys.argv[3], sys.argv[4]
    w = SessionWriter(path, (16, 16), {"serial": "KILLED01"}, metadata={"subject": subject, "trial": trial},
                      background=False)
    imu = w.add_stream("imu", kind="imu", shape=(5, 3), device={"serial": "IMU01"})
    for k in range(n):  # frame k holds the count k; the IMU's angles k / 10 degrees
        w.append(np.full((16, 16), k, np.uint16), 0.01 * k, True, seq=k, device_time_us=10_000 * k)
        if k % 10 == 0:
            imu.append(np.full((5, 3), k / 10), 0.01 * k, True, seq=k // 10)
    w.flush()
    os._exit(0)  # ended without closing, as a kill or a power cut after the last sync ends it
    """
)


def _journal_only(path: Path, n: int, subject: str = "S01", trial: str = "t1") -> None:
    proc = subprocess.run([sys.executable, "-c", WRITER, str(path), str(n), subject, trial], capture_output=True,
                          text=True, timeout=WAIT_S)
    assert proc.returncode == 0, proc.stderr
    assert not path.exists() and journal_path(path).is_file() and journal_path(path, "imu").is_file()


def test_repair_writes_every_frame_of_a_journal_only_recording(tmp_path) -> None:
    path = tmp_path / "k.h5"
    _journal_only(path, 57)
    # every command that meets it says that psmat repair finishes it
    proc = _psmat("info", path)
    assert proc.returncode == 0 and f"psmat repair {path}" in proc.stderr and len(proc.stderr.splitlines()) == 1
    _refused(_psmat("view", path), "view", f"psmat repair {path}")
    proc = _psmat("repair", path)
    assert proc.returncode == 0, proc.stderr
    assert "57 frames (psm)" in proc.stdout and "stream imu: 6 frames (imu)" in proc.stdout
    assert "recovered from the journal" in proc.stdout  # the loader's notes
    assert sorted(p.name for p in tmp_path.iterdir()) == ["k.h5"]
    s = load_session(path)
    assert s.complete and s.n_frames == 57
    np.testing.assert_array_equal(s.counts, np.arange(57)[:, None, None] * np.ones((1, 16, 16)))
    np.testing.assert_array_equal(s.seq, np.arange(57))
    np.testing.assert_array_equal(s.streams["imu"].counts[:, 0, 0], np.arange(0, 57, 10) / 10)
    # a finished file: nothing to repair, nothing touched
    before = _digest(path)
    proc = _psmat("repair", path)
    assert proc.returncode == 0 and "nothing to repair" in proc.stdout
    assert _digest(path) == before
    _refused(_psmat("repair", tmp_path / "none.h5"), "repair", "nothing to repair")


def test_a_killed_overwrite_keeps_the_old_file_and_repair_needs_overwrite(recorded, tmp_path) -> None:
    path, before = _copy(recorded, tmp_path / "v.h5")
    proc = _start_record(path, "--overwrite")
    _wait_for_frames(proc, journal_path(path))
    proc.kill()  # SIGKILL: nothing closes
    proc.communicate(timeout=WAIT_S)
    assert _digest(path) == before  # the old file untouched while the new recording ran
    line = _psmat("info", path).stderr
    assert f"psmat repair {path} --overwrite" in line
    _refused(_psmat("record", "--simulate", "-o", path, "--overwrite", "--seconds", "0.2"), "record",
             f"psmat repair {path}")  # the unfinished recording is never recorded over
    _refused(_psmat("repair", path), "repair", "--overwrite")
    assert _digest(path) == before
    proc = _psmat("repair", path, "--overwrite")
    assert proc.returncode == 0, proc.stderr
    s = load_session(path)
    assert s.complete and s.n_frames > 0 and not journal_path(path).exists()
    assert s.created_utc != load_session(recorded).created_utc  # the new recording, not the old one


# ------------------------------------------------------------------ studies
@pytest.fixture(scope="module")
def small_study(tmp_path_factory) -> Path:
    """One volunteer, three 4 s trials at 50 Hz (read-only: copy it before use)."""
    from psmat.synth import simulate_study

    root = simulate_study(tmp_path_factory.mktemp("study") / "study", volunteers=1, duration_s=4.0, seed=5,
                          rate_hz=50.0)
    shutil.rmtree(root / "truth")
    return root


def test_a_journal_only_session_is_a_status_row_and_the_run_goes_on(small_study, tmp_path) -> None:
    root = Path(shutil.copytree(small_study, tmp_path / "study"))
    killed = root / "sessions" / "V01_rotation.h5"
    killed.unlink()
    _journal_only(killed, 120, subject="V01", trial="rotation")
    proc = _psmat("study", "run", root, "--workers", "1", "--quiet")
    assert proc.returncode == 0, proc.stderr
    assert f"psmat repair {killed}" in proc.stdout
    with open(root / "results" / "metrics.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    rotation = [r for r in rows if r["trial"] == "rotation"]
    # every row of it, SCHC-DYN (fitted across volunteers) saying why it was not corrected
    assert rotation and all(f"recording not closed: run psmat repair {killed}" in r["status"] for r in rotation)
    assert all(r["sd_ml_cm"] == "" for r in rotation)  # no numbers from an unfinished recording
    others = [r for r in rows if r["trial"] != "rotation" and r["variant"] == "PROP"]
    assert {r["trial"] for r in others} == {"right-leg", "left-leg"} and all(r["status"] == "ok" for r in others)
    assert journal_path(killed).is_file() and not killed.exists()  # the study never repairs or deletes it


def test_a_posture_study_names_a_journal_only_session(tmp_path) -> None:
    from psmat.posture import load_posture_study

    (tmp_path / "sessions").mkdir()
    killed = tmp_path / "sessions" / "P01_d1.h5"
    _journal_only(killed, 30, subject="P01", trial="d1")
    with pytest.raises(FileNotFoundError, match=f"psmat repair {killed}"):
        load_posture_study(tmp_path, workers=1, progress=False)


def _command(p) -> str:
    import psutil

    try:
        return " ".join(p.cmdline())
    except (psutil.NoSuchProcess, psutil.AccessDenied, psutil.ZombieProcess):
        return ""


def _gone(p) -> bool:
    import psutil

    try:
        return p.status() == psutil.STATUS_ZOMBIE  # ended; its new parent has not reaped it yet
    except psutil.NoSuchProcess:
        return True


def test_a_killed_study_run_leaves_no_worker_behind(small_study, tmp_path) -> None:
    psutil = pytest.importorskip("psutil")
    root = Path(shutil.copytree(small_study, tmp_path / "study"))
    proc = subprocess.Popen([sys.executable, "-m", "psmat", "study", "run", str(root), "--workers", "2", "--quiet"],
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                            preexec_fn=child_preexec() if os.name == "posix" else None)
    parent = psutil.Process(proc.pid)
    children: list = []
    try:
        deadline = time.monotonic() + WAIT_S
        while time.monotonic() < deadline and proc.poll() is None:  # until the pool's workers run
            children = parent.children(recursive=True)
            if sum("loky" in _command(c) for c in children if not _gone(c)) >= 2:
                break
            time.sleep(0.05)
        assert proc.poll() is None, "the run ended before its workers were seen"
        proc.kill()  # SIGKILL: nothing in the run gets to clean up
        proc.wait(timeout=WAIT_S)
        children = [c for c in children if not _gone(c)]
        assert children
        deadline = time.monotonic() + WAIT_S
        while time.monotonic() < deadline and not all(_gone(c) for c in children):
            time.sleep(0.1)
        assert [c.pid for c in children if not _gone(c)] == []
    finally:
        for c in children:
            if not _gone(c):
                c.kill()
        if proc.poll() is None:
            proc.kill()


@pytest.fixture
def small(tmp_path: Path):
    """A real full disk: a tmpfs of 160 KiB."""
    with small_disk(tmp_path / "small", 160) as d:
        yield d


def test_a_recording_that_fills_the_disk_stops_says_so_and_its_frames_are_repaired(small, tmp_path) -> None:
    """Before: the reader detached the full file and went on, the progress bar counting frames that
    went nowhere for the whole --seconds, and the close ended in a traceback. Now the recording stops
    at the first frame the file cannot take, in two lines, and the journal holds every frame before it."""
    out = small / "a.h5"
    done = _psmat("record", "--simulate", "--seconds", "60", "-o", out)
    assert done.returncode == 1 and "Traceback" not in done.stderr, done.stderr
    lines = [ln for ln in done.stderr.replace("\r", "\n").splitlines() if ln.startswith("psmat record:")]
    assert lines == [
        f"psmat record: {out} takes no more frames (no space left on the disk): the recording stopped; the frames "
        "before it are kept",
        f"psmat record: {out}: the session could not be completed (no space left on the disk); the journal "
        f"{journal_path(out)} was kept — load_session() recovers it; psmat repair {out} finishes it once the disk "
        "has room"]
    room = tmp_path / "room"
    room.mkdir()
    shutil.copy(journal_path(out), journal_path(room / "a.h5"))  # the person makes room elsewhere
    fixed = _psmat("repair", room / "a.h5")
    assert fixed.returncode == 0, fixed.stderr
    s = load_session(room / "a.h5")
    assert s.n_frames > 10 and s.valid.all() and np.all(np.diff(s.seq) == 1)  # every frame before the disk filled


def test_a_command_that_fills_the_disk_is_one_line(small) -> None:
    done = _psmat("study", "simulate", small / "study", "--volunteers", "1", "--seconds", "5", "--seed", "1")
    assert done.returncode == 1 and "Traceback" not in done.stderr, done.stderr
    last = done.stderr.replace("\r", "\n").splitlines()[-1]
    assert last.startswith("psmat study simulate: ") and "no space left on the disk" in last
    assert last.endswith(f"make room, remove {small / 'study'} and run it again")

"""Bad input is one clear line (command line: exit status 1, nothing written) or one clear
exception (API), never a traceback or a raw library error.

Each case was a traceback, a raw pybind11/numpy/torch error or a silent waste before: a missing
output folder, a missing calibration file, a rate the firmware cannot run (docs/spec.md §5:
1 ... 1000 frames/s), a mat larger than the twin's 64 x 64 frame buffer, a NaN or negative
argument, an hour-long simulation asked for a billion seconds, a posture command on a balance
study, a subjects.csv with one bad row or a byte-order mark, a force-platform file that is not
text or whose clock stands still, an IECM iteration count beyond a 32-bit integer, a frame whose
dense matrices do not fit, a pressure of 1e300 psi, a truncated posture checkpoint.

The command line runs as a person runs it: ``python -m psmat ...`` in a subprocess, in a fresh
folder.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import posture_synth as ps
import pytest

import psmat
from psmat.io import SessionWriter
from psmat.sensor import MPICreep
from psmat.study import find_study
from psmat.study import process_trial

# ---------------------------------------------------------------------------------- command line


def _files(folder: Path) -> set[str]:
    return {str(p.relative_to(folder)) for p in folder.rglob("*")}


def _psmat(args: list[str], cwd: Path) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, "MPLBACKEND": "Agg", "PYTHONWARNINGS": "ignore"}
    # a hang guard, not a timing: a check that works answers before any device or simulation starts
    return subprocess.run([sys.executable, "-m", "psmat", *args], cwd=cwd, env=env, capture_output=True, text=True,
                          timeout=240, check=False)


def _one_clear_line(proc: subprocess.CompletedProcess[str], prog: str, words: list[str]) -> str:
    assert proc.returncode == 1, (proc.returncode, proc.stderr[-2000:])
    assert "Traceback" not in proc.stderr, proc.stderr[-2000:]
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1, lines
    line = lines[0]
    assert line.startswith(f"{prog}: "), line
    for w in words:
        assert w in line, (w, line)
    return line


# (argv, the words the one line must hold); every command stops by itself (--seconds) if a
# check is missing, so a regression fails instead of waiting
TWIN = ["--simulate", "--seconds", "1"]
BAD_COMMAND_LINES = [
    (["record", *TWIN, "-o", "nodir/x.h5"], ["nodir", "exist"]),
    (["record", *TWIN, "-o", "x.h5", "--calibration", "missing.json"],
     ["--calibration", "no such file", "missing.json"]),
    (["record", *TWIN, "-o", "x.h5", "--calibration", "caldir"], ["--calibration", "caldir", "folder"]),
    (["record", *TWIN, "-o", "x.h5", "--calibration", "notjson.json"], ["notjson.json", "not a valid calibration"]),
    (["record", *TWIN, "-o", "x.h5", "--rate", "100000"], ["--rate", "1000 Hz", "100000"]),
    (["record", *TWIN, "-o", "x.h5", "--rate", "1e-6"], ["--rate", "whole number"]),
    (["record", *TWIN, "-o", "x.h5", "--shape", "255x255"], ["64x64", "255x255"]),
    (["record", *TWIN, "-o", "x.h5", "--device", "imu", "--rate", "500"], ["100 Hz", "500"]),
    (["view", *TWIN, "--save", "v.png", "--g-rest", "-1"], ["--g-rest", ">= 0"]),
    (["view", *TWIN, "--save", "v.png", "--g-rest", "nan"], ["--g-rest", "nan"]),
    (["view", *TWIN, "--save", "nodir/v.png"], ["nodir", "exist"]),
    (["view", *TWIN, "--save", "v.xyz"], ["--save", ".xyz", ".png"]),
    (["calibrate", "--simulate", "--seconds", "0.2", "--out", "nodir/c.json"], ["nodir", "exist"]),
    (["calibrate", "--simulate", "--seconds", "0.2", "--out", "c.json", "--shape", "255x255"], ["64x64", "255x255"]),
    (["demo", "--twin", "--seconds", "1", "--out", "nodir/d.png", "--session", "d.h5"], ["nodir", "exist"]),
    (["demo", "--twin", "--seconds", "1", "--out", "d.xyz", "--session", "d.h5"], ["--out", ".xyz"]),
    (["demo", "--twin", "--seconds", "1", "--rate", "100000", "--out", "d.png", "--session", "d.h5"],
     ["--rate", "1000"]),
    (["demo", "--twin", "--seconds", "1e9", "--out", "d.png", "--session", "d.h5"], ["--seconds", "3600"]),
    (["demo", "--crosstalk", "--out", "nodir/d.png"], ["nodir", "exist"]),
    (["demo", "--crosstalk", "--out", "d.png", "--noise-mv", "nan"], ["--noise-mv", "nan"]),
    (["demo", "--crosstalk", "--out", "d.png", "--shape", "255x255"], ["64x64", "255x255"]),
    (["study", "simulate", "s", "--volunteers", "1", "--seconds", "1e9", "--seed", "0"], ["--seconds", "3600"]),
    (["study", "simulate", "s", "--volunteers", "1", "--seconds", "2", "--seed", "0", "--rate", "5000"],
     ["--rate", "1000"]),
    (["posture", "simulate", "p", "--seed", "0", "--seconds", "1e9", "--quiet"], ["--seconds", "3600"]),
    (["simulate", "--rate", "100000", "--duration", "1"], ["--rate", "1000"]),
    (["simulate", "--rate", "1e-6", "--duration", "1"], ["--rate", "whole number"]),
]


@pytest.mark.parametrize("argv, words", BAD_COMMAND_LINES, ids=[" ".join(a) for a, _ in BAD_COMMAND_LINES])
def test_a_bad_command_line_is_one_line_exit_1_and_writes_nothing(argv, words, tmp_path):
    (tmp_path / "caldir").mkdir()
    (tmp_path / "notjson.json").write_text("{not json")
    before = _files(tmp_path)
    proc = _psmat(argv, tmp_path)
    prog = "psmat " + " ".join(argv[:2] if argv[0] in ("study", "posture") else argv[:1])
    _one_clear_line(proc, prog, words)
    assert _files(tmp_path) == before


@pytest.fixture(scope="module")
def balance_study(tmp_path_factory):
    """A small simulated balance study: the mat and the force platform, no spine IMUs."""
    from psmat.synth import simulate_study

    return simulate_study(tmp_path_factory.mktemp("bal") / "study", volunteers=1, duration_s=2.0, seed=0)


@pytest.mark.parametrize("action", [["train", "--split", "ksi"], ["heldout"]])
def test_posture_on_a_balance_study_is_one_line(action, balance_study, tmp_path):
    pytest.importorskip("torch")
    before = _files(balance_study)
    proc = _psmat(["posture", *action, str(balance_study), "--quiet", "--epochs", "1"], tmp_path)
    # one line for the study, not one per session, and no posture input computed or cached
    _one_clear_line(proc, f"psmat posture {action[0]}", ["no session can be used", "3 left out", "imu",
                                                         "balance study"])
    assert _files(balance_study) == before and _files(tmp_path) == set()


# ---------------------------------------------------------------------------------- study inputs


def _session(path: Path, subject: str, trial: str, host_time_s: np.ndarray) -> None:
    n = host_time_s.size
    with SessionWriter(path, (4, 4), {"rows": 4, "cols": 4}, metadata={"subject": subject, "trial": trial}) as w:
        w.append(np.full((n, 4, 4), 1000, np.uint16), host_time_s, np.ones(n, bool))


def _study(root: Path, subjects_csv: bytes) -> Path:
    (root / "sessions").mkdir(parents=True)
    (root / "forceplate").mkdir()
    (root / "subjects.csv").write_bytes(subjects_csv)
    for sid in ("S01", "S02", "S03"):
        _session(root / "sessions" / f"{sid}_rot.h5", sid, "rotation", np.arange(16) * 0.01)
        (root / "forceplate" / f"{sid}_rot.csv").write_text("time,x,y\n0,0,0\n0.01,0.1,0.2\n")
    return root


SUBJECTS = "subject,weight_kg,height_cm\nS01,70.5,175\nS02,58,160\nS03,81.2,181\n"


@pytest.mark.parametrize("text, refused, why", [
    (SUBJECTS.encode("utf-8-sig"), set(), None),  # a spreadsheet's UTF-8 CSV starts with a byte-order mark
    (SUBJECTS.replace("S02,58", "S02,heavy").encode(), {"S02"}, "weight_kg of 'S02' is not a number"),
    (SUBJECTS.replace("S02,58,160", "S02,58,160,extra").encode("utf-8-sig"), {"S02"}, "4 fields for 3 columns"),
    ((SUBJECTS + "S03,80,180\n").encode(), {"S03"}, "'S03' appears twice (lines 4 and 5)"),
], ids=["byte-order mark", "weight not a number", "a field too many", "a subject twice"])
def test_a_bad_subjects_row_costs_only_its_subject(text, refused, why, tmp_path):
    layout = find_study(_study(tmp_path / "study", text))
    weights = {"S01": 70.5, "S02": 58.0, "S03": 81.2}
    kept = {s: w for s, w in weights.items() if s not in refused}
    assert {s: v.weight_kg for s, v in layout.subjects.items()} == kept
    for item in layout.items:
        if item.subject in refused:
            assert len(item.problems) == 1 and why in item.problems[0] and "subjects.csv:" in item.problems[0]
        else:
            assert item.ok, item.problems
    assert layout.problems == []  # said by the sessions of the subject, once each


@pytest.mark.parametrize("encoding", ["cp1252", "utf-16"])
def test_a_subjects_file_a_spreadsheet_saved_is_read(encoding, tmp_path):
    # Excel's "CSV" on a western Windows is Windows-1252; its "Unicode text" UTF-16 with tabs
    text = SUBJECTS.replace("S01", "José")
    if encoding == "utf-16":
        text = text.replace(",", "\t").replace("70.5", "70,5")  # and a decimal comma, as a European Excel
    layout = find_study(_study(tmp_path / "study", text.encode(encoding)))
    assert {s: v.weight_kg for s, v in layout.subjects.items()} == {"José": 70.5, "S02": 58.0, "S03": 81.2}


def test_a_subjects_file_that_is_not_text_is_one_line(tmp_path):
    layout = find_study(_study(tmp_path / "study", SUBJECTS.encode() + b"S04\x00\x00,70\n"))
    assert layout.subjects == {}
    assert len(layout.problems) == 1 and "is not text (byte 0x00 at offset" in layout.problems[0]
    assert "Error" not in layout.problems[0]


@pytest.mark.parametrize("case, words", [
    ("mat clock stands still", ["frame times do not advance"]),
    ("platform clock stands still", ["S01_rot.csv", "times do not advance"]),
    ("platform file is binary", ["S01_rot.csv", "is not text", "0xff"]),
])
def test_a_study_status_says_what_is_wrong_in_words(case, words, tmp_path):
    root = _study(tmp_path / "study", SUBJECTS.encode())
    session, plate = root / "sessions" / "S01_rot.h5", root / "forceplate" / "S01_rot.csv"
    if case == "mat clock stands still":  # every frame stamped at the same time: no frame rate
        session.unlink()
        _session(session, "S01", "rotation", np.zeros(16))
    elif case == "platform clock stands still":
        plate.write_text("time,x,y\n" + "".join(f"0,{0.1 * k},0.2\n" for k in range(20)))
    else:
        plate.write_bytes(b"\xff\xfe\x00\x01binary")
    rows = process_trial(session, plate, "S01", "rotation", 70.5)
    status = rows[0]["status"]
    assert all(r["status"] == status for r in rows) and status.startswith("error: ValueError: ")
    for w in words:
        assert w in status, (w, status)
    assert "ZeroDivisionError" not in status and "UnicodeDecodeError" not in status


# ---------------------------------------------------------------------------------- numerical API

G4 = np.full((4, 4), 1e-3)


@pytest.mark.parametrize("max_iter", [10**12, 2**31, 2.5, "many", True, 0])
def test_iecm_iteration_count_is_checked_in_python(max_iter):
    # the core counts iterations in a 32-bit int: 2**31 - 1 at most, never a pybind11 TypeError
    with pytest.raises(ValueError, match=r"max_iter must be an integer 1 \.\.\. 2147483647"):
        psmat.iecm.solve(G4, max_iter=max_iter)


@pytest.mark.parametrize("call", [
    lambda G: psmat.iecm.solve(G),
    lambda G: psmat.iecm.solve(G, method="bounded_lsq"),
    lambda G: psmat.iecm.Stream(G.shape),
    lambda G: psmat.iecm.jacobian(G),
    lambda G: psmat.iecm.propagate_uncertainty(G),
], ids=["solve", "solve bounded_lsq", "Stream", "jacobian", "propagate_uncertainty"])
def test_a_frame_too_large_for_dense_matrices_is_refused_before_allocating(call):
    # 200 x 200 = 40 000 cells: a dense 40 000 x 40 000 matrix of float32 alone is 6.4 GB, of
    # float64 12.8 GB, over the 4 GiB per thread any method may take (std::bad_alloc before)
    with pytest.raises(ValueError, match=r"200x200 frame has 40000 cells.*40000x40000.*limit of 4\.29 GB.*at most"):
        call(np.full((200, 200), 1e-4))


def test_the_dense_limit_still_admits_the_largest_mat_of_the_spec():
    # docs/spec.md §10 benchmarks 64 x 64 mats: far inside the limit for every method
    from psmat.iecm._validate import check_dense_size

    for method in psmat.iecm.METHODS:
        check_dense_size((64, 64), method, threads=1)


@pytest.mark.parametrize("p, words", [
    ([1e300], ["1e+300 psi at sample 0", "beyond 320 psi", "psi"]),
    ([5.0, 1e300], ["at sample 1"]),
    ([400.0], ["400 psi", "beyond 320 psi"]),
])
def test_a_pressure_out_of_range_is_refused_and_the_state_kept(p, words):
    m = MPICreep.thesis()  # p_max = 32 psi (thesis Table 2.11)
    state = m.rest_state()
    m.direct([3.0, 4.0], 0.01, state)
    y, yc, p_prev = state.y.copy(), state.y_creep.copy(), state.p_prev.copy()
    with pytest.raises(ValueError) as err:
        m.direct(p, 0.01, state)
    for w in words:
        assert w in str(err.value), (w, str(err.value))
    assert np.array_equal(state.y, y) and np.array_equal(state.y_creep, yc) and np.array_equal(state.p_prev, p_prev)


def test_a_non_finite_conductance_is_refused_and_the_state_kept():
    # a1 = 1e307 S/psi: at 30 psi the polynomial term alone is 3e308 S, beyond a float64
    m = MPICreep(rho=1.64e-4, tau=0.269, a1=1e307, a2=0.0, a3=0.0)
    state = m.rest_state()
    with pytest.raises(ValueError, match=r"p = 30 psi at sample 0 gives a conductance of inf S, not a finite number"):
        m.direct([30.0], 0.01, state)
    assert np.all(state.y == 0) and np.all(state.y_creep == 0) and state.p_prev == 0


# ---------------------------------------------------------------------------------- posture checkpoint


def _truncated_zip(path: Path) -> None:
    """A torch archive cut one byte short of its end (torch.load: "[Errno 22] Invalid argument")."""
    import torch

    torch.save({"a": torch.zeros(1000), "fingerprint": "x"}, path)
    data = path.read_bytes()
    path.write_bytes(data[:-1])


@pytest.mark.parametrize("damage", ["empty", "half", "one byte short", "not a dict"])
def test_a_damaged_checkpoint_is_one_error_naming_the_file(damage, tmp_path):
    torch = pytest.importorskip("torch")
    from psmat.posture.learn import train_posture

    recs = ps.study(3, 1, 200, 8, 8)
    kw = dict(split="ksi", epochs=1, window=20, windows_per_epoch=64, augment=False, progress=False,
              baseline=False, threads=1)
    train_posture(recs, tmp_path, **kw)
    ckpt = tmp_path / "checkpoints" / "ksi" / "last.pt"
    good = ckpt.read_bytes()
    if damage == "empty":
        ckpt.write_bytes(b"")
    elif damage == "half":
        ckpt.write_bytes(good[: len(good) // 2])
    elif damage == "one byte short":
        _truncated_zip(ckpt)
    else:
        torch.save([1, 2, 3], ckpt)
    with pytest.raises(ValueError) as err:
        train_posture(recs, tmp_path, **{**kw, "epochs": 2})
    msg = str(err.value)
    assert str(ckpt) in msg and "checkpoint" in msg and "\n" not in msg


@pytest.mark.parametrize("content, says", [
    (b"\x89HDF\r\n\x1a\n" + bytes(504), "is a session file (HDF5), not a serial port: `psmat info"),
    (b"0,1,2\n", "is a regular file, not a serial port (a device such as"),
])
def test_a_file_given_as_the_port_of_record_is_one_line_and_nothing_written(tmp_path, content, says) -> None:
    """A recording (or any file) where ``psmat record`` expects a device: one line naming what
    reads files, exit 1, and no output file."""
    src = tmp_path / "given.h5"
    src.write_bytes(content)
    out = tmp_path / "out.h5"
    r = subprocess.run([sys.executable, "-m", "psmat", "record", str(src), "--seconds", "1", "-o", str(out)],
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 1, r.stderr
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and says in lines[0], r.stderr
    assert not out.exists() and src.read_bytes() == content

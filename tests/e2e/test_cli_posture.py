"""``psmat posture simulate`` (docs/spec.md §8): a one-subject posture study written from the command
line; errors are one line and exit status 1."""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import pytest

from psmat.cli import main
from psmat.io import load_session


@pytest.fixture(scope="module")
def simulated(tmp_path_factory) -> Path:
    root = tmp_path_factory.mktemp("cli") / "posture"
    assert main(["posture", "simulate", str(root), "--subjects", "1", "--days", "2", "--seed", "3", "--seconds", "8",
                 "--rate", "50", "--quiet"]) == 0
    return root


def test_posture_simulate_writes_the_study_and_says_where(simulated, capsys) -> None:
    assert sorted(p.name for p in (simulated / "sessions").iterdir()) == ["P01_d1.h5", "P01_d2.h5"]
    with open(simulated / "subjects.csv", newline="") as fh:
        assert [r["subject"] for r in csv.DictReader(fh)] == ["P01"]
    s = load_session(simulated / "sessions" / "P01_d2.h5")
    assert s.metadata["day"] == 2 and s.device["rate"] == 50
    assert np.median(np.diff(s.host_time_s)) == pytest.approx(0.02, rel=0.01)  # --rate 50
    assert s.streams["imu"].counts.shape[1:] == (5, 3)
    assert (simulated / "truth" / "README.txt").is_file()


def test_the_command_prints_one_line(tmp_path, capsys) -> None:
    root = tmp_path / "p"
    assert main(["posture", "simulate", str(root), "--subjects", "1", "--days", "1", "--seed", "1", "--seconds",
                 "6", "--quiet"]) == 0
    out, err = capsys.readouterr()
    assert out == f"simulated posture study in {root}: 1 subject(s) x 1 day(s)\n"
    assert err == ""  # --quiet: no progress bar


ERRORS = [
    (["posture"], "required: {simulate,train,heldout}"),
    (["posture", "simulate", "{missing}", "--seed", "1", "--subjects", "0"], "--subjects: must be >= 1"),
    (["posture", "simulate", "{missing}", "--seed", "1", "--days", "two"], "--days: must be an integer"),
    (["posture", "simulate", "{missing}", "--seed", "1", "--seconds", "2"], "at least 5 s"),
    (["posture", "simulate", "{missing}", "--seed", "-1", "--seconds", "6"], "seed must be a non-negative integer"),
    (["posture", "simulate", "{missing}", "--seconds", "6"], "required: --seed"),
    (["posture", "simulate", "{study}", "--seed", "1", "--seconds", "6"], "not an empty folder"),
]


@pytest.mark.parametrize("argv, words", ERRORS, ids=[w for _, w in ERRORS])
def test_errors_are_one_line_and_exit_status_1(simulated, tmp_path, capsys, argv, words) -> None:
    missing = tmp_path / "nowhere"
    argv = [a.format(missing=missing, study=simulated) for a in argv]
    capsys.readouterr()
    assert main(argv) == 1
    out, err = capsys.readouterr()
    lines = err.strip().splitlines()
    assert len(lines) == 1 and words in lines[0], err
    assert not missing.exists()


# ------------------------------------------------------------------ psmat posture train (simulation)
@pytest.fixture(scope="module")
def trainable(tmp_path_factory) -> Path:
    # 2 subjects x 1 day x 60 s: 600 IMU samples per session, so the 10 % validation block holds
    # 50-frame windows; the mat at 20 Hz keeps IECM short
    root = tmp_path_factory.mktemp("cli") / "train"
    assert main(["posture", "simulate", str(root), "--subjects", "2", "--days", "1", "--seed", "4", "--seconds", "60",
                 "--rate", "20", "--quiet"]) == 0
    return root


def test_posture_train_writes_table_4_4_and_reports_it(trainable, capsys) -> None:
    capsys.readouterr()
    assert main(["posture", "train", str(trainable), "--split", "ksi", "--epochs", "1", "--windows-per-epoch", "64",
                 "--workers", "1", "--quiet"]) == 0
    out = capsys.readouterr().out
    table = trainable / "results" / "posture" / "table44_ksi.csv"
    assert str(table) in out
    with open(table, newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert [(r["model"], r["subset"]) for r in rows][:2] == [(rows[0]["model"], "validation"),
                                                              (rows[0]["model"], "test")]
    assert {r["split"] for r in rows} == {"ksi"}
    for r in rows:
        assert float(r["MSE"]) > 0 and all(k in r for k in ("R2_Sensor0", "R2_Sum"))
        assert f"{r['model']} {r['subset']}: MSE" in out
    # each session's inputs are cached (psmat.posture.load_posture_study)
    assert len(list((trainable / "results" / "posture" / "inputs").glob("*.npz"))) == 2


def test_posture_train_errors_are_one_line(tmp_path, capsys) -> None:
    assert main(["posture", "train", str(tmp_path), "--split", "lso", "--quiet"]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "no sessions/ folder" in err[0]


# ------------------------------------------------------------------ psmat posture heldout
def test_posture_heldout_needs_three_subjects_and_says_so_in_one_line(trainable, tmp_path, capsys) -> None:
    capsys.readouterr()
    assert main(["posture", "heldout", str(trainable), "--epochs", "1", "--workers", "1", "--quiet"]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0] == "psmat posture heldout: LSO needs at least 3 subjects (train, validation, " \
                                      "test), got 2"
    assert not (trainable / "results" / "posture" / "heldout.csv").exists()
    assert main(["posture", "heldout", str(tmp_path), "--quiet"]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "no sessions/ folder" in err[0]

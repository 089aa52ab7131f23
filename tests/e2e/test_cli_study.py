"""``psmat study simulate`` and ``psmat study run`` (docs/spec.md §9 command line): a one-volunteer
simulated study written and run from the command line; errors are one line and exit status 1."""

from __future__ import annotations

import csv
from pathlib import Path

import pytest

from psmat.balance import VARIANTS
from psmat.cli import main


@pytest.fixture(scope="module")
def simulated(tmp_path_factory) -> Path:
    root = tmp_path_factory.mktemp("cli") / "study"
    assert main(["study", "simulate", str(root), "--volunteers", "1", "--seconds", "4", "--seed", "3",
                 "--rate", "50"]) == 0
    return root


def test_study_run_writes_the_variants_asked_for_and_says_where(simulated, capsys) -> None:
    # one run for the whole command: --variants beyond the thesis' (by name) ride along;
    # run_study's default variants are checked in tests/e2e/test_study_run.py
    capsys.readouterr()
    variants = ["--variants", "default,SCHC-EQ"]
    assert main(["study", "run", str(simulated), "--workers", "1", "--quiet", *variants]) == 0
    out, err = capsys.readouterr()
    assert out.splitlines()[:2] == ["3 sessions: 3 computed, 0 reused, 0 failed",
                                    f"results in {simulated / 'results'}: metrics.csv, summary.csv, pairwise.csv, "
                                    "report.md, figures/"]
    assert err == ""  # --quiet: no progress bar
    with open(simulated / "results" / "metrics.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    # 'default' stands for the thesis' variants; SCHC-EQ after them, the study-level SCHC-DYN last
    assert [(r["subject"], r["trial"], r["variant"]) for r in rows] == [
        ("V01", t, v) for t in ("right-leg", "left-leg", "rotation")
        for v in ("FP",) + VARIANTS + ("SCHC-EQ", "SCHC-DYN")]
    # one volunteer: no other to fit SCHC-DYN on, said in its status
    assert all(r["status"] != "ok" for r in rows if r["variant"] == "SCHC-DYN")
    assert (simulated / "results" / "summary.csv").is_file()
    # the sessions say a simulator wrote them (their metadata; truth/ is not read): so does the report
    assert (simulated / "results" / "report.md").read_text().startswith("# Balance study results (simulation)")
    # run again (default workers): nothing to compute
    assert main(["study", "run", str(simulated), "--quiet", *variants]) == 0
    assert capsys.readouterr().out.startswith("3 sessions: 0 computed, 3 reused, 0 failed\n")


ERRORS = [
    (["study", "run", "{missing}"], "psmat study run: study folder not found"),
    (["study", "run", "{study}", "--workers", "2", "--scheduler", "tcp://127.0.0.1:8786"], "not both"),
    (["study", "run", "{study}", "--workers", "0"], "--workers: must be >= 1"),
    (["study", "run", "{study}", "--variants", "default,SCHC-XX"], "unknown variant(s) ['SCHC-XX']"),
    (["study"], "required: {run,simulate}"),
    (["study", "simulate", "{missing}", "--volunteers", "0", "--seconds", "4", "--seed", "1"],
     "--volunteers: must be >= 1"),
    (["study", "simulate", "{missing}", "--volunteers", "1", "--seconds", "4", "--seed", "1", "--bds",
      "{missing}.txt"], "psmat study simulate: BDS trajectory file not found"),
    (["study", "simulate", "{study}", "--volunteers", "1", "--seconds", "4", "--seed", "1"], "not an empty folder"),
]


@pytest.mark.parametrize("argv, words", ERRORS, ids=[" ".join(a[:2]) + f" ({w})" for a, w in ERRORS])
def test_errors_are_one_line_and_exit_status_1(simulated, tmp_path, capsys, argv, words) -> None:
    missing = tmp_path / "nowhere"
    argv = [a.format(missing=missing, study=simulated) for a in argv]
    capsys.readouterr()
    assert main(argv) == 1
    out, err = capsys.readouterr()
    lines = err.strip().splitlines()
    assert len(lines) == 1 and words in lines[0], err
    assert not missing.exists()

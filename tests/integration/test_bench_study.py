"""The balance-study benchmark end to end on a tiny simulated study (its figures are not
checked: no test asserts a time; what it runs and compares is)."""

from __future__ import annotations

import json

import pytest

from psmat.bench.study import format_report, main, parallel_fraction, run
from psmat.study import DEFAULT_PARAMS


def test_the_benchmark_runs_both_ways_and_the_rerun_reuses_every_session(tmp_path) -> None:
    r = run(volunteers=1, seconds=4.0, rate_hz=50.0, workers=1, seed=3, study_dir=str(tmp_path / "study"))
    assert r["sessions"] == 3 and r["frames"] == 3 * 200
    assert r["psmat_report"] == {"computed": 3, "reused": 0, "failed": 0}
    assert r["resume_computed"] == 0
    # the baseline ran the same per-session function over the same sessions: FP + every variant
    assert r["baseline_rows"] == 3 * (1 + len(DEFAULT_PARAMS["variants"]))
    text = format_report(r)
    assert "600 frames" in text and "multiprocessing.Pool" in text and "extrapolated" in text
    # each stage from the run's own results/timings.csv, and the serial part beside the run
    assert {"discover", "sessions", "after_sessions", "figures", "report"} <= set(r["stages"])
    assert r["stages"]["sessions"]["cpu_s"] > 0 and r["resume_stages"]["sessions"]["cpu_s"] == 0
    assert text.count("serial part (all but the session tasks)") == 2 and "after the sessions" in text
    assert text.count("parallel fraction") == 1  # the first run only: the rerun has no session work
    # a second benchmark run reuses the simulated study in --dir instead of simulating again
    again = run(volunteers=1, seconds=4.0, rate_hz=50.0, workers=1, seed=3, study_dir=str(tmp_path / "study"),
                baseline=False)
    assert again["simulate_s"] is None and "baseline_s" not in again


def test_quick_runs_a_tiny_study_and_writes_its_stages(tmp_path, capsys) -> None:
    out = tmp_path / "bench.json"
    assert main(["--quick", "--no-baseline", "--json", str(out)]) == 0
    r = json.loads(out.read_text(encoding="utf-8"))
    assert (r["volunteers"], r["seconds"], r["rate_hz"], r["workers"], r["sessions"]) == (1, 4.0, 50.0, 1, 3)
    assert r["psmat_report"]["computed"] == 3 and "baseline_s" not in r
    assert "serial part" in capsys.readouterr().out


def test_the_parallel_fraction_by_hand() -> None:
    # 80 CPU s of session work and a 10 s serial part: one core would take 90 s, 80 of them parallel
    assert parallel_fraction(80.0, 10.0) == pytest.approx(80.0 / 90.0)
    assert parallel_fraction(80.0, 0.0) == pytest.approx(1.0)  # nothing serial
    assert parallel_fraction(0.0, 5.0) is None  # no session work: nothing to estimate

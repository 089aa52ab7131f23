"""The balance-study benchmark end to end on a tiny simulated study (its figures are not
checked: no test asserts a time; what it runs and compares is)."""

from __future__ import annotations

from psmat.bench.study import format_report, run
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
    # a second benchmark run reuses the simulated study in --dir instead of simulating again
    again = run(volunteers=1, seconds=4.0, rate_hz=50.0, workers=1, seed=3, study_dir=str(tmp_path / "study"),
                baseline=False)
    assert again["simulate_s"] is None and "baseline_s" not in again

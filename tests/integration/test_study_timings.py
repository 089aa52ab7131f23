"""``results/timings.csv`` and ``results/session_timings.csv`` of ``psmat study run`` on a small
simulated study (docs/spec.md §12): every stage, each session computed then reused, and a rerun
that rewrites only the timings (no assertion on how long anything takes); on a real Dask
LocalCluster (two worker processes), each session's line names the worker that ran it, checked
against the cluster's own list of its workers and their pids."""

from __future__ import annotations

import csv
import os
import shutil
from pathlib import Path

import pytest
from dask_cluster import LOOPBACK_HTTP

from psmat.study import run_study
from psmat.synth import simulate_study

STAGES = ["discover", "keys", "sessions", "reports", "after_sessions", "figures", "report"]


def _read(path: Path) -> list[dict[str, str]]:
    with path.open(newline="", encoding="utf-8") as f:
        return list(csv.DictReader(f))


def _outputs(results: Path) -> dict[str, tuple[bytes, int]]:
    """metrics.csv, report.md, the other tables and every figure: (bytes, mtime ns)."""
    files = [results / n for n in ("metrics.csv", "report.md", "summary.csv", "pairwise.csv", ".outputs.json")]
    files += sorted((results / "figures").glob("*.png"))
    return {p.name: (p.read_bytes(), p.stat().st_mtime_ns) for p in files}


@pytest.fixture(scope="module")
def study(tmp_path_factory: pytest.TempPathFactory) -> Path:
    root = tmp_path_factory.mktemp("timings") / "study"
    simulate_study(root, volunteers=2, duration_s=4.0, seed=5, rate_hz=50.0)
    return root


def test_a_run_writes_its_stages_and_one_line_per_session_and_a_rerun_reuses_everything(study: Path) -> None:
    first = run_study(study, workers=2, progress=False)
    results = study / "results"
    sessions = sorted(p.stem for p in (study / "sessions").glob("*.h5"))
    assert first.computed == len(sessions) == 6

    stages = _read(results / "timings.csv")
    assert [r["stage"] for r in stages] == STAGES
    assert list(stages[0]) == ["stage", "wall_s", "cpu_s", "computed", "reused"]
    for r in stages:
        assert float(r["wall_s"]) >= 0 and float(r["cpu_s"]) >= 0, r
    by = {r["stage"]: r for r in stages}
    assert (by["sessions"]["computed"], by["sessions"]["reused"]) == ("6", "0")
    assert float(by["sessions"]["cpu_s"]) > 0  # six sessions processed in the workers took CPU time
    assert (by["report"]["computed"], by["report"]["reused"]) == ("1", "0")
    figures = sorted((results / "figures").glob("*.png"))
    assert (by["figures"]["computed"], by["figures"]["reused"]) == (str(len(figures)), "0")
    assert by["reports"]["computed"] == ""  # no --reports: no pages

    per = _read(results / "session_timings.csv")
    assert list(per[0]) == ["subject", "trial", "stem", "result", "start_s", "wall_s", "cpu_s", "pid", "worker"]
    assert sorted(r["stem"] for r in per) == sessions
    assert {r["result"] for r in per} == {"computed"}
    for r in per:
        assert float(r["start_s"]) >= 0 and float(r["wall_s"]) > 0 and float(r["cpu_s"]) >= 0
        assert int(r["pid"]) != os.getpid()  # two workers: each session ran in a worker process
        assert r["worker"] == ""  # a process of this machine, no Dask worker
        assert r["stem"] == f"{r['subject']}_{r['trial']}"

    before = _outputs(results)
    again = run_study(study, workers=2, progress=False)
    assert (again.computed, again.reused) == (0, 6)
    assert _outputs(results) == before  # byte-identical and not written again (mtime unchanged)

    by = {r["stage"]: r for r in _read(results / "timings.csv")}
    assert list(by) == STAGES
    assert (by["sessions"]["computed"], by["sessions"]["reused"]) == ("0", "6")
    assert float(by["sessions"]["cpu_s"]) == 0  # no task ran
    assert (by["report"]["computed"], by["report"]["reused"]) == ("0", "1")
    assert (by["figures"]["computed"], by["figures"]["reused"]) == ("0", str(len(figures)))
    per = _read(results / "session_timings.csv")
    assert sorted(r["stem"] for r in per) == sessions
    assert all(r["result"] == "reused" and r["wall_s"] == r["cpu_s"] == r["pid"] == r["worker"] == "" for r in per)


def test_with_one_worker_the_sessions_run_in_this_process(tmp_path: Path, study: Path) -> None:
    root = tmp_path / "copy"
    simulate_study(root, volunteers=1, duration_s=4.0, seed=6, rate_hz=50.0)
    run_study(root, workers=1, progress=False, reports=True)
    per = _read(root / "results" / "session_timings.csv")
    assert len(per) == 3 and {int(r["pid"]) for r in per} == {os.getpid()}
    by = {r["stage"]: r for r in _read(root / "results" / "timings.csv")}
    assert (by["reports"]["computed"], by["reports"]["reused"]) == ("1", "0")  # one subject, one page
    assert float(by["reports"]["cpu_s"]) > 0


def test_on_a_dask_cluster_each_session_names_the_worker_that_ran_it(study: Path, tmp_path: Path) -> None:
    distributed = pytest.importorskip("distributed")
    root = tmp_path / "dask"
    shutil.copytree(study, root, ignore=shutil.ignore_patterns("results"))
    sessions = sorted(p.stem for p in (root / "sessions").glob("*.h5"))
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None,
                                  scheduler_kwargs=LOOPBACK_HTTP) as c, \
            distributed.Client(c.scheduler_address) as client:
        pids = client.run(os.getpid)  # {worker address: its process id}, as the cluster knows them
        report = run_study(root, scheduler=c.scheduler_address, progress=False, reports=True)
    assert (report.computed, report.failed) == (len(sessions), 0)
    assert len(pids) == 2 and os.getpid() not in pids.values()
    results = root / "results"
    per = _read(results / "session_timings.csv")
    assert sorted(r["stem"] for r in per) == sessions and {r["result"] for r in per} == {"computed"}
    for r in per:
        assert float(r["start_s"]) >= 0 and float(r["wall_s"]) > 0 and float(r["cpu_s"]) > 0, r
        assert r["worker"] in pids and int(r["pid"]) == pids[r["worker"]], r  # a worker of this cluster
    by = {r["stage"]: r for r in _read(results / "timings.csv")}
    assert (by["sessions"]["computed"], by["sessions"]["reused"]) == (str(len(sessions)), "0")
    assert float(by["sessions"]["cpu_s"]) == pytest.approx(sum(float(r["cpu_s"]) for r in per), abs=1e-3)
    assert (by["reports"]["computed"], by["reports"]["reused"]) == ("2", "0")  # a page per volunteer, on the workers
    assert float(by["reports"]["cpu_s"]) > 0
    figures = sorted((results / "figures").glob("*.png"))
    assert figures and (by["figures"]["computed"], by["figures"]["reused"]) == (str(len(figures)), "0")
    assert sorted(p.name for p in (results / "reports").glob("*.html")) == ["V01.html", "V02.html"]


def test_a_first_run_starts_its_pool_before_finding_the_sessions_and_a_rerun_does_not(tmp_path: Path) -> None:
    from joblib.externals.loky import reusable_executor

    from psmat.study._run import _start_pool

    root = tmp_path / "first"
    simulate_study(root, volunteers=1, duration_s=4.0, seed=7, rate_hz=50.0)
    assert _start_pool(root, 1) is None  # one worker: the sessions run in this process
    ready = _start_pool(root, 2)
    assert ready is not None
    ready()  # returns once both processes have started and loaded the study's modules
    started = {p.pid for p in reusable_executor._executor._processes.values()}
    assert len(started) == 2
    run_study(root, workers=2, progress=False)
    per = _read(root / "results" / "session_timings.csv")
    assert {int(r["pid"]) for r in per} <= started  # the sessions ran in the processes started ahead
    assert _start_pool(root, 2) is None  # stored results: a rerun may have nothing to compute


def test_the_longest_sessions_are_handed_out_first(tmp_path: Path) -> None:
    root = tmp_path / "romberg"
    simulate_study(root, volunteers=1, duration_s=4.0, seed=8, rate_hz=50.0, romberg=True)  # Romberg: twice as long
    sizes = {p.stem: p.stat().st_size for p in (root / "sessions").glob("*.h5")}
    assert max(sizes, key=sizes.get) == "V01_romberg" and sorted(sizes.values())[-2] < sizes["V01_romberg"]
    run_study(root, workers=1, progress=False)  # one worker: the tasks run in the order they are handed out
    per = sorted(_read(root / "results" / "session_timings.csv"), key=lambda r: float(r["start_s"]))
    assert per[0]["stem"] == "V01_romberg"
    # the others, of one size: the rotation trial, on two feet, has the most loaded cells
    # (psmat.study._order), then the one-leg trials
    assert per[1]["trial"] == "rotation" and {r["trial"] for r in per[2:]} == {"left-leg", "right-leg"}


def test_the_work_after_the_sessions_reuses_the_pools_processes_and_starts_none(tmp_path: Path) -> None:
    # three volunteers (three SCHC-DYN tasks, seven figures) and a rerun that recomputes two
    # sessions with 4 workers asked for: its pool has 2 processes, and the SCHC-DYN tasks and the
    # figures run on those 2 instead of starting more (each new process pays the imports again)
    from joblib.externals.loky import reusable_executor

    root = tmp_path / "three"
    simulate_study(root, volunteers=3, duration_s=4.0, seed=9, rate_hz=50.0)
    run_study(root, workers=1, progress=False)
    for stem in ("V01_left-leg", "V03_rotation"):
        (root / "results" / "sessions" / f"{stem}.json").unlink()
    shutil.rmtree(root / "results" / "figures")
    report = run_study(root, workers=4, progress=False)
    assert (report.computed, report.reused) == (2, 7)
    assert len(list((root / "results" / "figures").glob("*.png"))) == 7  # drawn again, all of them
    per = _read(root / "results" / "session_timings.csv")
    ran = {int(r["pid"]) for r in per if r["result"] == "computed"}
    pool = {p.pid for p in reusable_executor._executor._processes.values()}
    assert len(pool) == 2 and ran <= pool

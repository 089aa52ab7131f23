"""``run_study`` (docs/spec.md §12) on a small simulated study (``simulate_study``): two volunteers,
their right-leg and left-leg trials (the rotation trials removed to keep it small), 6 s at
50 Hz on 16×16 mats, each volunteer on their own box and clock; ``truth/`` deleted first,
as a lab has none. The tables are compared byte for byte across reruns, a SIGKILL and resume,
worker counts and a real Dask cluster; the cache is checked through what each change reruns."""

from __future__ import annotations

import csv
import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from dask_cluster import LOOPBACK_HTTP
from small_study import SUBJECTS, two_trial_study

from psmat import Calibration
from psmat.balance import VARIANTS
from psmat.io import load_session
from psmat.study import run_study
from psmat.study import study_lock
from psmat.study import COLUMNS, process_trial
from conftest import child_preexec

TRIALS = ("right-leg", "left-leg")


@pytest.fixture(scope="module")
def study(tmp_path_factory):
    """The study and its first, uninterrupted run in one process (workers=1)."""
    root = two_trial_study(tmp_path_factory.mktemp("study") / "study", duration_s=6.0, seed=12)
    report = run_study(root, workers=1, progress=False)
    return root, report, (root / "results" / "metrics.csv").read_bytes()


def _box(root: Path, stem: str) -> Path:
    """The study's calibration file of the box a session was recorded with."""
    return root / "calibration" / f"{load_session(root / 'sessions' / f'{stem}.h5').device['serial']}.json"


def _copy(root: Path, dst: Path, results: bool) -> Path:
    shutil.copytree(root, dst, ignore=None if results else shutil.ignore_patterns("results"))
    return dst


def _rows(path: Path) -> list[dict[str, str]]:
    with open(path, newline="") as fh:
        return list(csv.DictReader(fh))


def _by_session(path: Path) -> dict[tuple[str, str], list[dict[str, str]]]:
    """Each session's own rows: SCHC-DYN is left out, it is fitted on the other volunteers
    (psmat.study.dynamic_rows), so it changes with theirs."""
    out: dict[tuple[str, str], list[dict[str, str]]] = {}
    for r in _rows(path):
        if r["variant"] == "SCHC-DYN":
            continue
        out.setdefault((r["subject"], r["trial"]), []).append(r)
    return out


def test_metrics_csv_has_a_row_per_subject_trial_variant_and_a_rerun_reuses_every_session(study, tmp_path) -> None:
    root, report, metrics = study
    assert (report.sessions, report.computed, report.reused, report.failed) == (4, 4, 0, 0)
    assert report.problems == []
    with open(root / "results" / "metrics.csv", newline="") as fh:
        assert next(csv.reader(fh)) == list(COLUMNS)
    rows = _rows(root / "results" / "metrics.csv")
    # each session's rows, then the study-level SCHC-DYN (psmat.study.dynamic_rows) after them
    assert [(r["subject"], r["trial"], r["variant"]) for r in rows] == [
        (s, t, v) for s in SUBJECTS for t in TRIALS for v in ("FP",) + VARIANTS + ("SCHC-DYN",)]
    assert {r["status"] for r in rows} == {"ok"}
    # the numbers are process_trial's for that session, weight and box, written exactly (repr)
    weight = float(_rows(root / "subjects.csv")[1]["weight_kg"])
    direct = process_trial(root / "sessions" / "V02_left-leg.h5", root / "forceplate" / "V02_left-leg.csv", "V02",
                           "left-leg", weight, calibration=_box(root, "V02_left-leg"))
    for mine, want in zip(_by_session(root / "results" / "metrics.csv")[("V02", "left-leg")], direct):
        for c in COLUMNS[4:-2]:  # the numbers (subject, trial, variant, condition, ispgr and status are text)
            assert (float(mine[c]) if mine[c] else np.nan) == pytest.approx(want[c], rel=0, abs=0, nan_ok=True), c
    # summary, figures and report beside it (psmat.study.write_results)
    assert {"summary", "pairwise", "report", "sigma_bars", "cop_traces_right-leg"} <= set(report.outputs)
    assert all(p.is_file() and p.is_relative_to(root / "results") for p in report.outputs.values())
    written = {p: p.stat().st_mtime_ns for p in report.outputs.values()}
    # a rerun reuses every session, writes the same bytes and leaves the report as it was
    again = run_study(root, workers=1, progress=False)
    assert (again.computed, again.reused, again.failed) == (0, 4, 0)
    assert (root / "results" / "metrics.csv").read_bytes() == metrics
    assert again.outputs == report.outputs and all(p.stat().st_mtime_ns == t for p, t in written.items())
    # a session taken out: its stored result is reported, not used, not deleted
    copy = _copy(root, tmp_path / "copy", results=True)
    (copy / "sessions" / "V01_left-leg.h5").unlink()
    fewer = run_study(copy, workers=1, progress=False)
    assert (fewer.computed, fewer.reused) == (0, 3)
    assert any("no longer in the study" in p and "V01_left-leg" in p for p in fewer.problems)
    assert (copy / "results" / "sessions" / "V01_left-leg.json").is_file()
    assert ("V01", "left-leg") not in _by_session(copy / "results" / "metrics.csv")


def _entries(folder: Path) -> list[Path]:
    """The finished session entries: not the hidden temporary files an unfinished write leaves (.tmp-*)."""
    return [p for p in folder.glob("*.json") if not p.name.startswith(".")]


def test_a_killed_run_resumes_with_the_unfinished_sessions_only(study, tmp_path) -> None:
    root, _, metrics = study
    copy = _copy(root, tmp_path / "killed", results=False)
    results = copy / "results" / "sessions"
    proc = subprocess.Popen([sys.executable, "-m", "psmat", "study", "run", str(copy), "--workers", "1", "--quiet"],
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, preexec_fn=child_preexec())
    try:
        deadline = time.monotonic() + 120
        while not _entries(results) and proc.poll() is None and time.monotonic() < deadline:
            time.sleep(0.01)
        os.kill(proc.pid, signal.SIGKILL)
    finally:
        proc.wait()
    assert proc.returncode == -signal.SIGKILL
    finished = {p: p.stat().st_mtime_ns for p in _entries(results)}
    assert 1 <= len(finished) < 4, sorted(p.name for p in finished)
    assert not (copy / "results" / "metrics.csv").exists()
    resumed = run_study(copy, workers=1, progress=False)
    assert (resumed.computed, resumed.reused, resumed.failed) == (4 - len(finished), len(finished), 0)
    assert all(p.stat().st_mtime_ns == t for p, t in finished.items())  # not rewritten
    assert (copy / "results" / "metrics.csv").read_bytes() == metrics  # the uninterrupted run's bytes


def test_a_changed_weight_reruns_its_subject_and_a_changed_parameter_everything(study, tmp_path) -> None:
    root, _, metrics = study
    copy = _copy(root, tmp_path / "weight", results=True)
    subjects = _rows(copy / "subjects.csv")
    subjects[1]["weight_kg"] = str(float(subjects[1]["weight_kg"]) + 8.0)
    with open(copy / "subjects.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(subjects[0]))
        w.writeheader()
        w.writerows(subjects)
    report = run_study(copy, workers=1, progress=False)
    assert (report.computed, report.reused) == (2, 2)
    assert (copy / "results" / "summary.csv").read_bytes() != (root / "results" / "summary.csv").read_bytes()
    before, after = _by_session(root / "results" / "metrics.csv"), _by_session(copy / "results" / "metrics.csv")
    for trial in TRIALS:
        assert after[("V01", trial)] == before[("V01", trial)]
        new = {r["variant"]: r for r in after[("V02", trial)]}
        old = {r["variant"]: r for r in before[("V02", trial)]}
        assert new["PROP"] == old["PROP"]  # no weight in PROP
        # eq. 3.3: a heavier body needs a larger f for the same trial (M monotone in f)
        assert float(new["SCHC"]["factor"]) > float(old["SCHC"]["factor"])
    # a parameter is part of every session's key: all rerun; only the variants asked for
    fewer = run_study(copy, workers=1, progress=False, params={"variants": ["PROP"]})
    assert (fewer.computed, fewer.reused) == (4, 0)
    rows = _by_session(copy / "results" / "metrics.csv")
    for (s, t), rs in rows.items():
        assert [r["variant"] for r in rs] == ["FP", "PROP"]
        assert rs == [r for r in before[(s, t)] if r["variant"] in ("FP", "PROP")]


def test_a_calibration_file_for_a_box_reruns_the_sessions_of_that_box(study, tmp_path) -> None:
    root, _, _ = study
    copy = _copy(root, tmp_path / "cal", results=True)
    box = _box(copy, "V02_right-leg")
    assert box.is_file() and box != _box(copy, "V01_right-leg")
    cal = Calibration.load(box)
    cal.r_mux = 0.0
    cal.short_stats = None
    cal.save(box)
    report = run_study(copy, workers=1, progress=False)
    assert (report.computed, report.reused) == (2, 2)
    stored = json.loads((copy / "results" / "sessions" / "V02_right-leg.json").read_text())
    assert stored["inputs"]["calibration"] == box.name
    before, after = _by_session(root / "results" / "metrics.csv"), _by_session(copy / "results" / "metrics.csv")
    assert after[("V01", "right-leg")] == before[("V01", "right-leg")]
    assert after[("V02", "right-leg")][1]["sd_ml_cm"] != before[("V02", "right-leg")][1]["sd_ml_cm"]
    # without the study's file the circuit stored in the session is used: the same box, the same numbers
    box.unlink()
    report = run_study(copy, workers=1, progress=False)
    assert (report.computed, report.reused) == (2, 2)
    assert _by_session(copy / "results" / "metrics.csv") == before


def test_processes_and_a_dask_cluster_give_the_same_bytes(study, tmp_path) -> None:
    distributed = pytest.importorskip("distributed")
    root, _, metrics = study
    two = _copy(root, tmp_path / "loky", results=False)
    report = run_study(two, workers=2, progress=False)
    assert (report.computed, report.reused) == (4, 0)
    assert (two / "results" / "metrics.csv").read_bytes() == metrics
    dask = _copy(root, tmp_path / "dask", results=False)
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None,
                                  scheduler_kwargs=LOOPBACK_HTTP) as c, \
            distributed.Client(c.scheduler_address) as client, distributed.get_task_stream(client) as stream:
        report = run_study(dask, scheduler=c.scheduler_address, progress=False)
        workers = set(client.scheduler_info()["workers"])
    assert (report.computed, report.reused) == (4, 0)
    assert (dask / "results" / "metrics.csv").read_bytes() == metrics
    # the figures too: drawn as tasks of the loky pool, and as tasks of the cluster's workers (the
    # scheduler's own record of what ran where), the same bytes
    figures = sorted(p.name for p in (two / "results" / "figures").glob("*.png"))
    assert figures and figures == sorted(p.name for p in (dask / "results" / "figures").glob("*.png"))
    for name in figures:
        assert (dask / "results" / "figures" / name).read_bytes() == (two / "results" / "figures" / name).read_bytes()
    ran = {str(t["key"]).rsplit("-", 1)[0]: t["worker"] for t in stream.data}
    assert {f"psmat-figure-{name[:-len('.png')]}" for name in figures} <= set(ran)
    # SCHC-DYN's per-session part too: one task per volunteer, on the cluster's workers
    dyn = [t for t in stream.data if str(t["key"]).startswith("psmat-dynamic-")]
    assert len(dyn) == len(SUBJECTS) and {t["worker"] for t in dyn} <= workers
    assert set(ran.values()) <= workers
    # a first run warms each worker first (psmat.study._warm): one task on each, begun before that
    # worker's first session (the task stream's stop of one task and start of the next on a worker
    # may overlap by a few ms: their bookkeeping)
    warm = [t for t in stream.data if str(t["key"]).startswith("psmat-warm-")]
    assert sorted(t["worker"] for t in warm) == sorted(workers)

    def computed(t):
        return [s for s in t["startstops"] if s["action"] == "compute"]

    for t in warm:
        sessions = [s["start"] for u in stream.data if u["worker"] == t["worker"]
                    and str(u["key"]).startswith("psmat-study-") for s in computed(u)]
        assert sessions and max(s["start"] for s in computed(t)) < min(sessions)
    for name in ("V01_right-leg", "V02_left-leg"):
        mine, ref = (json.loads((d / "results" / "sessions" / f"{name}.json").read_text()) for d in (dask, root))
        assert mine["key"] == ref["key"]  # the key is made of contents, not of where the folder lies
        a, b = (np.load(d / "results" / "sessions" / m["traces"]) for d, m in ((dask, mine), (root, ref)))
        assert sorted(a.files) == sorted(b.files) and all(np.array_equal(a[k], b[k]) for k in a.files)


def test_bad_input_is_reported_and_does_not_stop_the_run(study, tmp_path) -> None:
    root, _, _ = study
    copy = _copy(root, tmp_path / "bad", results=True)
    (copy / "forceplate" / "V01_left-leg.csv").unlink()
    (copy / "subjects.csv").write_text("subject,weight_kg\nV01,60\n")
    (copy / "sessions" / "V01_right-leg.h5").write_bytes(b"\x89HDF\r\n\x1a\n" + b"\0" * 100)
    report = run_study(copy, workers=1, progress=False)
    # every session's inputs changed (V01's weight too): computed, except the corrupt one
    assert (report.sessions, report.computed, report.reused, report.failed) == (4, 3, 0, 1)
    rows = _by_session(copy / "results" / "metrics.csv")
    assert list(rows) == [(s, t) for s in SUBJECTS for t in TRIALS]
    assert all(len(rs) == 1 + len(VARIANTS) for rs in rows.values())
    assert all(r["status"].startswith("error: SessionFormatError") for r in rows[("V01", "right-leg")])
    # a session with no readable metadata is not known to be simulated: the report is not labelled so
    assert (copy / "results" / "report.md").read_text().startswith("# Balance study results\n")
    no_plate = {r["variant"]: r["status"] for r in rows[("V01", "left-leg")]}
    assert no_plate["FP"] == "no force-platform file"
    assert no_plate["CHC"] == "no force-platform file: no Eu, no lag"
    for trial in TRIALS:
        status = {r["variant"]: r["status"] for r in rows[("V02", trial)]}
        assert status["PROP"] == "ok" and status["SCHC-8x8"] == "no body weight: subject missing from subjects.csv"
    problems = "\n".join(report.problems)
    assert "V01_right-leg: unreadable session" in problems
    assert "V01_left-leg: no force-platform file" in problems
    assert "V02_left-leg: subject 'V02' is not in subjects.csv" in problems
    # a failed session is not stored: the next run tries it again
    again = run_study(copy, workers=1, progress=False)
    assert (again.computed, again.reused, again.failed) == (0, 3, 1)


def test_bad_arguments_and_a_second_run_at_once_are_one_clear_error(study, tmp_path) -> None:
    root, _, _ = study
    with pytest.raises(FileNotFoundError, match="study folder not found"):
        run_study(tmp_path / "nowhere", progress=False)
    with pytest.raises(ValueError, match="unknown parameter.*windw_s"):
        run_study(root, params={"windw_s": 10.0}, progress=False)
    with pytest.raises(ValueError, match="unknown variant.*SCHC-4x4"):
        run_study(root, params={"variants": ["SCHC-4x4"]}, progress=False)
    with pytest.raises(ValueError, match="workers must be an integer >= 1"):
        run_study(root, workers=0, progress=False)
    with pytest.raises(ValueError, match="not both"):
        run_study(root, workers=2, scheduler="tcp://127.0.0.1:8786", progress=False)
    with study_lock(root / "results"), pytest.raises(RuntimeError, match="another psmat study run"):
        run_study(root, workers=1, progress=False)

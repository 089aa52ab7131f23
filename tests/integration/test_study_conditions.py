"""A study's trials cut into conditions by events, and Romberg quotients (docs/spec.md §7 "Events,
conditions, Romberg"; docs/spec.md §6 study layout ``events/``), on simulated studies
(``psmat.synth.simulate_study``) run by the real runner and the real chain.

Simulation only. The Romberg study: one volunteer, 56 s per condition with the mat at 10 Hz (the
platform at its own 100 Hz); 56 s keeps each condition's cut of its 60 s BDS source in one piece.
The study's processing reads ``truth/`` never; only these tests do, to name the BDS trials whose
published ``COPvelo`` (``trials.tsv``, Santos & Duarte 2016) is the independent expectation.
"""

from __future__ import annotations

import csv
import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from psmat.io import bds_trials_table, load_session
from psmat.study import run_study
from psmat.synth import simulate_study

VARIANTS = ["PROP", "PROP-8x8"]


def _rows(root: Path) -> list[dict[str, str]]:
    with open(root / "results" / "metrics.csv", newline="") as fh:
        return list(csv.DictReader(fh))


def _run(root: Path):
    return run_study(root, workers=1, params={"variants": VARIANTS}, progress=False)


@pytest.fixture(scope="module")
def romberg_study(tmp_path_factory) -> Path:
    root = simulate_study(tmp_path_factory.mktemp("rb") / "study", volunteers=1, duration_s=56, seed=11, rate_hz=10,
                          romberg=True)
    report = _run(root)
    assert report.failed == 0 and report.problems == []
    return root


def test_each_condition_has_rows_for_fp_and_every_variant(romberg_study) -> None:
    rows = [r for r in _rows(romberg_study) if r["trial"] == "romberg"]
    assert [(r["variant"], r["condition"]) for r in rows] == [
        (v, c) for c in ("", "eyes open", "eyes closed") for v in ("FP", *VARIANTS)]
    assert {r["status"] for r in rows} == {"ok"}
    whole = {r["variant"]: r for r in rows if r["condition"] == ""}
    for v in ("FP", *VARIANTS):
        eo, ec = (next(r for r in rows if r["variant"] == v and r["condition"] == c)
                  for c in ("eyes open", "eyes closed"))
        # the two conditions split the aligned window; the switch is 56 s (560 frames at 10 Hz) in
        assert float(eo["duration_s"]) + float(ec["duration_s"]) == pytest.approx(float(whole[v]["duration_s"]))
        assert float(eo["duration_s"]) == pytest.approx(56.0, abs=1.0)
        assert eo["ispgr"] == ("ok" if v == "FP" else "rate 10 Hz < 50 Hz")
    # the other trials have no markers: whole-trial rows only
    assert {r["condition"] for r in _rows(romberg_study) if r["trial"] != "romberg"} == {""}


def test_romberg_csv_is_the_quotient_of_the_condition_rows_and_the_published_one(romberg_study) -> None:
    rows = _rows(romberg_study)
    with open(romberg_study / "results" / "romberg.csv", newline="") as fh:
        quotients = {r["variant"]: r for r in csv.DictReader(fh)}
    assert sorted(quotients) == sorted(["FP", *VARIANTS])
    fp = {r["condition"]: r for r in rows if r["trial"] == "romberg" and r["variant"] == "FP"}
    q = quotients["FP"]
    assert (q["subject"], q["trial"], q["eyes_open"], q["eyes_closed"]) == ("V01", "romberg", "eyes open",
                                                                           "eyes closed")
    for m in ("velocity_cm_s", "path_cm", "area95_cm2", "sd_ml_cm", "sd_ap_cm", "range_ml_cm", "range_ap_cm"):
        assert float(q[f"romberg_{m}"]) == pytest.approx(float(fp["eyes closed"][m]) / float(fp["eyes open"][m]),
                                                         rel=1e-12), m
    # independent: the BDS authors' published COPvelo of the two source trials (the test reads truth/ to name
    # them). Tolerance 13 %: over every 55-60 s window of the firm-surface BDS trials shipped with psmat the
    # mean velocity stays within 6.1 % of the whole trial's, so a quotient of two within 1.061/0.939 ≈ 1.13;
    # the one preprocessing (10 Hz low-pass) applies to both conditions alike.
    info = json.loads((romberg_study / "truth" / "sessions" / "V01_romberg.json").read_text())["romberg"]
    table = {r["Trial"]: r for r in bds_trials_table()}
    published = table[info["eyes_closed"]]["COPvelo"] / table[info["eyes_open"]]["COPvelo"]
    assert float(q["romberg_velocity_cm_s"]) == pytest.approx(published, rel=0.13)


def test_the_report_has_a_romberg_section_labelled_simulation(romberg_study) -> None:
    text = (romberg_study / "results" / "report.md").read_text(encoding="utf-8")
    section = text[text.index("## Romberg"):]
    section = section[:section.index("\n## ", 1)]
    assert "simulation" in section
    assert "| romberg | FP | 1 |" in section and "| romberg | PROP | 1 |" in section
    # the summary and its figures use the whole-trial rows only: one row per trial × variant
    with open(romberg_study / "results" / "summary.csv", newline="") as fh:
        summary = list(csv.DictReader(fh))
    assert len(summary) == 4 * (1 + len(VARIANTS)) and all(r["n"] == "1" for r in summary)


@pytest.fixture(scope="module")
def plain_study(tmp_path_factory) -> Path:
    root = simulate_study(tmp_path_factory.mktemp("ev") / "study", volunteers=1, duration_s=30, seed=5, rate_hz=10)
    first = _run(root)
    assert first.computed == 3 and first.problems == []
    return root


def _write_events(root: Path, text: str) -> Path:
    (root / "events").mkdir(exist_ok=True)
    path = root / "events" / "V01_right-leg.csv"
    path.write_text(text, encoding="utf-8")
    return path


def test_an_events_file_overrides_the_markers_and_reruns_only_its_session(plain_study, tmp_path) -> None:
    root = tmp_path / "study"
    shutil.copytree(plain_study, root)
    s = load_session(root / "sessions" / "V01_right-leg.h5")
    assert s.events == []  # the session has no markers of its own
    host = [float(x) for x in s.host_time_s]
    mid = host[len(host) // 2]
    # an experimenter's log on the host clock: two halves, and a blink too short for the mat's metrics (0.3 s)
    _write_events(root, f"time_s;label\n{host[0]!r};first half\n{mid - 0.3!r};blink\n{mid!r};second half\n")
    report = _run(root)
    assert (report.computed, report.reused, report.failed) == (1, 2, 0) and report.problems == []
    rows = [r for r in _rows(root) if r["trial"] == "right-leg"]
    assert [(r["variant"], r["condition"]) for r in rows] == [
        (v, c) for c in ("", "first half", "blink", "second half") for v in ("FP", *VARIANTS)]
    by = {(r["variant"], r["condition"]): r for r in rows}
    for v in ("FP", *VARIANTS):
        assert by[v, ""]["status"] == by[v, "first half"]["status"] == by[v, "second half"]["status"] == "ok"
        parts = sum(float(by[v, c]["duration_s"]) for c in ("first half", "blink", "second half"))
        assert parts == pytest.approx(float(by[v, ""]["duration_s"]))
        assert float(by[v, "blink"]["duration_s"]) == pytest.approx(0.3, abs=0.02)
    for v in VARIANTS:  # 0.3 s at 10 Hz: 2 or 3 mat frames; a status, no numbers, the session not failed
        assert by[v, "blink"]["status"] in ("condition too short: 2 samples < 8",
                                            "condition too short: 3 samples < 8"), by[v, "blink"]["status"]
        assert by[v, "blink"]["velocity_cm_s"] == ""
    assert by["FP", "blink"]["status"] == "ok" or by["FP", "blink"]["status"].startswith("condition too short")
    # each half's path is its share of the whole one's, give or take the blink and the cut (same trace, same filter)
    for v in ("FP", *VARIANTS):
        halves = float(by[v, "first half"]["path_cm"]) + float(by[v, "second half"]["path_cm"])
        assert halves == pytest.approx(float(by[v, ""]["path_cm"]), rel=0.05)
    # no Romberg pair: no romberg.csv
    assert not (root / "results" / "romberg.csv").exists()
    # unchanged: all reused; the events file edited: that session alone reruns
    assert _run(root).reused == 3
    _write_events(root, f"time,label\n{host[0]!r},first half\n{mid!r},second half\n")
    again = _run(root)
    assert (again.computed, again.reused) == (1, 2)
    assert [r["condition"] for r in _rows(root) if r["trial"] == "right-leg" and r["variant"] == "FP"] == [
        "", "first half", "second half"]


def test_a_bad_events_file_is_one_problem_and_the_whole_trial_rows_stay(plain_study, tmp_path) -> None:
    root = tmp_path / "study"
    shutil.copytree(plain_study, root)
    path = _write_events(root, "time_s,label\n1.0,start\nsoon,eyes closed\n")
    report = _run(root)
    assert report.failed == 0 and report.computed == 1
    assert report.problems == [f"V01_right-leg: events file not used, no conditions: {path}: line 3: time 'soon' "
                               "is not a number of seconds, nor a clock time (10:32:15, 2024-03-01T10:32:15+01:00)"]
    rows = [r for r in _rows(root) if r["trial"] == "right-leg"]
    assert [(r["variant"], r["condition"], r["status"]) for r in rows] == [(v, "", "ok") for v in ("FP", *VARIANTS)]
    assert np.isfinite([float(r["velocity_cm_s"]) for r in rows]).all()


def test_markers_on_another_clock_are_one_problem_not_a_silent_trial(plain_study, tmp_path) -> None:
    """An experimenter's log in seconds from the start (0-30 s) where the session's host clock counts
    from 1970: not one marker falls within the recording, so no condition can be cut. Before, the run
    said nothing and the trial simply had none; now it is one problem line naming the two clocks."""
    root = tmp_path / "study"
    shutil.copytree(plain_study, root)
    s = load_session(root / "sessions" / "V01_right-leg.h5")
    path = _write_events(root, "time_s,label\n0.5,eyes open\n15.0,eyes closed\n")
    report = _run(root)
    assert report.failed == 0 and report.computed == 1
    assert len(report.problems) == 1
    line = report.problems[0]
    assert line.startswith(f"V01_right-leg: events file not used, no conditions: none of the 2 markers of {path} "
                           "(0.5-15 s) falls within 1 h of the recording (")
    assert f"{s.host_time_s[0]:.6f}-{s.host_time_s[-1]:.6f} s on the session's host clock" in line
    rows = [r for r in _rows(root) if r["trial"] == "right-leg"]
    assert [(r["variant"], r["condition"], r["status"]) for r in rows] == [(v, "", "ok") for v in ("FP", *VARIANTS)]
    # the same markers on the host clock: no problem, the conditions cut
    t0 = float(s.host_time_s[0])
    _write_events(root, f"time_s,label\n{t0 + 0.5!r},eyes open\n{t0 + 15.0!r},eyes closed\n")
    again = _run(root)
    assert again.problems == [] and {r["condition"] for r in _rows(root) if r["trial"] == "right-leg"} == {
        "", "unmarked", "eyes open", "eyes closed"}  # unmarked: the first 0.5 s, before the first marker


def test_a_log_written_by_the_clock_on_the_wall_cuts_the_same_conditions(plain_study, tmp_path, monkeypatch) -> None:
    """An experimenter's log with the time of day (``10:32:15.250``), as a person reads it off the wall or
    a watch: before, "is not a number of seconds", and host times since 1970 are no one's to write by
    hand. The session is recorded on a computer three hours east of UTC (it stores its offset), the log
    written on its local clock, once as times of day and once as dates and times without an offset:
    the same conditions as the log on the host clock. Expected times by hand: local = host + 3 h."""
    import datetime as dt
    import time

    from psmat.io import SessionWriter

    root = tmp_path / "study"
    shutil.copytree(plain_study, root)
    path = root / "sessions" / "V01_right-leg.h5"
    s = load_session(path)
    monkeypatch.setenv("TZ", "XYZ-3")  # POSIX: three hours east of UTC
    time.tzset()
    try:
        with SessionWriter(path, s.frame_shape, device=s.device, calibration=s.calibration, metadata=s.metadata,
                           profile=s.profile, overwrite=True) as w:
            w.append(s.counts, s.host_time_s, s.valid, seq=s.seq, device_time_us=s.device_time_us)
    finally:
        monkeypatch.delenv("TZ")
        time.tzset()
    assert load_session(path).utc_offset_s == 3 * 3600
    t0 = float(s.host_time_s[0])
    marks = [(round(t0, 3) + 0.5, "eyes open"), (round(t0, 3) + 15.25, "eyes closed")]

    def local(t: float, date: bool) -> str:
        d = dt.datetime.fromtimestamp(t, dt.timezone.utc) + dt.timedelta(hours=3)
        return d.strftime("%Y-%m-%d %H:%M:%S.%f" if date else "%H:%M:%S.%f")

    runs = {}
    for how in ("host", "day", "date"):
        _write_events(root, "time,label\n" + "".join(
            (f"{t!r}" if how == "host" else local(t, how == "date")) + f",{label}\n" for t, label in marks))
        report = _run(root)
        assert report.problems == [], how
        runs[how] = [(r["variant"], r["condition"], r["duration_s"], r["path_cm"]) for r in _rows(root)
                     if r["trial"] == "right-leg"]
    assert {c for _, c, _, _ in runs["host"]} == {"", "unmarked", "eyes open", "eyes closed"}
    assert runs["day"] == runs["host"] and runs["date"] == runs["host"]

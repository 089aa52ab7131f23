"""A study's rows with the one preprocessing, the 72 descriptors and the ISPGR check (docs/spec.md §9),
on simulated studies (``psmat.synth.simulate_study``: BDS platform trajectories through a mat the
processing does not know) run by the real command line and the real chain."""

from __future__ import annotations

import csv
import re
import shutil

import numpy as np
import pytest
from scipy import signal

from psmat.balance import descriptors
from psmat.balance._preprocess import swarii  # the resampler (its own unit tests); the filter is scipy's here
from psmat.cli import main
from psmat.io import load_forceplate_csv
from psmat.study import COLUMNS, run_study
from psmat.synth import simulate_study

VARIANTS = "PROP,PROP-8x8,CHC"


def _rows(root) -> tuple[list[str], list[dict[str, str]]]:
    with open(root / "results" / "metrics.csv", newline="") as fh:
        r = csv.DictReader(fh)
        return list(r.fieldnames or []), list(r)


def _num(v: str) -> float:
    return float(v) if v != "" else np.nan


@pytest.fixture(scope="module")
def study(tmp_path_factory):
    """One volunteer, 30 s trials at 50 Hz, run with --descriptors (preprocessing by default)."""
    root = simulate_study(tmp_path_factory.mktemp("d") / "study", volunteers=1, duration_s=30, seed=3, rate_hz=50)
    assert main(["study", "run", str(root), "--workers", "1", "--quiet", "--variants", VARIANTS,
                 "--descriptors", "quijoux2021"]) == 0
    return root


def test_the_72_descriptors_are_columns_of_every_row(study) -> None:
    header, rows = _rows(study)
    # the descriptors' own names, from a trace made here (a 60 s random walk at 25 Hz)
    t = np.arange(0.0, 60.0, 0.04)
    walk = np.cumsum(np.random.default_rng(1).standard_normal((t.size, 2)), axis=0) * 0.05
    names = list(descriptors(t, walk[:, 0], walk[:, 1]))
    assert len(names) == 72
    assert header == list(COLUMNS) + names
    ok = [r for r in rows if r["status"] == "ok"]
    assert {r["variant"] for r in ok} == {"FP", "PROP", "PROP-8x8", "CHC"} and len(ok) == 12  # three trials
    values = np.array([[_num(r[n]) for n in names] for r in ok])
    assert not np.any(np.isinf(values))
    # defined on a 30 s standing trace: every descriptor is a number in most rows
    assert np.all(np.isfinite(values).mean(axis=0) >= 0.5), [n for n, f in zip(names, np.isfinite(values).mean(0))
                                                             if f < 0.5]


def _fp_window(study, trial: str, duration_s: float):
    """The platform samples of the analysed window [lo, hi]: the overlap of the platform's samples and
    the mat's aligned frames (traces file), so each end is the platform's or the mat's (docs/spec.md §9)."""
    z = np.load(next((study / "results" / "sessions").glob(f"*_{trial}.*.npz")))
    tm = z["t_s"]
    fp = load_forceplate_csv(next((study / "forceplate").glob(f"*_{trial}*.csv")))
    ends = [(lo, hi) for lo in (tm[0], fp.t[0]) for hi in (tm[-1], fp.t[-1]) if abs(hi - lo - duration_s) < 1e-9]
    assert ends, "the row's duration_s is not the overlap of platform and mat"
    lo, hi = ends[0]
    keep = (fp.t >= lo) & (fp.t <= hi)
    return fp.t[keep], fp.cop_cm[keep]


def test_fp_sway_is_that_of_the_preprocessed_platform_trace(study) -> None:
    _, rows = _rows(study)
    fp_rows = [r for r in rows if r["variant"] == "FP" and r["status"] == "ok"]
    assert fp_rows
    for r in fp_rows:
        t, c = _fp_window(study, r["trial"], float(r["duration_s"]))
        # SWARII to 25 Hz, 4th-order 10 Hz Butterworth forward-backward (Quijoux et al. 2021)
        _, x = swarii(t, c, 25.0, 1.0 / 25.0)
        b, a = signal.butter(4, 10.0, fs=25.0)
        x = signal.filtfilt(b, a, x, axis=0)
        path = float(np.sum(np.hypot(*np.diff(x, axis=0).T)))  # cm, by hand
        assert float(r["path_cm"]) == pytest.approx(path, rel=1e-9)
        assert float(r["velocity_cm_s"]) == pytest.approx(path / (len(x) / 25.0), rel=1e-9)  # cm/s, N/fs seconds
        # descriptors: of the same window, the paper's preset
        d = descriptors(t, c[:, 0], c[:, 1])
        assert float(r["mean_value_ML"]) == pytest.approx(d["mean_value_ML"], rel=1e-9)
        # ISPGR: a 100 Hz platform, a window near 30 s
        assert float(r["rate_hz"]) >= 50.0
        assert r["ispgr"] == ("ok" if float(r["duration_s"]) >= 25.0 else f"short: {float(r['duration_s']):.1f} s < 25 s")


def test_platform_samples_without_a_cop_are_left_out_not_the_session(study, tmp_path) -> None:
    """A platform's software writes NaN where Fz fell below its threshold (a dropout, the subject
    stepping off at the end): those samples are left out and the rest keep their times, so the
    platform's metrics are those of its other samples, by hand as above. Before, the whole session
    was an error ("cop_ref has 10 non-finite value(s)") in every variant."""
    from psmat.study import process_trial

    session = next((study / "sessions").glob("*_rotation.h5"))
    clean = next((study / "forceplate").glob("*_rotation.csv"))
    lines = clean.read_text().splitlines()
    gone = set(range(400, 405)) | set(range(len(lines) - 41, len(lines) - 1))  # data rows (0 = first after header)
    holed = tmp_path / clean.name
    holed.write_text("\n".join([lines[0]] + [",".join([ln.split(",")[0], "NaN", "NaN", *ln.split(",")[3:]])
                                            if k in gone else ln for k, ln in enumerate(lines[1:])]) + "\n")
    subject, trial = session.stem.split("_", 1)
    params = {"variants": VARIANTS.split(",")}
    rows, traces = process_trial(session, holed, subject, trial, 70.0, params, traces=True)
    assert [r["status"] for r in rows if r["condition"] == ""] == ["ok"] * 4
    fp_row = rows[0]
    fp = load_forceplate_csv(clean)
    keep = np.ones(fp.t.size, bool)
    keep[sorted(gone)] = False
    t, c = fp.t[keep], fp.cop_cm[keep]
    tm = traces["t_s"]  # the mat's aligned frames: the window is their overlap with the platform's samples
    ends = [(lo, hi) for lo in (tm[0], t[0]) for hi in (tm[-1], t[-1]) if abs(hi - lo - fp_row["duration_s"]) < 1e-9]
    w = (t >= ends[0][0]) & (t <= ends[0][1])
    _, x = swarii(t[w], c[w], 25.0, 1.0 / 25.0)
    b, a = signal.butter(4, 10.0, fs=25.0)
    x = signal.filtfilt(b, a, x, axis=0)
    assert fp_row["path_cm"] == pytest.approx(float(np.sum(np.hypot(*np.diff(x, axis=0).T))), rel=1e-9)


def test_preprocessing_brings_the_mat_path_closer_to_the_platform(study, tmp_path) -> None:
    """The point of the low-pass (measured on this simulation): the mat's frame-to-frame noise, the
    8×8 mat's most, inflates its raw path; after the same preprocessing the mat's paths are closer
    to the platform's as a whole (not in every trial for the full mat: measured 1 of 3 closer, 1 even, 1 farther)."""
    raw = tmp_path / "raw"
    shutil.copytree(study, raw, ignore=shutil.ignore_patterns("results"))
    assert main(["study", "run", str(raw), "--workers", "1", "--quiet", "--variants", VARIANTS,
                 "--preprocess", "none"]) == 0
    header, raw_rows = _rows(raw)
    assert header == list(COLUMNS)  # no descriptors asked for: no descriptor columns
    _, pre_rows = _rows(study)

    def err(rows, variants):
        by = {(r["trial"], r["variant"]): r for r in rows if r["status"] == "ok"}
        return np.array([abs(float(by[k]["path_cm"]) - float(by[(k[0], "FP")]["path_cm"]))
                         for k in sorted(by) if k[1] in variants])

    mat = ("PROP", "PROP-8x8", "CHC")
    assert err(pre_rows, mat).sum() < 0.5 * err(raw_rows, mat).sum(), (err(pre_rows, mat), err(raw_rows, mat))
    assert np.all(err(pre_rows, ("PROP-8x8",)) < err(raw_rows, ("PROP-8x8",)))
    # Eu stays on the unfiltered aligned traces: the same with or without preprocessing
    for a, b in zip(pre_rows, raw_rows):
        assert (a["variant"], a["trial"]) == (b["variant"], b["trial"])
        assert a["eu_cm"] == b["eu_cm"]


def test_a_short_slow_study_misses_ispgr_and_changed_params_rerun(tmp_path) -> None:
    root = simulate_study(tmp_path / "short", volunteers=1, duration_s=20, seed=4, rate_hz=40)
    params = {"variants": ["PROP"], "preprocess": None}
    first = run_study(root, workers=1, params=params, progress=False)
    assert first.computed == 3
    _, rows = _rows(root)
    for r in rows:
        assert r["status"] == "ok", r["status"]
        d, f = float(r["duration_s"]), float(r["rate_hz"])
        assert d < 20.0 + 1e-6
        why = [f"short: {d:.1f} s < 25 s"] + ([f"rate {f:.4g} Hz < 50 Hz"] if f < 50.0 else [])
        assert r["ispgr"] == "; ".join(why)
        if r["variant"] == "PROP":  # the mat's frame rate, near the 40 Hz it was simulated at
            assert f == pytest.approx(40.0, rel=0.01) and re.search(r"rate 40(\.\d+)? Hz < 50 Hz", r["ispgr"])
    # the same params reuse every session; a changed one reruns them all
    assert run_study(root, workers=1, params=params, progress=False).reused == 3
    again = run_study(root, workers=1, params={**params, "preprocess": "quijoux2021"}, progress=False)
    assert again.computed == 3 and again.reused == 0
    report = (root / "results" / "report.md").read_text()
    assert "SWARII resampling to 25 Hz" in report and "10 Hz" in report


def test_bad_preset_is_one_line(tmp_path) -> None:
    with pytest.raises(ValueError, match="preprocess must be one of"):
        run_study(tmp_path, params={"preprocess": "butter"}, progress=False)

"""psmat.synth.simulate_posture_study (docs/spec.md §8): a simulated posture study in the docs/spec.md §6 layout.

A tiny study (2 subjects, 1 day, 20 s) is written once: its sessions load with
psmat.io.load_session, the mat at ~100 Hz and the IMUs at ~10 Hz on one host clock, the
metadata and device descriptions of contract B, subjects.csv, the calibration, truth/ — and the
same seed writes the same arrays, another seed others.
"""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path

import numpy as np
import pytest

from psmat import Calibration
from psmat.io import load_session
from psmat.synth import simulate_posture_study
from psmat.twin.seated import EULER_LSB_DEG

SECONDS = 20.0


def _write(root: Path, seed: int) -> Path:
    return simulate_posture_study(root, subjects=2, days=1, seed=seed, duration_s=SECONDS)


@pytest.fixture(scope="module")
def study(tmp_path_factory) -> Path:
    return _write(tmp_path_factory.mktemp("posture") / "study", 5)


@pytest.fixture(scope="module")
def again(tmp_path_factory) -> Path:
    return _write(tmp_path_factory.mktemp("posture") / "again", 5)


def test_the_layout_and_subjects(study):
    assert sorted(p.name for p in (study / "sessions").iterdir()) == ["P01_d1.h5", "P02_d1.h5"]
    with open(study / "subjects.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert [r["subject"] for r in rows] == ["P01", "P02"]
    assert list(rows[0]) == ["subject", "weight_kg", "height_cm", "age", "sex"]
    for r in rows:
        assert 42.0 <= float(r["weight_kg"]) <= 100.0 and 150.0 <= float(r["height_cm"]) <= 195.0
        assert 18 <= int(r["age"]) <= 70 and r["sex"] in ("M", "F")
    assert [r["sex"] for r in rows].count("M") == 1  # round(5 · 2 / 12) men (Table 4.2's 5:7)
    for name in ("study.json", "README.txt", "subjects/P01.json", "subjects/P01.npz", "subjects/P02.npz",
                 "sessions/P01_d1.json", "sessions/P01_d1.npz", "sessions/P02_d1.npz"):
        assert (study / "truth" / name).is_file(), name


def test_sessions_hold_the_mat_and_the_imus_on_one_host_clock(study):
    for stem, pid in (("P01_d1", "P01"), ("P02_d1", "P02")):
        s = load_session(study / "sessions" / f"{stem}.h5")
        assert s.metadata == {"subject": pid, "trial": "posture", "day": 1, "simulated": True, "study": "posture",
                              "operator": "psmat.synth.simulate_posture_study"}
        assert s.counts.shape[1:] == (16, 16) and s.counts.dtype == np.uint16
        for key, value in (("device", "psm"), ("r_o", 2200), ("v_ref", 3.3), ("bits", 12), ("serial", f"SIM5-{pid}")):
            assert s.device[key] == value
        # the calibration stored in the session is the box's file
        cal = Calibration.load(study / "calibration" / f"SIM5-{pid}.json")
        assert s.calibration == cal.to_dict()
        imu = s.streams["imu"]
        assert imu.counts.shape[1:] == (5, 3) and imu.counts.dtype == np.float32
        assert imu.device["device"] == "imu" and imu.device["serial"] == "SIM5-IMU"
        assert imu.valid.all() and np.array_equal(imu.seq, np.arange(imu.seq.size))
        # each device's own clock ticks at its nominal rate: 10 000 µs and 100 000 µs
        ok = s.valid
        assert np.all(np.diff(s.device_time_us[ok]) % 10_000 == 0)
        assert np.all(np.diff(imu.device_time_us) == 100_000)
        # on the host clock: ~100 Hz and ~10 Hz over the same ~20 s
        for times, period in ((s.host_time_s, 0.01), (imu.host_time_s, 0.1)):
            assert np.median(np.diff(times)) == pytest.approx(period, rel=0.01)
            assert times[-1] - times[0] == pytest.approx(SECONDS, abs=1.1)
        assert abs(imu.host_time_s[0] - s.host_time_s[0]) < 0.6
        assert 0.95 * SECONDS * 100 < s.counts.shape[0] <= SECONDS * 100 + 1
        assert 0.95 * SECONDS * 10 < imu.counts.shape[0] <= SECONDS * 10 + 1
        # somebody sits on it: cells well below the open-circuit reading under the tuberosities
        assert np.median(s.counts[ok].min(axis=(1, 2))) < 3000


def test_the_imu_angles_are_the_truth_plus_drift_and_noise(study):
    truth = json.loads((study / "truth" / "study.json").read_text())
    noise = np.asarray(truth["imu_device"]["noise_deg"])
    for stem in ("P01_d1", "P02_d1"):
        imu = load_session(study / "sessions" / f"{stem}.h5").streams["imu"]
        z = np.load(study / "truth" / "sessions" / f"{stem}.npz")
        # the host times in truth are the file's; the file's angles are on the BNO055's 1/16° grid
        np.testing.assert_array_equal(z["imu_t_host_s"], imu.host_time_s)
        a = imu.counts.astype(np.float64)
        np.testing.assert_array_equal(a / EULER_LSB_DEG, np.round(a / EULER_LSB_DEG))
        # pitch: sent = true + drift + white noise of the sensor's SD, quantised
        r = a[:, :, 2] - z["angles_true_deg"][:, :, 2] - z["drift_deg"][:, :, 2]
        assert np.all(np.abs(r.mean(axis=0)) < 4.0 * noise / math.sqrt(r.shape[0]) + 0.02)
        np.testing.assert_allclose(r.std(axis=0), np.hypot(noise, EULER_LSB_DEG / math.sqrt(12)), rtol=0.25)
        # the back's pitch at the sensors is the true reading less the mounting offsets
        info = json.loads((study / "truth" / "sessions" / f"{stem}.json").read_text())
        mount = np.asarray(info["seated_day"]["mount_deg"])
        np.testing.assert_allclose(z["angles_true_deg"][:, :, 2] - mount[:, 2], z["back_pitch_deg"], atol=1e-9)


def test_truth_describes_the_session(study):
    info = json.loads((study / "truth" / "sessions" / "P01_d1.json").read_text())
    phases = info["phases"]
    assert [p["name"] for p in phases][:3] == ["settle", "bounce", "straight"]
    assert phases[-1]["end_s"] == pytest.approx(SECONDS, rel=1e-9)  # the protocol scaled to the session
    assert all(0.0 <= v <= 1.0 for v in info["sensor_sites_v"])
    np.testing.assert_allclose(np.diff(info["sensor_cm_below_c7"]), 9.0, atol=1e-9)  # 90 mm apart (docs/spec.md §8)
    z = np.load(study / "truth" / "sessions" / "P01_d1.npz")
    person = json.loads((study / "truth" / "subjects" / "P01.json").read_text())["person"]
    # the seat's force is the subject's weight times its share on the cushion times (1 + bounce)
    t = z["mat_t_s"]
    bounce = np.interp(t, z["imu_t_s"], z["bounce"])
    quiet = np.abs(bounce) < 1e-12
    np.testing.assert_allclose(z["force_n"][quiet], person["weight_kg"] * 9.80665 * z["seat_share"][quiet], rtol=1e-12)
    assert z["cop_cm"].shape == (t.size, 2) and z["rows"].shape == (t.size, 3)
    np.testing.assert_allclose(z["rows"].sum(axis=1), 1.0, atol=1e-12)


def test_same_seed_same_study_and_another_seed_another(study, again, tmp_path):
    for stem in ("P01_d1", "P02_d1"):
        a, b = (load_session(root / "sessions" / f"{stem}.h5") for root in (study, again))
        for sa, sb in ((a, b), (a.streams["imu"], b.streams["imu"])):
            for field in ("counts", "host_time_s", "valid", "seq", "device_time_us"):
                np.testing.assert_array_equal(getattr(sa, field), getattr(sb, field))
    for name in ("subjects.csv", "calibration/SIM5-P01.json", "truth/study.json", "truth/sessions/P02_d1.npz",
                 "truth/sessions/P02_d1.json", "truth/subjects/P01.npz"):
        assert (study / name).read_bytes() == (again / name).read_bytes(), name
    other = simulate_posture_study(tmp_path / "other", subjects=1, days=1, seed=6, duration_s=SECONDS)
    a, c = (load_session(root / "sessions" / "P01_d1.h5") for root in (study, other))
    n = min(a.counts.shape[0], c.counts.shape[0])
    assert not np.array_equal(a.counts[:n], c.counts[:n])
    assert not np.array_equal(a.streams["imu"].counts[:50], c.streams["imu"].counts[:50])


@pytest.mark.parametrize("kwargs, exc, words", [
    (dict(subjects=0), ValueError, "subjects"),
    (dict(days=1.5), ValueError, "days"),
    (dict(seed=-1), ValueError, "seed"),
    (dict(duration_s=2.0), ValueError, "at least 5 s"),
    (dict(rate_hz=0.0), ValueError, "rate_hz"),
    (dict(shape=(8, 8)), ValueError, "at least (16, 16)"),
])
def test_bad_arguments_are_one_line_errors(tmp_path, kwargs, exc, words):
    args = dict(subjects=1, days=1, seed=0, duration_s=10.0)
    args.update(kwargs)
    with pytest.raises(exc) as info:
        simulate_posture_study(tmp_path / "s", **args)
    assert words in str(info.value) and "\n" not in str(info.value)
    assert not (tmp_path / "s").exists()


def test_a_study_is_never_overwritten(study):
    with pytest.raises(FileExistsError, match="not an empty folder"):
        simulate_posture_study(study, subjects=1, days=1, seed=0, duration_s=10.0)

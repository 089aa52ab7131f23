"""The honest simulation of a balance study (docs/spec.md §7, §6 layout): ``psmat.synth.simulate_study``.

A two-volunteer, 10 s study at 50 Hz (the platform at its own 100 Hz): the layout is complete
for ``find_study``; the truth differs from what the processing assumes (sensor model, R_mux,
clock); the platform file has its own rate, start and origin; the seed fixes every array; the
lag in truth/ is what the clocks say and what the mat's CoP gives; a single-leg trial loads
one foot.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from psmat.balance import align
from psmat.circuit import Calibration
from psmat.io import load_forceplate_csv, load_session
from psmat.process import process_counts, session_circuit
from psmat.sensor import THESIS_TABLE_2_11
from psmat.study import find_study
from psmat.synth import simulate_study

RATE = 50.0
SEED = 3
TRIALS = ("right-leg", "left-leg", "rotation")


@pytest.fixture(scope="module")
def study(tmp_path_factory) -> Path:
    return simulate_study(tmp_path_factory.mktemp("a") / "study", volunteers=2, duration_s=10, seed=SEED, rate_hz=RATE)


@pytest.fixture(scope="module")
def same_seed_one_volunteer(tmp_path_factory) -> Path:
    return simulate_study(tmp_path_factory.mktemp("b") / "study", volunteers=1, duration_s=10, seed=SEED, rate_hz=RATE,
                          progress=True)


def _truth(root: Path, stem: str) -> tuple[dict, dict]:
    with np.load(root / "truth" / "sessions" / f"{stem}.npz") as z:
        arrays = dict(z)
    return json.loads((root / "truth" / "sessions" / f"{stem}.json").read_text()), arrays


def _volunteer(root: Path, vid: str) -> tuple[dict, dict]:
    with np.load(root / "truth" / "volunteers" / f"{vid}.npz") as z:
        arrays = dict(z)
    return json.loads((root / "truth" / "volunteers" / f"{vid}.json").read_text()), arrays


def _device_clock(session) -> np.ndarray:
    """The session's device times (s); a frame lost on the wire (-1) on the grid of its neighbours."""
    t = session.device_time_us.astype(np.float64) * 1e-6
    k = np.arange(t.size)
    good = session.device_time_us >= 0
    return np.interp(k, k[good], t[good])


def test_the_layout_is_complete_and_every_session_ready(study) -> None:
    layout = find_study(study)
    assert layout.problems == []
    assert sorted(layout.subjects) == ["V01", "V02"]
    assert [(i.subject, i.trial) for i in layout.items] == sorted((v, t) for v in ("V01", "V02") for t in TRIALS)
    assert all(i.ok for i in layout.items) and len(layout.items) == 6
    assert sorted(layout.calibrations) == [f"SIM{SEED}-V01", f"SIM{SEED}-V02"]
    for item in layout.items:
        s = load_session(item.session)
        cal = Calibration.load(layout.calibrations[s.device["serial"]])
        # each session carries its box's calibration, as `psmat record --calibration` stores it
        assert Calibration.from_dict(s.calibration) == cal
        assert (s.device["rows"], s.device["cols"], s.frame_shape) == (16, 16, (16, 16))
        assert s.n_frames == 10 * RATE
        assert item.forceplate == study / "forceplate" / f"{item.stem}.csv"
    readme = (study / "truth" / "README.txt").read_text()
    assert "Nothing but the evaluation of the simulation itself may read it" in readme
    header = (study / "subjects.csv").read_text().splitlines()[0]
    assert header == "subject,weight_kg,height_cm,age,sex"


def test_the_truth_is_not_what_the_processing_assumes(study) -> None:
    for vid in ("V01", "V02"):
        truth, arrays = _volunteer(study, vid)
        sensor = truth["mat"]["sensor"]
        k = truth["mat"]["conductance_scale"]
        assert 1 / 0.75 <= k <= 1 / 0.25  # thesis §3.2.2: f in [0.25, 0.75]
        # every conductance term is the pneumatic fit's times about 1/f (10 % spread), the rest spread too
        for name in ("rho", "a1", "a2", "a3"):
            assert 0.6 < sensor[name] / (THESIS_TABLE_2_11[name] * k) < 1.6
        assert sensor["tau"] != THESIS_TABLE_2_11["tau"] and sensor["l"] != list(THESIS_TABLE_2_11["l"])
        gain_sd = np.std(np.log(arrays["gain"]))
        assert 0.1 < gain_sd < 0.45 and gain_sd == pytest.approx(truth["mat"]["variability"], rel=0.25)
        # R_mux: not the nominal 145 Ω; the lab's calibration (median of the four shorted corners) finds it
        r_mux = arrays["r_mux_ohm"]
        assert abs(np.median(r_mux) - 145.0) > 5.0
        corners = np.median(r_mux[[0, 0, -1, -1], [0, -1, 0, -1]])
        cal = Calibration.load(study / "calibration" / f"SIM{SEED}-{vid}.json")
        assert cal.r_mux == pytest.approx(corners, abs=0.05)
        # the box's clock: frames stamped every nominal period, but they really come (1 + e) apart
        e = truth["box"]["clock_error"]
        assert 2e-6 <= abs(e) <= 1e-3
        for trial in TRIALS:
            s = load_session(study / "sessions" / f"{vid}_{trial}.h5")
            info, t = _truth(study, f"{vid}_{trial}")
            dev = s.device_time_us[s.device_time_us >= 0]
            assert np.all(np.diff(dev) % int(1e6 / RATE) == 0)
            np.testing.assert_allclose(np.diff(t["t_platform_s"]), (1 + e) / RATE, rtol=1e-9)
            assert info["lag_drift"] == e


def test_the_platform_has_its_own_rate_start_and_origin(study) -> None:
    for vid in ("V01", "V02"):
        vtruth, _ = _volunteer(study, vid)
        weight_n = float(find_study(study).subjects[vid].weight_n)
        for trial in TRIALS:
            stem = f"{vid}_{trial}"
            fp = load_forceplate_csv(study / "forceplate" / f"{stem}.csv")
            s = load_session(study / "sessions" / f"{stem}.h5")
            info, t = _truth(study, stem)
            np.testing.assert_allclose(np.diff(fp.t), 0.01, atol=1e-9)  # 100 Hz from its own 0
            assert fp.t[0] == 0.0 and s.device_time_us[0] * 1e-6 > 10.0  # the box's counter runs since power-on
            assert np.median(np.diff(s.device_time_us)) == 1e6 / RATE  # the mat at its own 50 Hz
            # the platform sees the true CoP in the mat's axes from its own origin (CSV to 1e-4 cm)
            seen = (t["t_platform_s"] >= fp.t[0]) & (t["t_platform_s"] <= fp.t[-1])
            plate = np.column_stack([np.interp(t["t_platform_s"][seen], fp.t, fp.cop_cm[:, i]) for i in range(2)])
            offset = plate - t["cop_cm"][seen]
            np.testing.assert_allclose(offset, np.broadcast_to(vtruth["platform_origin_cm"], offset.shape), atol=2e-3)
            assert np.all(np.abs(vtruth["platform_origin_cm"]) > 5.0)  # its origin is its centre, not cell (0, 0)
            assert np.mean(fp.fz_n) == pytest.approx(weight_n, rel=0.02)  # Fz scaled to the body weight


def test_the_same_seed_gives_the_same_data_another_seed_other_data(study, same_seed_one_volunteer, tmp_path) -> None:
    other = simulate_study(tmp_path / "other", volunteers=1, duration_s=10, seed=SEED + 1, rate_hz=RATE)
    b = same_seed_one_volunteer
    # V01 is the same whatever the number of volunteers: its files byte for byte (no clock in them)
    names: list[str] = []
    for trial in TRIALS:
        stem = f"V01_{trial}"
        names += [f"forceplate/{stem}.csv", f"truth/sessions/{stem}.json", f"truth/sessions/{stem}.npz"]
        a_s, b_s, o_s = (load_session(r / "sessions" / f"{stem}.h5") for r in (study, b, other))
        for name in ("counts", "valid", "seq", "device_time_us", "host_time_s"):
            np.testing.assert_array_equal(getattr(a_s, name), getattr(b_s, name), err_msg=f"{stem}: {name}")
        assert not np.array_equal(a_s.counts, o_s.counts)
        assert (study / f"forceplate/{stem}.csv").read_bytes() != (other / f"forceplate/{stem}.csv").read_bytes()
    names += [f"calibration/SIM{SEED}-V01.json", "truth/volunteers/V01.json", "truth/volunteers/V01.npz"]
    for name in names:
        assert (study / name).read_bytes() == (b / name).read_bytes(), name
    assert (study / "subjects.csv").read_text().splitlines()[1] == (b / "subjects.csv").read_text().splitlines()[1]
    assert _volunteer(study, "V01")[0]["box"] != _volunteer(other, "V01")[0]["box"]


def test_the_lag_in_truth_is_what_the_clocks_say(study) -> None:
    for vid in ("V01", "V02"):
        for trial in TRIALS:
            stem = f"{vid}_{trial}"
            fp = load_forceplate_csv(study / "forceplate" / f"{stem}.csv")
            info, t = _truth(study, stem)
            clock = _device_clock(load_session(study / "sessions" / f"{stem}.h5"))
            # the true CoP on the session's own device times matches the platform file best at
            # truth's lag, to half a millisecond: cop(t) = cop_ref(t + lag) (docs/spec.md §9)
            r = {d: align(fp.t, fp.cop_cm, clock, t["cop_cm"], lag_s=info["lag_s"] + d).r for d in (-5e-4, 0.0, 5e-4)}
            assert r[0.0] > 0.9999 and r[0.0] >= max(r[-5e-4], r[5e-4]), stem


def test_align_finds_the_lag_from_the_mats_cop(study) -> None:
    errors = []
    for stem in ("V01_right-leg", "V02_left-leg", "V01_rotation"):
        fp = load_forceplate_csv(study / "forceplate" / f"{stem}.csv")
        s = load_session(study / "sessions" / f"{stem}.h5")
        clock = _device_clock(s)
        # the mat's CoP through the processing chain, the circuit from the session's calibration
        out = process_counts(s.counts, np.diff(clock, prepend=2 * clock[0] - clock[1]), valid=s.valid,
                             circuit=session_circuit(s), threads=1, progress=False)
        found = align(fp.t, fp.cop_cm, clock[out.usable], out.cop_cm[out.usable])
        assert found.r > 0.9, stem
        errors.append(abs(found.lag_s - _truth(study, stem)[0]["lag_s"]))
    # within a frame (20 ms); the sensor's hysteresis delays the mat's CoP by up to a few frames
    # in some trials (its CoP is not the platform's), never by more than three
    assert np.median(errors) < 1.0 / RATE
    assert max(errors) < 3.0 / RATE


def test_single_leg_trials_load_one_foot_rotation_two(study) -> None:
    for vid in ("V01", "V02"):
        foot_width = _volunteer(study, vid)[0]["person"]["foot_width_cm"]
        for trial in TRIALS:
            info, t = _truth(study, f"{vid}_{trial}")
            col = t["pressure_mean_psi"].sum(axis=0)
            loaded = np.flatnonzero(col > 0.01 * col.max())
            assert info["clipped_frames"] == 0 and info["force_on_mat_min"] > 0.999
            if trial == "rotation":
                assert info["stance"] == "two" and info["rotation"]["freq_hz"] == pytest.approx(0.5, abs=0.1)
                assert np.any(np.diff(loaded) > 1)  # two feet, unloaded columns between them
            else:
                assert info["stance"] == trial.split("-")[0]
                assert np.all(np.diff(loaded) == 1)  # one strip of columns, one foot wide (2 cm cells)
                assert loaded.size * 2.0 <= foot_width + 4.0
                assert 0 < info["sway_scale"] <= 2.0 == info["sway_scale_wanted"]


@pytest.mark.parametrize("kwargs, error, match", [
    ({"volunteers": 0}, ValueError, "volunteers"),
    ({"volunteers": 1.5}, ValueError, "volunteers"),
    ({"volunteers": True}, ValueError, "volunteers"),
    ({"duration_s": 0}, ValueError, "duration_s"),
    ({"duration_s": float("nan")}, ValueError, "duration_s"),
    ({"duration_s": 0.05}, ValueError, "at least 8"),
    ({"seed": -1}, ValueError, "seed"),
    ({"rate_hz": 0.0}, ValueError, "rate_hz"),
    ({"shape": (8, 8)}, ValueError, "shape"),
    ({"bds_paths": []}, ValueError, "no trajectory file"),
    ({"bds_paths": ["/nonexistent/BDS00001.txt"]}, FileNotFoundError, "not found"),
])
def test_bad_arguments_are_one_clear_error_and_write_nothing(tmp_path, kwargs, error, match) -> None:
    args = {"volunteers": 1, "duration_s": 2.0, "seed": 0, **kwargs}
    root = tmp_path / "study"
    with pytest.raises(error, match=match) as info:
        simulate_study(root, **args)
    assert "\n" not in str(info.value)
    assert not root.exists()


def test_an_existing_study_is_not_overwritten(tmp_path) -> None:
    root = tmp_path / "study"
    root.mkdir()
    (root / "subjects.csv").write_text("mine\n")
    with pytest.raises(FileExistsError, match="not an empty folder"):
        simulate_study(root, volunteers=1, duration_s=2.0, seed=0)
    assert (root / "subjects.csv").read_text() == "mine\n"
    assert sorted(p.name for p in root.iterdir()) == ["subjects.csv"]

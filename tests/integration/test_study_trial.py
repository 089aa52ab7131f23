"""One session of a balance study end to end (simulation): a BDS trajectory drives the twin
through a mat the processing does not know (twice as conductive as the nominal sensor model,
15 % cell gains, its own clock); the platform file has its own clock and rate. Also the
aligned traces the figures draw, and a study's calibration file for the session's box."""

from __future__ import annotations

import csv
import shutil

import numpy as np
import pytest

from psmat import Calibration, Circuit, twin
from psmat.io import SessionWriter, bds_trial
from psmat.sensor import THESIS_TABLE_2_11, MPICreep
from psmat.balance import POOR_ALIGNMENT_R
from psmat.study import COLUMNS, process_trial, run_study

LAG_TRUE = None  # set by the fixture: platform clock minus mat clock (s)


def _mat_model(k: float) -> MPICreep:
    """The nominal model k times more conductive (every conductance term scaled)."""
    p = dict(THESIS_TABLE_2_11)
    for name in ("rho", "a1", "a2", "a3"):
        p[name] = p[name] * k
    p["w"] = tuple(v * k for v in p["w"])
    return MPICreep(**p)


@pytest.fixture(scope="module")
def trial(tmp_path_factory):
    d = tmp_path_factory.mktemp("trial")
    rec = bds_trial(3)
    keep = rec.t <= rec.t[0] + 12.0
    t, ml, ap, fz = rec.t[keep], rec.cop_ml_cm[keep], rec.cop_ap_cm[keep], rec.fz_n[keep]
    scene = twin.trajectory_sway(t, ml, ap, fz, 50.0)
    mat = twin.MatPhysics((16, 16), dt=0.02, sensor=_mat_model(2.0), variability=0.15, seed=5)
    counts = mat.counts(np.minimum(scene.pressure_psi, 32.0))
    mat_clock = 500.0 + np.arange(len(counts)) * 0.02  # the mat's own clock
    lag = float(scene.t[0] - 500.0)  # cop(t) = cop_ref(t + lag)
    session = d / "S01_right.h5"
    with SessionWriter(session, (16, 16), {"rows": 16, "cols": 16, "serial": "BOX7"}, metadata={"subject": "S01", "trial": "right"}) as w:
        w.append(counts, mat_clock, np.ones(len(counts), bool))
    plate = d / "S01_right.csv"
    # the platform in the mat's axes (trajectory_sway: M-L -> x, A-P -> y), its own 100 Hz
    np.savetxt(plate, np.c_[t, ml, ap, fz], delimiter=",", header="time,x,y,Fz", comments="")
    weight_kg = float(np.mean(fz)) / 9.80665
    return session, plate, weight_kg, lag


def test_a_simulated_trial_gives_every_variant_against_the_platform(trial) -> None:
    session, plate, weight_kg, lag = trial
    rows = process_trial(session, plate, "S01", "right", weight_kg)
    by = {r["variant"]: r for r in rows}
    assert list(by) == ["FP", "PROP", "PROP-C", "CHC", "SCHC", "PROP-8x8", "PROP-C-8x8", "CHC-8x8", "SCHC-8x8"]
    assert all(set(r) == set(COLUMNS) and r["status"] == "ok" for r in rows)
    # the two clocks are found within a fraction of the mat's 20 ms frame
    assert by["FP"]["lag_s"] == pytest.approx(lag, abs=0.005)
    assert by["FP"]["r_align"] > 0.9
    # eq. 3.3 finds the mat's extra conductance: f near 1/2 (cell gains and the part of the foot
    # off the loaded cells keep it from being exact)
    assert 0.4 < by["SCHC"]["factor"] < 0.6
    # the mat tracks the platform better than a mat that saw nothing: a still trace has Eu = the
    # platform's RMS sway / sqrt(N) (eq. 3.1); N <= the session's frames, so eu · sqrt(frames)
    # bounds the mat's RMS distance from above
    sway = np.hypot(by["FP"]["sd_ml_cm"], by["FP"]["sd_ap_cm"])
    for v in ("PROP", "CHC", "SCHC", "SCHC-8x8"):
        assert by[v]["eu_cm"] * np.sqrt(by[v]["frames"]) < 0.8 * sway
    assert by["FP"]["eu_cm"] == 0.0


def test_bad_sessions_are_rows_with_a_status_not_exceptions(trial, tmp_path) -> None:
    session, plate, weight_kg, lag = trial
    no_plate = process_trial(session, None, "S01", "right", weight_kg, {"variants": ["PROP"]})
    assert [r["status"] for r in no_plate] == ["no force-platform file", "no force-platform file: no Eu, no lag"]
    assert np.isfinite(no_plate[1]["sd_ml_cm"]) and np.isnan(no_plate[1]["eu_cm"])
    no_weight = process_trial(session, plate, "S01", "right", None, {"variants": ["PROP", "SCHC"]})
    assert [r["status"] for r in no_weight][1:] == ["ok", "no body weight: subject missing from subjects.csv"]
    bad = tmp_path / "broken.h5"
    bad.write_bytes(b"\x89HDF\r\n\x1a\n" + b"\0" * 100)
    rows = process_trial(bad, plate, "S02", "left", 70.0, {"variants": ["PROP"]})
    assert len(rows) == 2 and all(r["status"].startswith("error: SessionFormatError") for r in rows)


def test_traces_are_the_aligned_window_the_metrics_come_from(trial) -> None:
    session, plate, weight_kg, lag = trial
    params = {"variants": ["PROP", "SCHC-8x8"], "preprocess": None}  # raw: the SDs of the traces themselves
    rows, traces = process_trial(session, plate, "S01", "right", weight_kg, params, traces=True)
    np.testing.assert_equal(rows, process_trial(session, plate, "S01", "right", weight_kg, params))
    by = {r["variant"]: r for r in rows}
    assert set(traces) == {"t_s", "FP", "PROP", "SCHC-8x8"}
    t = traces["t_s"]
    assert all(traces[k].shape == (t.size, 2) for k in ("FP", "PROP", "SCHC-8x8"))
    # the mat's own frames (clock 500 s + 20 ms steps) moved onto the platform's clock by the lag
    frame = (t - by["FP"]["lag_s"] - 500.0) / 0.02
    np.testing.assert_allclose(frame, np.round(frame), atol=1e-6)
    np.testing.assert_array_equal(np.diff(np.round(frame)), 1.0)
    # FP is the platform file itself at those times, absolute
    data = np.loadtxt(plate, delimiter=",", skiprows=1)
    for k in range(2):
        np.testing.assert_allclose(traces["FP"][:, k], np.interp(t, data[:, 0], data[:, 1 + k]), rtol=1e-12)
    # the full-mat trace is the one whose spread the row reports (docs/spec.md §7: SD, ddof 1, per axis)
    assert np.std(traces["PROP"][:, 0], ddof=1) == pytest.approx(by["PROP"]["sd_ml_cm"], rel=1e-9)
    assert np.std(traces["PROP"][:, 1], ddof=1) == pytest.approx(by["PROP"]["sd_ap_cm"], rel=1e-9)
    # absolute mat coordinates (not mean-removed): on the 32 cm mat, away from its corner
    assert np.all((traces["PROP"] > 1.0) & (traces["PROP"] < 31.0))
    # no platform, no alignment: no traces; a failed session: none either
    assert process_trial(session, None, "S01", "right", weight_kg, params, traces=True)[1] == {}
    assert process_trial(plate, plate, "S01", "right", weight_kg, params, traces=True)[1] == {}


def test_a_calibration_file_gives_the_box_its_r_adc_and_r_mux(trial, tmp_path) -> None:
    """The twin's box is the nominal circuit (R_mux 145 Ω): a calibration file saying so changes
    nothing; one that misstates R_mux (none, or 50 % more) distorts G -> g and the mat follows
    the platform less closely (larger Eu, eq. 3.1)."""
    session, plate, weight_kg, lag = trial
    params = {"variants": ["PROP"]}
    stored = process_trial(session, plate, "S01", "right", weight_kg, params)
    nominal = Circuit()
    same = tmp_path / "BOX7.json"
    Calibration("BOX7", r_adc=nominal.r_adc, r_mux=nominal.r_mux).save(same)
    np.testing.assert_equal(process_trial(session, plate, "S01", "right", weight_kg, params, calibration=same), stored)
    for r_mux in (0.0, 1.5 * nominal.r_mux):
        other = tmp_path / f"mux{r_mux:g}.json"
        Calibration("BOX7", r_adc=nominal.r_adc, r_mux=r_mux).save(other)
        rows = process_trial(session, plate, "S01", "right", weight_kg, params, calibration=other)
        assert [r["status"] for r in rows] == ["ok", "ok"]
        assert rows[1]["eu_cm"] > 1.5 * stored[1]["eu_cm"]
    wrong = tmp_path / "BOX9.json"
    Calibration("BOX9", r_adc=nominal.r_adc, r_mux=nominal.r_mux).save(wrong)
    rows = process_trial(session, plate, "S01", "right", weight_kg, params, calibration=wrong)
    assert {r["status"] for r in rows} == {"error: ValueError: BOX9.json is box 'BOX9'; the session was recorded "
                                           "with box 'BOX7'"}
    broken = tmp_path / "broken.json"
    broken.write_text("{")
    rows = process_trial(session, plate, "S01", "right", weight_kg, params, calibration=broken)
    assert all(r["status"].startswith("error: ValueError:") and "not a valid calibration" in r["status"] for r in rows)


def test_a_lost_frame_does_not_move_the_session_to_the_host_clock(trial, tmp_path) -> None:
    # A frame lost on the wire is stored with device time -1 (docs/spec.md §6). The lag must still be
    # measured on the device clock, the lost frame's time taken from the frame grid; before,
    # one such frame sent the whole session to the host clock (a lag of about -1.7e9 s here).
    from psmat.io import load_session

    session, plate, weight_kg, lag = trial
    s = load_session(session)
    device_us = np.round((s.host_time_s - 500.0) * 1e6).astype(np.int64)  # device clock starts at 0
    valid = s.valid.copy()
    device_us[[0, 100]], valid[[0, 100]] = -1, False  # the first frame too: its time from the grid
    host = 1.7e9 + np.arange(s.n_frames) * 0.02 + 0.003 * np.random.default_rng(0).random(s.n_frames)
    lost = tmp_path / "S01_right.h5"
    counts = s.counts.copy()
    counts[[0, 100]] = 0
    with SessionWriter(lost, (16, 16), {"rows": 16, "cols": 16}, metadata={"subject": "S01", "trial": "right"}) as w:
        w.append(counts, host, valid, seq=np.where(valid, np.arange(s.n_frames), -1), device_time_us=device_us)
    rows = process_trial(lost, plate, "S01", "right", weight_kg, {"variants": ["PROP"]})
    assert [r["status"] for r in rows] == ["ok", "ok"]
    assert rows[0]["frames_missing"] == 2
    assert rows[0]["lag_s"] == pytest.approx(lag + 500.0, abs=0.005)  # platform clock minus device clock


def test_frames_iecm_did_not_converge_are_counted_in_the_rows_not_warned(tmp_path) -> None:
    """The chain warns once per push when IECM leaves frames unconverged; a study has one push per
    session in a worker process, so process_trial counts them in a column instead.

    Which frames cannot converge is known by construction. Every frame reads one count on every
    cell, except the last three, where one cell of the loaded mat reads open. A uniform frame is
    solved by the thesis' fixed point (eq. 2.10) exactly: by symmetry its iterate stays uniform and
    the iteration is a scalar contraction. An open cell (j, q) among loaded cells is no network
    at all: effective resistance is a metric, so 1/G[j,q] <= 1/G[j,p] + 1/G[i,p] + 1/G[i,q] for any
    other row i and column p, three times a loaded cell's resistance, while the open reading says
    over a thousand times more; no positive g reproduces that frame and the iteration cannot meet it."""
    import warnings

    n, k, shape = 12, 3, (8, 8)
    counts = np.full((n,) + shape, 2000, np.uint16)  # about 5e-4 S on every cell (default circuit)
    counts[n - k:, 3, 4] = Circuit().full_scale  # open: the chain takes the open floor, ~8e-8 S
    session = tmp_path / "S01_right.h5"
    with SessionWriter(session, shape, {"rows": 8, "cols": 8}, metadata={"subject": "S01", "trial": "right"}) as w:
        w.append(counts, 100.0 + 0.02 * np.arange(n), np.ones(n, bool))
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # nothing escapes process_trial
        rows = process_trial(session, None, "S01", "right", None, {"variants": [], "method": "fixed_point"})
    assert [r["status"] for r in rows] == ["no force-platform file"]
    assert rows[0]["frames_unconverged"] == k and rows[0]["frames"] == n and rows[0]["frames_missing"] == 0
    # the same frames under Newton: the open cell held at the bound, every frame a solution
    rows = process_trial(session, None, "S01", "right", None, {"variants": [], "method": "newton"})
    assert rows[0]["frames_unconverged"] == 0


def test_a_platform_file_of_another_recording_is_a_poor_alignment_not_a_result(trial, tmp_path) -> None:
    """Another recording's platform file (a mix-up of names) shares no sway with the mat: before, its lag,
    Eu and metrics entered the summary as the session's. Now every row says so and keeps its numbers,
    and the summary leaves them out (status not "ok")."""
    session, plate, weight_kg, lag = trial
    other = bds_trial(11)  # another volunteer's recording, on the platform clock of this trial's file
    t0 = float(np.loadtxt(plate, delimiter=",", skiprows=1, max_rows=1)[0])
    keep = other.t <= other.t[0] + 12.0
    wrong = tmp_path / "S01_left.csv"
    np.savetxt(wrong, np.c_[other.t[keep] - other.t[0] + t0, other.cop_ml_cm[keep], other.cop_ap_cm[keep],
                            other.fz_n[keep]], delimiter=",", header="time,x,y,Fz", comments="")
    params = {"variants": ["PROP", "SCHC"]}
    rows = process_trial(session, wrong, "S01", "right", weight_kg, params)
    assert rows[0]["r_align"] < POOR_ALIGNMENT_R
    for r in rows:
        assert r["status"] == (f"poor alignment: r {rows[0]['r_align']:.2f} < 0.6 at the best lag: is S01_left.csv "
                               "this session's platform file?")
        assert np.isfinite(r["sd_ml_cm"])
    assert all(r["status"] == "ok" for r in process_trial(session, plate, "S01", "right", weight_kg, params))
    # a study run says so among its problems (its sessions' lines), and its summary has no such row
    root = tmp_path / "study"
    (root / "sessions").mkdir(parents=True)
    (root / "forceplate").mkdir()
    shutil.copy(session, root / "sessions" / "S01_right.h5")
    shutil.copy(wrong, root / "forceplate" / "S01_right.csv")
    (root / "subjects.csv").write_text(f"subject,weight_kg\nS01,{weight_kg:.3f}\n")
    run = run_study(root, workers=1, params=params, progress=False)
    assert [p for p in run.problems if "poor alignment" in p] == [f"S01_right: {rows[0]['status'].replace('S01_left', 'S01_right')}"]
    with open(run.outputs["summary"], newline="") as fh:
        summary = list(csv.DictReader(fh))
    assert summary and all(r["n_ok"] == "0" and r["n_failed"] == "1" for r in summary)
    assert "platform's axes were turned" not in (root / "results" / "report.md").read_text(encoding="utf-8")
    with pytest.raises(ValueError, match="platform_axes must be one of x,y, -x,y"):
        run_study(root, workers=1, params={**params, "platform_axes": "x,z"}, progress=False)


def test_a_platform_whose_a_p_axis_points_the_other_way_is_named_and_can_be_turned(trial, tmp_path) -> None:
    """Platforms differ in where their axes point; a file whose A-P axis points towards the heels
    aligns poorly (before: a lag found on noise, and Eu and the summary from it). The status names
    the axes that align it, and with them the rows are those of the file written the mat's way."""
    session, plate, weight_kg, lag = trial
    data = np.loadtxt(plate, delimiter=",", skiprows=1)
    turned = tmp_path / "S01_right.csv"
    np.savetxt(turned, np.c_[data[:, 0], data[:, 1], -data[:, 2], data[:, 3]], delimiter=",",
               header="time,x,y,Fz", comments="")
    params = {"variants": ["PROP"]}
    rows = process_trial(session, turned, "S01", "right", weight_kg, params)
    assert all(r["status"].startswith(f"poor alignment: r {rows[0]['r_align']:.2f} < 0.6 at the best lag, ")
               and r["status"].endswith("with the platform's axes x,-y: they lie otherwise than the mat's "
                                        "(study run --platform-axes=x,-y)") for r in rows)
    fixed = process_trial(session, turned, "S01", "right", weight_kg, {**params, "platform_axes": "x,-y"})
    # a study whose platform lies so in every trial is told once, first; run with those axes it reads
    # them so, and report.md says so
    root = tmp_path / "study"
    (root / "sessions").mkdir(parents=True)
    (root / "forceplate").mkdir()
    for stem in ("S01_right", "S01_again"):
        shutil.copy(session, root / "sessions" / f"{stem}.h5")
        shutil.copy(turned, root / "forceplate" / f"{stem}.csv")
    (root / "subjects.csv").write_text(f"subject,weight_kg\nS01,{weight_kg:.3f}\n")
    run = run_study(root, workers=1, params=params, progress=False)
    told = [k for k, line in enumerate(run.problems) if "x,-y" in line]
    assert run.problems[told[0]] == ("2 trials align only with the platform's axes x,-y: run the study again with "
                                     "--platform-axes=x,-y") and len(told) == 3  # then each trial's own line
    run = run_study(root, workers=1, params={**params, "platform_axes": "x,-y"}, progress=False)
    assert not [p for p in run.problems if "alignment" in p]
    assert ("The force platform's axes were turned onto the mat's: M-L, A-P = x,-y of its files (platform_axes)."
            in (root / "results" / "report.md").read_text(encoding="utf-8"))
    plain = process_trial(session, plate, "S01", "right", weight_kg, params)
    assert [r["status"] for r in fixed] == ["ok", "ok"]
    for a, b in zip(fixed, plain):
        for k in ("lag_s", "r_align", "eu_cm", "sd_ml_cm", "sd_ap_cm", "path_cm"):
            assert a[k] == pytest.approx(b[k], rel=1e-9, abs=1e-12), k


def test_a_platform_file_read_in_another_unit_is_said_not_summarised(trial, tmp_path) -> None:
    """A platform whose software writes mm under a header without units ("x,y"): read as cm, its CoP
    moves ten times the mat's, and its sway metrics and Eu were ten times too large while the
    alignment, a correlation, stayed good (before: entered the summary). Now the rows keep their
    numbers under a status that names the unit that fits; the file's header naming mm gives the
    plain rows back. The same in m: a hundredth."""
    session, plate, weight_kg, lag = trial
    data = np.loadtxt(plate, delimiter=",", skiprows=1)
    params = {"variants": ["PROP"]}
    plain = process_trial(session, plate, "S01", "right", weight_kg, params)
    status = {}
    for unit, k in (("mm", 10.0), ("m", 0.01)):
        written = tmp_path / f"S01_right_{unit}.csv"
        np.savetxt(written, np.c_[data[:, 0], data[:, 1:3] * k, data[:, 3]], delimiter=",", header="time,x,y,Fz",
                   comments="", fmt="%.10g")
        rows = process_trial(session, written, "S01", "right", weight_kg, params)
        ratio = rows[0]["sd_ml_cm"] / plain[0]["sd_ml_cm"]
        assert ratio == pytest.approx(k, rel=1e-6)  # (the slip itself: the rows are ten times the plain ones)
        head = rows[0]["status"].split(" times the mat's")[0]
        spread = float(head.split()[-1])
        assert head.startswith("platform spread: its CoP spreads ") and (spread > 4 if k > 1 else spread < 0.25)
        status[unit] = rows[0]["status"]
        assert all(r["status"] == rows[0]["status"] for r in rows) and rows[0]["status"].endswith(
            f"is {written.name} in {unit}, read as cm? (name the unit in its CoP columns' header, e.g. x [{unit}])")
        named = tmp_path / f"named_{unit}.csv"
        np.savetxt(named, np.c_[data[:, 0], data[:, 1:3] * k, data[:, 3]], delimiter=",", comments="", fmt="%.10g",
                   header=f"time,x [{unit}],y [{unit}],Fz")
        fixed = process_trial(session, named, "S01", "right", weight_kg, params)
        assert all(r["status"] == "ok" for r in fixed)
        assert fixed[0]["sd_ml_cm"] == pytest.approx(plain[0]["sd_ml_cm"], rel=1e-6)
    # a study run lists it among the problems, and its summary leaves it out
    root = tmp_path / "study"
    (root / "sessions").mkdir(parents=True)
    (root / "forceplate").mkdir()
    shutil.copy(session, root / "sessions" / "S01_right.h5")
    shutil.copy(tmp_path / "S01_right_mm.csv", root / "forceplate" / "S01_right.csv")
    (root / "subjects.csv").write_text(f"subject,weight_kg\nS01,{weight_kg:.3f}\n")
    run = run_study(root, workers=1, params=params, progress=False)
    assert [p for p in run.problems if "platform spread" in p] == [
        "S01_right: " + status["mm"].replace("S01_right_mm.csv", "S01_right.csv")]
    with open(run.outputs["summary"], newline="") as fh:
        summary = list(csv.DictReader(fh))
    assert summary and all(r["n_ok"] == "0" for r in summary)


def test_a_session_from_a_narrower_adc_is_an_error_not_a_result(trial, tmp_path) -> None:
    """The trial's counts as a 10-bit board sends them, stored under the session's 12 bits (its profile's):
    every empty cell would read as a loaded one and the rows would be garbage with a misleading status
    (a poor alignment). Now the session's rows say why, one line."""
    from psmat.io import load_session

    session, plate, weight_kg, lag = trial
    s = load_session(session)
    ten = tmp_path / "S01_right.h5"
    with SessionWriter(ten, (16, 16), s.device, metadata=s.metadata) as w:
        w.append((s.counts >> 2).astype(np.uint16), s.host_time_s, s.valid)
    top = int((s.counts >> 2).max())
    # an open cell of the nominal box: V_ref through R_o (2200 ohm) into the ADC's 6.9 Mohm (thesis §2.4)
    empty = round(4095 * 6.9e6 / (6.9e6 + 2200))
    rows = process_trial(ten, plate, "S01", "right", weight_kg, {"variants": ["PROP"]})
    assert top >= 1000 and all(r["status"] == (
        f"error: ValueError: no count above {top} in {s.n_frames} valid frames, where an empty cell reads "
        f"{empty} of 4095 (12 bits): is the board's ADC 10-bit? Every cell then reads as loaded: "
        "record with --bits 10 (or a profile with bits = 10)") for r in rows)


def test_a_platform_that_writes_0_0_off_the_plate_loses_those_samples(trial, tmp_path) -> None:
    """A platform without Fz whose software writes (0, 0) while no one stands on it, its origin at a corner
    (the CoP 20 cm from it): before, the second the subject stepped off joined the trace, and the trial
    aligned poorly ("is FILE this session's platform file?"). Now such samples, far outside the trace, are
    lost samples: the rows are those of the same file with that second's fields left empty."""
    session, plate, weight_kg, lag = trial
    data = np.loadtxt(plate, delimiter=",", skiprows=1)
    xy = data[:, 1:3] + 20.0
    off = (data[:, 0] >= data[0, 0] + 5.0) & (data[:, 0] < data[0, 0] + 6.0)  # one second off the plate
    zeros, empty = tmp_path / "zeros.csv", tmp_path / "empty.csv"
    np.savetxt(zeros, np.c_[data[:, 0], np.where(off[:, None], 0.0, xy)], delimiter=",", header="time,x,y",
               comments="", fmt="%.10g")
    empty.write_text("time,x,y\n" + "".join(f"{t:.10g},,\n" if o else f"{t:.10g},{x:.10g},{y:.10g}\n"
                                             for t, (x, y), o in zip(data[:, 0], xy, off)))
    params = {"variants": ["PROP"]}
    rows, ref = (process_trial(session, f, "S01", "right", weight_kg, params) for f in (zeros, empty))
    assert all(r["status"] == "ok" for r in rows)
    for a, b in zip(rows, ref, strict=True):
        assert a.keys() == b.keys()
        for k in a:
            same = a[k] == b[k] or (isinstance(a[k], float) and np.isnan(a[k]) and np.isnan(b[k]))
            assert same, (a["variant"], k, a[k], b[k])

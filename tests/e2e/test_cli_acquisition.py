"""The acquisition commands on the digital twin: calibrate, record, info, demo."""

from __future__ import annotations

import csv
import json
import time

import numpy as np
import pytest

from psmat import Calibration, Circuit
from psmat.cli import main
from psmat.io import load_session
from psmat.process import process_session


def test_calibrate_recovers_the_twins_circuit(tmp_path, capsys):
    out = tmp_path / "cal.json"
    assert main(["calibrate", "--simulate", "--seconds", "0.5", "--out", str(out)]) == 0
    cal = Calibration.load(out)
    true = Circuit()  # what the twin's box has (docs/spec.md §2 defaults)
    assert cal.r_mux == pytest.approx(true.r_mux, rel=0.02)
    assert cal.r_adc == pytest.approx(true.r_adc, rel=0.05)
    assert cal.serial == "TWIN0001"
    assert "R_adc" in capsys.readouterr().out


def test_record_info_csv_and_processing(tmp_path, capsys):
    path = tmp_path / "s.h5"
    before = time.time()
    assert main(["record", "--simulate", "-o", str(path), "--seconds", "1.5", "--subject", "S07", "--trial", "eo1"]) == 0
    after = time.time()
    s = load_session(path)
    # what the recording must hold, however fast a loaded machine let the twin stream:
    # some frames, every one valid, none lost between the first and the last (contiguous seq)
    assert s.n_frames > 0 and s.complete and s.valid.all()
    np.testing.assert_array_equal(s.seq, s.seq[0] + np.arange(s.n_frames))
    assert s.counters["dropped_frames"] == 0 and s.counters["bad_frames"] == 0
    # host times never go backwards and were all stamped while the command ran
    host = s.host_time_s
    assert np.all(np.diff(host) >= 0) and before <= host[0] and host[-1] <= after
    assert s.metadata["subject"] == "S07" and s.device["serial"] == "TWIN0001"
    capsys.readouterr()
    csv_path = tmp_path / "s.csv"
    assert main(["info", str(path), "--csv", str(csv_path)]) == 0
    text = capsys.readouterr().out
    assert "frames" in text and "TWIN0001" in text
    with open(csv_path, newline="") as f:
        rows = list(csv.reader(f))
    assert rows[0][:4] == ["time_s", "valid", "seq", "c_0_0"] and len(rows) == s.n_frames + 1
    assert [int(v) for v in rows[1][3:]] == s.counts[0].ravel().tolist()

    out = process_session(path, g_rest=1e-7, progress=False)
    again = load_session(path)
    assert set(again.products) >= {"G", "g", "pressure", "cop"}
    assert again.products["pressure"].unit == "kPa" and again.products["cop"].data.shape == (s.n_frames, 2)
    assert again.products["g"].params["iecm_method"] == "newton"
    # two feet on a 32 cm mat: the CoP is inside the mat
    assert np.all((out.cop_cm > 0) & (out.cop_cm < 30))


def test_info_reports_a_corrupt_file(tmp_path, capsys):
    bad = tmp_path / "bad.h5"
    bad.write_bytes(b"not an HDF5 file at all")
    assert main(["info", str(bad)]) == 1
    assert "bad.h5" in capsys.readouterr().err


@pytest.mark.slow
def test_demo_improves_the_cop_against_the_force_platform(tmp_path):
    from psmat.workflows.sway_demo import run_sway_demo

    res = run_sway_demo(tmp_path / "demo.png", seconds=3, session=tmp_path / "demo.h5", progress=False,
                        log=lambda *a: None)
    assert res["lost"] == 0 and res["invalid"] == 0 and res["frames"] > 0  # how many: the twin's timer and the load, not a claim
    assert (tmp_path / "demo.png").stat().st_size > 10_000
    # crosstalk compresses and shifts the CoP trace; IECM + the sensor model undo most of it
    assert res["cop_rms_cm"] < res["cop_rms_raw_cm"]
    assert res["cop_rms_after_offset_cm"] < 0.5 * res["cop_rms_raw_after_offset_cm"]
    json.dumps(res)  # everything it reports is plain data


@pytest.mark.parametrize("command", [["record", "{port}", "-o", "{out}", "--seconds", "1"], ["calibrate", "{port}"],
                                     ["demo", "--port", "{port}", "--session", "{out}"]])
def test_a_port_that_does_not_exist_is_one_clear_line(command, tmp_path, capsys):
    port = str(tmp_path / "ttyNOPE")
    argv = [a.format(port=port, out=tmp_path / "x.h5") for a in command]
    assert main(argv) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "ttyNOPE" in err[0] and err[0].startswith(f"psmat {command[0]}:")


def test_a_recorded_material_daq_session_becomes_a_pneumatic_run(tmp_path):
    from psmat.protocol import DAQ_MAX_COUNT
    from psmat.sensor import load_daq_session
    from psmat.sensor.pneumatic import DAQ_R_O

    path = tmp_path / "daq.h5"
    assert main(["record", "--simulate", "--device", "daq", "--rate", "20", "-o", str(path), "--seconds", "1"]) == 0
    s = load_session(path)
    run = load_daq_session(path)
    assert run.g.shape == (int(s.valid.sum()), 10)
    # the divider by hand (sensor on the low side, R_o to V_ref): g = (1 - x) / (R_o x)
    x = s.counts[s.valid] / DAQ_MAX_COUNT
    with np.errstate(divide="ignore"):
        expected = np.where(x > 0, (1 - x) / (DAQ_R_O * x), np.nan)
    ok = np.isfinite(expected) & (x < 1)
    np.testing.assert_allclose(run.g[ok], expected[ok], rtol=1e-12)
    assert np.all(np.diff(run.t) > 0)
    with pytest.raises(ValueError, match="daq"):
        load_daq_session(_psm_session(tmp_path))


def _psm_session(tmp_path):
    path = tmp_path / "psm.h5"
    assert main(["record", "--simulate", "-o", str(path), "--seconds", "0.3"]) == 0
    return path

"""``--profile`` on ``psmat record``, ``psmat simulate`` and ``psmat calibrate`` (docs/spec.md §5
"Device profiles"), as subprocesses on real pseudo-terminals.

* A shipped profile (psm8) recorded from the twin: the session holds it, and processing takes
  its 4 cm pitch; ``--protocol csv`` alone is the arduino16 mat, 10-bit.
* A user's profile file (12 x 10 cells, 1.5 cm, rows and columns sent in another order) served
  by ``psmat simulate`` and recorded by ``psmat record PORT``: the session's frames are in
  logical order. The expectation is the scene's footprint (where the feet press, from the
  scene's pressure, not from the reordering code): loaded cells read lower counts than the
  unloaded ones (more conductance pulls the divider down; an open cell reads full scale,
  docs/spec.md §2). The wire order chosen moves many cells of that footprint, and so does
  applying it twice, so a missing or doubled reordering fails the test.
* Bad profiles: one line on stderr, exit 1, nothing written.
* ``psmat calibrate --simulate --profile arduino16``: the calibration is of a 10-bit, 5 V box.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import psmat
from psmat.io import load_session
from psmat.process import process_session
from psmat.twin import make_scene

from conftest import child_preexec

GUARD_S = 60.0  # hang guard, not a duration

pytestmark = pytest.mark.skipif(not hasattr(os, "openpty"), reason="needs pseudo-terminals (POSIX)")

#: a cyclic shift of the rows and a scramble of the columns: no cycle of length 1 or 2, so neither
#: the order nor the order applied twice is the identity
ROW_ORDER = [5, 6, 7, 8, 9, 10, 11, 0, 1, 2, 3, 4]
COL_ORDER = [3, 7, 1, 9, 5, 0, 8, 2, 6, 4]

USER_PROFILE = f"""\
name = "bench12x10"
description = "a 12 x 10 test mat, rows and columns wired out of order"
kind = "psm"
protocol = "v2"
rate_hz = 49.6
baudrate = 1000000

[geometry]
shape = [12, 10]
pitch_cm = 1.5

[wire]
row_order = {ROW_ORDER}
col_order = {COL_ORDER}

[circuit]
r_o_ohm = 2200.0
v_ref_volt = 3.3
bits = 12
r_mux_ohm = 145.0
r_adc_ohm = 6.9e6
"""


def _psmat(*args: str, timeout_s: float = GUARD_S) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "psmat", *args], capture_output=True, text=True, timeout=timeout_s)


def _one_line(text: str) -> str:
    lines = text.strip().splitlines()
    assert len(lines) == 1, text
    return lines[0]


def test_record_the_psm8_twin_stores_its_profile_and_processing_takes_its_pitch(tmp_path: Path) -> None:
    out = tmp_path / "p8.h5"
    r = _psmat("record", "--simulate", "--profile", "psm8", "--seconds", "1", "-o", str(out))
    assert r.returncode == 0, r.stderr
    s = load_session(out)
    assert s.counts.shape[1:] == (8, 8) and s.n_frames > 0 and s.valid.all()
    assert psmat.Profile.from_dict(s.profile) == psmat.load_profile("psm8")
    processed = process_session(out, g_rest=1e-7, progress=False)
    assert processed.params["pitch_cm"] == 4.0  # psm8: 8 cells on 32 cm


def test_record_protocol_csv_alone_is_the_arduino_mat(tmp_path: Path) -> None:
    out = tmp_path / "diy.h5"
    r = _psmat("record", "--simulate", "--protocol", "csv", "--seconds", "1", "-o", str(out))
    assert r.returncode == 0, r.stderr
    s = load_session(out)
    prof = psmat.Profile.from_dict(s.profile)
    assert prof == psmat.load_profile("arduino16") and prof.bits == 10 and prof.v_ref_volt == 5.0
    assert s.device["proto"] == "csv" and s.device["bits"] == 10
    assert s.n_frames > 0 and int(s.counts[s.valid].max()) <= 2**10 - 1


def test_a_user_profile_served_and_recorded_comes_out_in_logical_order(tmp_path: Path) -> None:
    path = tmp_path / "bench12x10.toml"
    path.write_text(USER_PROFILE)
    prof = psmat.load_profile(path)
    # where the quiet scene's feet press on this mat (logical order), from the scene's pressure alone
    pressure = make_scene("quiet", 2.0, 50.0, prof.shape, pitch_cm=prof.pitch_cm).pressure_psi
    loaded = (pressure > 0).all(axis=0)
    assert ((pressure > 0).any(axis=0) == loaded).all() and 20 <= loaded.sum() <= 100  # a steady footprint
    wire = prof.logical_to_wire(loaded)
    twice = prof.logical_to_wire(wire)
    assert (wire != loaded).sum() >= 20 and (twice != loaded).sum() >= 20  # the test can tell them apart

    sim = subprocess.Popen([sys.executable, "-m", "psmat", "simulate", "--profile", str(path), "--scene", "quiet"],
                           stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, preexec_fn=child_preexec())
    try:
        port = sim.stdout.readline().strip()
        assert port, sim.communicate()
        out = tmp_path / "bench.h5"
        r = _psmat("record", port, "--profile", str(path), "--seconds", "1", "-o", str(out))
    finally:
        sim.send_signal(signal.SIGTERM)
        _, sim_err = sim.communicate(timeout=GUARD_S)
    assert r.returncode == 0, r.stderr
    assert "rate_hz 49.6 rounded to 50 Hz" in sim_err  # the firmware's timer counts whole frames
    s = load_session(out)
    assert psmat.Profile.from_dict(s.profile) == prof
    frames = s.counts[s.valid].astype(float)
    assert frames.shape[1:] == (12, 10) and len(frames) >= 10
    mean = frames.mean(axis=0)
    assert mean[loaded].max() < mean[~loaded].min(), np.round(mean)
    # the same frames left in wire order would not be: (a check that the footprint discriminates)
    on_wire = prof.logical_to_wire(mean)
    assert not on_wire[loaded].max() < on_wire[~loaded].min()


def test_profile_that_is_not_there_names_psmat_profiles(tmp_path: Path) -> None:
    for cmd in (["record", "--simulate", "-o", str(tmp_path / "x.h5")], ["simulate"], ["calibrate", "--simulate"]):
        r = _psmat(*cmd, "--profile", "nosuch")
        assert r.returncode == 1 and "psmat profiles" in _one_line(r.stderr), (cmd, r.stderr)
    assert list(tmp_path.iterdir()) == []


def test_record_refuses_a_profile_of_another_device_kind(tmp_path: Path) -> None:
    out = tmp_path / "x.h5"
    r = _psmat("record", "--simulate", "--profile", "imu", "--device", "psm", "--seconds", "1", "-o", str(out))
    assert r.returncode == 1 and "--profile imu" in _one_line(r.stderr) and "--device psm" in r.stderr
    assert list(tmp_path.iterdir()) == []


def test_calibrate_the_arduino_twin_records_its_10_bit_5_volt_box(tmp_path: Path) -> None:
    out = tmp_path / "cal.json"
    r = _psmat("calibrate", "--simulate", "--profile", "arduino16", "--yes", "--seconds", "0.5", "--out", str(out))
    assert r.returncode == 0, r.stderr
    cal = psmat.Calibration.load(out)
    assert (cal.bits, cal.v_ref, cal.r_o) == (10, 5.0, 2200.0)
    # the shorted pairs read R_mux through a 10-bit ADC: near the box's two ~70 Ohm channels (one count
    # near a short is worth R_o / 1023 ~ 2 Ohm)
    nominal = psmat.load_profile("arduino16")
    assert cal.r_mux == pytest.approx(nominal.r_mux_ohm, abs=10.0)

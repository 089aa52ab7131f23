"""One session of a balance study end to end (simulation): a BDS trajectory drives the twin
through a mat the processing does not know (twice as conductive as the nominal sensor model,
15 % cell gains, its own clock); the platform file has its own clock and rate."""

from __future__ import annotations

import numpy as np
import pytest

from psmat import twin
from psmat.io import SessionWriter, bds_trial
from psmat.sensor import THESIS_TABLE_2_11, MPICreep
from psmat.study.trial import COLUMNS, process_trial

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
    counts = mat.counts(np.minimum(scene.pressure, 32.0))
    mat_clock = 500.0 + np.arange(len(counts)) * 0.02  # the mat's own clock
    lag = float(scene.t[0] - 500.0)  # cop(t) = cop_ref(t + lag)
    session = d / "S01_right.h5"
    with SessionWriter(session, (16, 16), {"rows": 16, "cols": 16}, metadata={"subject": "S01", "trial": "right"}) as w:
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

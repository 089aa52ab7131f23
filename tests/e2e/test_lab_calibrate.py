"""``psmat lab``'s calibration walk-through of the box (docs/spec.md §2 "Calibration"), over real HTTP.

``psmat lab --simulate`` puts the twin behind a calibration fixture, which the server switches
to each step's set-up (mat unplugged, one row wired to one column), so the walk-through runs
without a person. The estimates are checked against the twin's true circuit (the psm16 box:
:class:`psmat.Circuit`'s defaults, docs/spec.md §2) with the tolerances ``psmat calibrate
--simulate`` is held to, and the step readings against the voltage divider computed by hand.
"""

from __future__ import annotations

import os
import time

import pytest

pytest.importorskip("starlette")
pytest.importorskip("uvicorn")

from psmat import Calibration, Circuit  # noqa: E402
from psmat.io import load_session  # noqa: E402

from test_cli_lab import Lab  # noqa: E402

TRUE = Circuit()   # the twin's box (psm16: 2.2 kOhm R_o, 145 Ohm R_mux, 6.9 MOhm R_adc, 12 bits)
FULL_SCALE = 2 ** 12 - 1


@pytest.fixture(scope="module")
def lab(tmp_path_factory: pytest.TempPathFactory):
    lab = Lab(tmp_path_factory.mktemp("labcal") / "data")
    yield lab
    lab.stop()


def _cal_dir(lab: Lab) -> str:
    return os.path.join(lab.data, "calibration")


def _wait_recorded(lab: Lab, n: int, timeout_s: float = 30.0) -> dict:
    """The status once the running recording holds at least ``n`` frames."""
    t_end = time.monotonic() + timeout_s
    while True:
        status, st = lab.request("GET", "/api/status")
        assert status == 200 and st["recording"], st
        if st["record"]["frames"] >= n:
            return st
        assert time.monotonic() < t_end, f"fewer than {n} frames recorded in {timeout_s:g} s: {st}"
        time.sleep(0.05)


def test_calibrate_endpoints_need_the_token(lab: Lab) -> None:
    for token in (None, "wrong" + lab.token[5:]):
        for action, body in (("start", {}), ("step", {"step": "open"}), ("finish", {}), ("cancel", {})):
            status, out = lab.request("POST", f"/api/calibrate/{action}", body, token=token)
            assert status == 401, (action, status, out)
    assert not os.path.exists(_cal_dir(lab))
    status, st = lab.request("GET", "/api/status")
    assert status == 200 and st["calibration"] is None and st["calibrated"] is None


def test_calibrate_is_refused_during_a_recording_and_blocks_one(lab: Lab) -> None:
    status, rec = lab.request("POST", "/api/record/start", {"subject": "S1", "trial": "before", "note": ""})
    assert status == 201
    status, out = lab.request("POST", "/api/calibrate/start", {})
    assert status == 409 and "recording" in out["error"]
    status, stop = lab.request("POST", "/api/record/stop", {})
    assert status == 200
    assert load_session(stop["session"]).calibration is None   # no calibration made yet in this run
    # and the other way round: no recording while the box is unplugged or wired
    assert lab.request("POST", "/api/calibrate/start", {})[0] == 200
    status, out = lab.request("POST", "/api/record/start", {"subject": "S1", "trial": "during", "note": ""})
    assert status == 409 and "calibration" in out["error"]
    assert lab.request("POST", "/api/calibrate/cancel", {}) == (200, {"cancelled": True})
    assert lab.request("POST", "/api/calibrate/step", {"step": "open"})[0] == 409   # nothing to step through


def test_bad_steps_get_one_line(lab: Lab) -> None:
    status, st = lab.request("POST", "/api/calibrate/start", {"pairs": "0,0;3,4", "seconds": 0.3})
    assert status == 200 and st["pairs"] == [[0, 0], [3, 4]]
    for body in ({"step": "wiggle"}, {"step": "short", "row": 5, "col": 5}, {"step": "short", "row": "0", "col": 0}):
        status, out = lab.request("POST", "/api/calibrate/step", body)
        assert status == 400 and "\n" not in out["error"], (body, out)
    status, out = lab.request("POST", "/api/calibrate/finish", {})
    assert status == 409 and "open step" in out["error"]
    assert lab.request("POST", "/api/calibrate/start", {"pairs": [[16, 0]]})[0] == 400   # outside the 16x16 mat
    assert lab.request("POST", "/api/calibrate/cancel", {})[0] == 200
    assert not os.path.exists(_cal_dir(lab))


def test_walk_through_recovers_the_twins_circuit_and_recordings_store_it(lab: Lab) -> None:
    status, st = lab.request("POST", "/api/calibrate/start", {})
    assert status == 200 and st["simulated"] is True
    steps = st["steps"]
    assert [(s["step"], s.get("row"), s.get("col")) for s in steps] == [
        ("open", None, None), ("short", 0, 0), ("short", 0, 15), ("short", 15, 0), ("short", 15, 15)]
    assert "Unplug the mat" in steps[0]["instruction"] and "row 15 to column 0" in steps[3]["instruction"]

    status, out = lab.request("POST", "/api/calibrate/step", {"step": "open"})
    assert status == 200, out
    d = out["diagnostics"]
    # open: the divider reads R_adc against R_o, FS * R_adc / (R_adc + R_o) = 4093.7 counts
    assert d["frames"] >= 50 and d["mean_count"] == pytest.approx(FULL_SCALE * TRUE.r_adc / (TRUE.r_adc + TRUE.r_o),
                                                                   abs=2.0)
    for s in steps[1:]:
        status, out = lab.request("POST", "/api/calibrate/step", {"step": "short", "row": s["row"], "col": s["col"]})
        assert status == 200, out
        d = out["diagnostics"]
        # a wired pair reads R_mux against R_o: FS * R_mux / (R_mux + R_o) = 253.2 counts, nothing clipped
        assert d["mean_count"] == pytest.approx(FULL_SCALE * TRUE.r_mux / (TRUE.r_mux + TRUE.r_o), abs=2.0)
        assert d["clipped_fraction"] == 0.0 and 0 < d["spread_count"] < 10
    status, st = lab.request("GET", "/api/status")
    assert st["calibration"]["ready"] is True and all(s["done"] for s in st["calibration"]["steps"])
    # the display kept running through the steps
    assert st["display"]["updates"] > 0 and st["rates"]["displayed_hz"]

    status, fin = lab.request("POST", "/api/calibrate/finish", {})
    assert status == 200, fin
    path = os.path.join(lab.data, "calibration", "TWIN0001.json")
    assert fin["path"] == path and os.path.isfile(path)
    assert [n for n in os.listdir(_cal_dir(lab))] == ["TWIN0001.json"]   # written whole: no temporary left
    cal = Calibration.load(path)
    assert cal.serial == "TWIN0001"
    assert cal.r_mux == pytest.approx(TRUE.r_mux, rel=0.02)
    assert cal.r_adc == pytest.approx(TRUE.r_adc, rel=0.05)
    assert fin["r_mux_ohm"] == pytest.approx(cal.r_mux) and fin["r_adc_ohm"] == pytest.approx(cal.r_adc)
    status, st = lab.request("GET", "/api/status")
    assert st["calibration"] is None and st["calibrated"]["path"] == path

    # the twin's mat is plugged back: someone stands on it again (loaded cells read well below full scale)
    status, rec = lab.request("POST", "/api/record/start", {"subject": "S1", "trial": "after", "note": ""})
    assert status == 201
    _wait_recorded(lab, 50)  # (a fixed second held no frame once, on a loaded machine)
    status, stop = lab.request("POST", "/api/record/stop", {})
    assert status == 200
    s = load_session(stop["session"])
    assert s.calibration is not None
    assert s.calibration["r_mux_ohm"] == pytest.approx(cal.r_mux) and s.calibration["serial"] == "TWIN0001"
    frames = s.frames[s.valid]
    assert len(frames) > 10 and (frames < 0.9 * FULL_SCALE).mean() > 0.01

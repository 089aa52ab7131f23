"""Pressure calibration (:mod:`psmat.pressure`, docs/spec.md §4): equilibration, known load, the
calibration as data, and the chain applying it.

Conductances are made here with the direct sensor model (thesis Table 2.11) times hand-chosen
gains, so the gains the calibration must find are known: a cell ``a·D(p)`` needs ``k = 1/a``.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from psmat import Calibration, Circuit, iecm
from psmat.pressure import PressureCalibration, describe, equilibrate, known_load
from psmat.process import Processor
from psmat.sensor import MPICreep

PSI_KPA = 6.894757  # 1 psi in kPa, by definition
DT = 0.02
T = 400
ONSET = 50  # frames unloaded before the load goes on
MODEL = MPICreep.thesis()


def _step(level_kpa: float, shape: tuple[int, int]) -> np.ndarray:
    """(T, R, C) psi: unloaded, a 0.4 s ramp to ``level_kpa`` on every cell, held."""
    ramp = np.clip((np.arange(T) - ONSET) / 20.0, 0.0, 1.0)
    return np.broadcast_to((level_kpa / PSI_KPA) * ramp[:, None, None], (T,) + shape).copy()


def _gains(shape: tuple[int, int], seed: int = 4) -> np.ndarray:
    return 2.0 * np.exp(0.3 * np.random.default_rng(seed).standard_normal(shape))


def test_equilibrate_recovers_hand_known_gains() -> None:
    a = _gains((5, 7))
    recs = [MODEL.direct(_step(v, a.shape), DT) * a for v in (15.0, 45.0)]
    r = equilibrate(recs, DT, [15.0, 45.0], settle_s=2.0)
    np.testing.assert_allclose(r.gains, 1.0 / a, rtol=1e-7)
    assert not r.flagged.any() and np.all(r.spread < 1e-7) and r.per_recording.shape == (2, 5, 7)


def test_a_cell_that_is_not_a_pure_gain_shows_a_spread_and_an_unloaded_one_is_flagged() -> None:
    a = _gains((4, 4))
    lo = MODEL.direct(_step(10.0, a.shape), DT) * a
    hi = MODEL.direct(_step(30.0, a.shape), DT) * a
    hi[:, 1, 2] *= 1.2  # this cell is 20 % more conductive at the higher level only
    lo[:, 3, 3] = hi[:, 3, 3] = 1e-8  # never loads (off the plate)
    r = equilibrate([lo, hi], [DT, DT], [10.0, 30.0], settle_s=2.0)
    assert r.spread[1, 2] == pytest.approx(0.2, rel=1e-6)  # max/min - 1 of 1/a and 1/(1.2a)
    assert r.gains[1, 2] == pytest.approx(1.0 / (a[1, 2] * np.sqrt(1.2)), rel=1e-6)  # geometric mean
    assert r.flagged[3, 3] and r.flagged.sum() == 1 and np.isnan(r.spread[3, 3])
    others = np.delete(r.gains.ravel(), 15)
    assert r.gains[3, 3] == pytest.approx(np.median(others), rel=1e-6)  # the median of the others


def test_equilibrate_refuses_what_it_cannot_use() -> None:
    g = MODEL.direct(_step(20.0, (3, 3)), DT)
    with pytest.raises(ValueError, match="one level"):
        equilibrate([g, g], DT, [20.0])
    with pytest.raises(ValueError, match="range"):
        equilibrate([g], DT, [300.0])  # beyond p_max = 32 psi
    with pytest.raises(ValueError, match="record longer"):
        equilibrate([g], DT, [20.0], settle_s=60.0)


def test_known_load_recovers_a_known_sensitivity() -> None:
    shape = (6, 6)
    level = 25.0  # kPa on every cell: W = p · A · cells
    g = 2.7 * MODEL.direct(_step(level, shape), DT)
    load_n = level * 1e3 * 4e-4 * 36
    assert known_load(g, DT, load_n, 4.0, settle_s=2.0) == pytest.approx(1 / 2.7, rel=1e-6)
    a = _gains(shape)
    s = known_load(g * a, DT, load_n, 4.0, gains=1 / a, settle_s=2.0)  # the gains first
    assert s == pytest.approx(1 / 2.7, rel=1e-6)
    with pytest.raises(ValueError, match="gains"):
        known_load(g, DT, load_n, 4.0, gains=np.ones((2, 2)))


def test_pressure_calibration_json_round_trip_and_describe(tmp_path) -> None:
    a = _gains((3, 4))
    flagged = np.zeros((3, 4), bool)
    flagged[0, 1] = True
    pc = PressureCalibration(sensor=MODEL, sensor_fitted_utc="2026-11-20T09:00:00Z", sensor_source="run1.txt",
                             gains=a, gains_utc="2026-11-27T10:00:00Z", gain_levels_kpa=(20, 40),
                             gains_flagged=flagged, scale=1.02, scale_utc="2026-11-28T10:00:00Z", scale_load_n=686.0)
    back = PressureCalibration.from_dict(json.loads(json.dumps(pc.to_dict())))
    assert back == pc and back.sensor.params == MODEL.params
    np.testing.assert_array_equal(back.gains, a)
    assert pc.describe() == ("equilibrated 2026-11-27 at 20, 40 kPa (1 cell without a gain: the median); known load "
                             "686 N on 2026-11-28 (scale 1.02); sensor model fitted 2026-11-20 on run1.txt")
    assert PressureCalibration(gains=a, gains_utc="2026-11-27T10:00:00Z", gain_levels_kpa=(20,)).describe() == \
        "equilibrated 2026-11-27 at 20 kPa; nominal sensor model (thesis Table 2.11)"
    assert describe(None).startswith("uncalibrated: nominal sensor model (thesis Table 2.11)")
    assert describe(PressureCalibration()) == describe(None)
    np.testing.assert_allclose(pc.effective(np.ones((2, 3, 4))), np.broadcast_to(a * 1.02, (2, 3, 4)))
    with pytest.raises(ValueError, match="invalid pressure calibration"):
        PressureCalibration.from_dict({"gains": [[1.0, -2.0]]})
    with pytest.raises(ValueError, match="unknown key"):
        PressureCalibration.from_dict({"gain": 1.0})


def test_calibration_file_holds_electronics_pressure_or_both(tmp_path) -> None:
    part = PressureCalibration(gains=_gains((2, 2)), gains_utc="2026-11-27T10:00:00Z", gain_levels_kpa=(20,))
    both = Calibration("BOX7", 6.9e6, 145.0, date="2026-11-27", mat_calibration=part.to_dict())
    both.save(tmp_path / "both.json")
    back = Calibration.load(tmp_path / "both.json")
    assert back == both and PressureCalibration.from_dict(back.mat_calibration) == part
    only = Calibration("BOX7", date="2026-11-27", mat_calibration=part.to_dict())
    only.save(tmp_path / "only.json")
    d = json.loads((tmp_path / "only.json").read_text())
    assert d["version"] == 2 and "r_adc_ohm" not in d and "r_mux_ohm" not in d
    back = Calibration.load(tmp_path / "only.json")
    assert back == only and not back.has_electronics
    with pytest.raises(ValueError, match="no R_adc"):
        Circuit().calibrated(back)
    with pytest.raises(ValueError, match="both"):
        Calibration("BOX7", 6.9e6)
    # a version-1 file (electronics only, as psmat wrote before) still loads
    v1 = Calibration("OLD", 123e3, 140.0, date="2024-01-01").to_dict()
    del v1["pressure"]
    v1["version"] = 1
    (tmp_path / "v1.json").write_text(json.dumps(v1))
    old = Calibration.load(tmp_path / "v1.json")
    assert (old.r_adc, old.r_mux, old.mat_calibration) == (123e3, 140.0, None)


def test_the_chain_applies_the_gains_a_calibrated_uniform_load_reads_uniform() -> None:
    shape = (6, 6)
    a = _gains(shape, seed=9)
    level = 20.0
    leak = 1e-7  # an unloaded cell's conductance (S): the chain subtracts it before the gains
    g = MODEL.direct(_step(level, shape), DT) * a + leak
    counts = Circuit().counts(iecm.forward(g))  # no noise: 12-bit quantisation only
    pc = PressureCalibration(gains=1 / a, gains_utc="2026-11-27T10:00:00Z", gain_levels_kpa=(level,))
    with Processor(shape, mat_calibration=pc, g_rest=leak) as proc:
        cal = proc.push(counts, DT)
    with Processor(shape, g_rest=leak) as proc:
        raw = proc.push(counts, DT)
    held = slice(ONSET + 40, None)
    assert cal.params["pressure_calibration"] == pc.describe()
    assert raw.params["pressure_calibration"].startswith("uncalibrated")
    p = cal.pressure_kpa[held]
    assert np.max(np.abs(p / level - 1)) < 0.02  # every cell at the level, to the ADC's resolution
    spread_raw = np.std(raw.pressure_kpa[held].mean(axis=0)) / level
    assert spread_raw > 0.3  # the gains, left in, are seen
    with pytest.raises(ValueError, match="4x4"):
        Processor((4, 4), mat_calibration=pc)
    with pytest.raises(ValueError, match="own sensor model"):
        Processor(shape, sensor=MODEL, mat_calibration=PressureCalibration(sensor=MODEL))

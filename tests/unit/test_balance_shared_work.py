"""Work the variants share (psmat.balance.variant_traces, scale_factors): each shared result
equals the separate computation it replaces, on a moving load with creep and a missing frame."""

from __future__ import annotations

import numpy as np
import pytest

from psmat import twin
from psmat.balance import cop, scale_factor, scale_factors, subgrids, variant_traces
from psmat.balance._scale import RTOL
from psmat.profile import geometry_for
from psmat.sensor import MPICreep, inverse_over_gaps


def _cop8(pressure, s):
    """CoP (cm) of a choice's own pressure run, placed where its cells are on the 2 cm mat."""
    return cop(pressure, geometry=geometry_for((16, 16), pitch_cm=2.0).subgrid(s.rows0, s.cols0, 2))


@pytest.fixture(scope="module")
def trial():
    scene = twin.quiet_standing(4.0, 50.0, seed=5)  # psi on the 16x16, 2 cm mat, the load moving
    p = np.minimum(scene.pressure_psi, 32.0)
    sensor = MPICreep.thesis()
    g = sensor.direct(p, 0.02) / 0.6 + 1e-12  # a mat more conductive than the model; IECM's floor everywhere
    g[37] = np.nan  # a frame lost on the wire: missing as a whole, as the chain gives it
    periods = np.full(g.shape[0], 0.02)
    periods[::7] = 0.03  # an irregular clock
    weight = 0.9 * float(np.nanmean(np.nansum(p, axis=(1, 2)))) * 6894.757 * 4e-4  # N, not exactly 1/0.6
    return g, periods, weight, sensor


def test_the_chc_of_a_subgrid_is_the_slice_of_the_full_mat(trial) -> None:
    g, periods, _, sensor = trial
    full = inverse_over_gaps(sensor, g, periods)
    for s in subgrids(g, 2.0):
        alone = inverse_over_gaps(sensor, s.images, periods)  # the model run on the 64 cells only
        np.testing.assert_array_equal(full[:, s.rows0::2, s.cols0::2], alone)
    v = variant_traces(g, g, periods, weight_n=None, sensor=sensor, pitch_cm=2.0, names=("CHC-8x8",))
    by_hand = [_cop8(inverse_over_gaps(sensor, s.images, periods), s) for s in subgrids(g, 2.0)]
    np.testing.assert_array_equal(v["CHC-8x8"].cop_cm, np.stack(by_hand))


# two searches for one root from different starts, each within RTOL of it (psmat.balance's tolerance on f)
SAME = 2 * RTOL


def test_shared_scale_factors_are_the_separate_searches(trial) -> None:
    g, periods, weight, sensor = trial
    f_full, f_sub = scale_factors(g, periods, weight, sensor, 4.0)
    assert f_full == pytest.approx(scale_factor(g, periods, weight, sensor, 4.0), rel=SAME, abs=0)
    assert list(f_sub) == [(s.rows0, s.cols0) for s in subgrids(g)]
    for s in subgrids(g):
        alone = scale_factor(s.images, periods, weight, sensor, 16.0)  # each kept cell stands for 4
        assert f_sub[(s.rows0, s.cols0)] == pytest.approx(alone, rel=SAME, abs=0)
    # the four choices see different loads: a test that could not tell them apart would prove nothing
    assert len({round(f, 6) for f in f_sub.values()}) > 1
    assert scale_factors(g, periods, weight, sensor, 4.0, full=False)[0] is None


def test_a_frame_missing_on_some_cells_only_falls_back_to_separate_runs(trial) -> None:
    g, periods, weight, sensor = trial
    h = g.copy()
    h[50, 0, 0] = np.nan  # missing for the (0, 0) choice and the full mat, complete for the other three
    _, f_sub = scale_factors(h, periods, weight, sensor, 4.0)
    for s in subgrids(h):
        assert f_sub[(s.rows0, s.cols0)] == pytest.approx(scale_factor(s.images, periods, weight, sensor, 16.0),
                                                           rel=SAME, abs=0)
    v = variant_traces(h, h, periods, weight_n=weight, sensor=sensor, pitch_cm=2.0, names=("CHC-8x8", "SCHC-8x8"))
    s11 = next(s for s in subgrids(h, 2.0) if (s.rows0, s.cols0) == (1, 1))
    np.testing.assert_array_equal(v["CHC-8x8"].cop_cm[3],
                                  _cop8(inverse_over_gaps(sensor, s11.images, periods), s11))
    assert np.all(np.isfinite(v["CHC-8x8"].cop_cm[3, 50]))  # the choice that lost nothing keeps the frame


class _Counting(MPICreep):
    """The thesis' sensor model, counting its runs over a trial."""

    runs = 0

    def inverse(self, *args, **kwargs):
        type(self).runs += 1
        return super().inverse(*args, **kwargs)


@pytest.mark.parametrize("quiet_cells", [False, True])
def test_schc_pressures_are_the_model_run_at_the_reported_factor(trial, quiet_cells: bool) -> None:
    # the variant's pressures come from its search's last run: they must be what running the model
    # at the reported factor gives, bit for bit, with a lost frame and (here) cells that never conduct
    g, periods, weight, sensor = trial
    if quiet_cells:
        g = g.copy()
        g[:, :3, :] = np.where(np.isnan(g[:, :3, :]), np.nan, 0.0)  # three rows of cells at exactly 0 S
        g[50, 0, 0] = np.nan  # and one of them missing in a frame: the model leaves that frame out
    v = variant_traces(g, g, periods, weight_n=weight, sensor=sensor, pitch_cm=2.0, names=("SCHC", "SCHC-8x8"))
    (f,) = v["SCHC"].factor
    full = cop(inverse_over_gaps(sensor, f * g, periods), geometry=geometry_for((16, 16), pitch_cm=2.0))
    np.testing.assert_array_equal(v["SCHC"].cop_cm[0], full)
    for k, s in enumerate(subgrids(g, 2.0)):
        f8 = v["SCHC-8x8"].factor[k]
        np.testing.assert_array_equal(v["SCHC-8x8"].cop_cm[k], _cop8(inverse_over_gaps(sensor, f8 * s.images, periods), s))
    assert np.isnan(v["SCHC"].cop_cm[0, 37]).all() and np.isfinite(v["SCHC"].cop_cm[0, 36]).all()
    assert np.isnan(v["SCHC"].cop_cm[0, 50]).all() == quiet_cells


def test_the_shared_searches_run_the_model_fewer_times_than_separate_ones(trial) -> None:
    g, periods, weight, _ = trial
    sensor = _Counting.thesis()
    _Counting.runs = 0
    f_full, f_sub = scale_factors(g, periods, weight, sensor, 4.0)
    shared = _Counting.runs
    _Counting.runs = 0
    assert f_full == pytest.approx(scale_factor(g, periods, weight, sensor, 4.0), rel=SAME, abs=0)
    for s in subgrids(g):
        assert f_sub[(s.rows0, s.cols0)] == pytest.approx(scale_factor(s.images, periods, weight, sensor, 16.0),
                                                           rel=SAME, abs=0)
    separate = _Counting.runs
    # the full mat's runs give each sub-grid its forces there: none of the four sub-grid searches runs
    # the model for its two starting points (8 runs), and each starts from the two nearest its root
    assert shared <= separate - 8, (shared, separate)


@pytest.mark.parametrize("case", ["whole", "partial", "quiet"])
def test_the_schc_search_takes_chc_run_as_its_first(trial, case: str) -> None:
    # CHC is the model at f = 1, the SCHC search's first run: computed once when CHC comes first, with
    # the same factors and traces bit for bit. "partial": a frame missing on one cell, which CHC and
    # the search both leave out; "quiet": cells that never conduct, one of them missing in a frame that
    # the search (on the conducting cells) keeps and CHC leaves out: the search runs the model itself
    g, periods, weight, _ = trial
    g = g.copy()
    if case == "quiet":
        g[:, :3, :] = np.where(np.isnan(g[:, :3, :]), np.nan, 0.0)
    if case != "whole":
        g[50, 0, 0] = np.nan
    sensor = _Counting.thesis()
    _Counting.runs = 0
    alone = variant_traces(g, g, periods, weight_n=weight, sensor=sensor, pitch_cm=2.0, names=("SCHC", "SCHC-8x8"))
    runs_alone = _Counting.runs
    _Counting.runs = 0
    chc = inverse_over_gaps(sensor, g, periods)
    assert _Counting.runs == 1
    _Counting.runs = 0
    both = variant_traces(g, g, periods, weight_n=weight, sensor=sensor, pitch_cm=2.0,
                          names=("CHC", "SCHC", "SCHC-8x8"))
    shared = case != "quiet"
    assert _Counting.runs == runs_alone + (0 if shared else 1), (_Counting.runs, runs_alone)
    for name in ("SCHC", "SCHC-8x8"):
        np.testing.assert_array_equal(both[name].factor, alone[name].factor)
        np.testing.assert_array_equal(both[name].cop_cm, alone[name].cop_cm)
    np.testing.assert_array_equal(both["CHC"].cop_cm[0], cop(chc, geometry=geometry_for((16, 16), pitch_cm=2.0)))

"""The sensor model over missing frames (the chain's one policy): psmat.sensor.frame_periods,
steps_over_gaps, inverse_over_gaps, and MPICreep.inverse with one period per sample."""

from __future__ import annotations

import numpy as np
import pytest

from psmat.sensor import MPICreep, frame_periods, inverse_over_gaps, steps_over_gaps


def test_steps_add_up_the_missing_frames_and_carry() -> None:
    steps, since = steps_over_gaps([0.01, 0.01, 0.02, 0.01, 0.01], [True, False, False, True, False], since=0.005)
    np.testing.assert_allclose(steps, [0.015, 0.04])
    assert since == pytest.approx(0.01)


def test_per_sample_steps_equal_the_direct_model_run_with_those_steps() -> None:
    # the direct model stepped sample by sample with varying dt, inverted with the same steps
    m = MPICreep.thesis()
    rng = np.random.default_rng(0)
    p = np.abs(rng.normal(8.0, 3.0, (40, 3)))
    steps = np.r_[np.full(10, 0.01), np.full(5, 0.05), np.full(25, 0.02)]
    state = m.rest_state((3,))
    g = np.concatenate([m.direct(p[a:b], float(steps[a]), state) for a, b in ((0, 10), (10, 15), (15, 40))])
    np.testing.assert_allclose(m.inverse(g, steps), p, rtol=1e-9, atol=1e-9)


def test_a_gap_is_stepped_as_one_long_step() -> None:
    m = MPICreep.thesis()
    p = np.linspace(2.0, 12.0, 30)[:, None] * np.ones((1, 2))
    g = m.direct(p, 0.01)
    g_gap = g.copy()
    g_gap[10:14] = np.nan
    got = inverse_over_gaps(m, g_gap, 0.01)
    assert np.all(np.isnan(got[10:14]))
    # by hand: frames 0-9 at 0.01 s, frame 14 one step of 0.05 s, then 0.01 s again
    state = m.rest_state((2,))
    ref = [m.inverse(g[:10], 0.01, state), m.inverse(g[14:15], 0.05, state), m.inverse(g[15:], 0.01, state)]
    np.testing.assert_array_equal(got[:10], ref[0])
    np.testing.assert_array_equal(got[14:15], ref[1])
    np.testing.assert_array_equal(got[15:], ref[2])


def test_steps_must_match_the_samples() -> None:
    with pytest.raises(ValueError, match="one per sample"):
        MPICreep.thesis().inverse(np.ones((4, 2)) * 1e-3, [0.01, 0.01])


def test_an_empty_stream_is_an_empty_answer_and_leaves_the_state() -> None:
    m = MPICreep.thesis()
    state = m.rest_state((2,))
    assert m.inverse(np.empty((0, 2)), np.empty(0), state).shape == (0, 2)
    np.testing.assert_array_equal(state.y, m.rest_state((2,)).y)
    got = inverse_over_gaps(m, np.full((3, 2), np.nan), 0.01)  # no usable frame: every one NaN
    assert got.shape == (3, 2) and np.all(np.isnan(got))


@pytest.mark.parametrize("dt, match", [([0.01, 0.01], r"one frame period or one per frame \(3,\)"),
                                       ([0.01, 0.0, 0.01], "frame 1 has 0.0"), (-0.01, "dt must be")])
def test_frame_periods_are_one_per_frame_and_positive(dt, match) -> None:
    np.testing.assert_array_equal(frame_periods(0.01, 3), [0.01, 0.01, 0.01])
    np.testing.assert_array_equal(frame_periods([0.01, 0.03, 0.02], 3), [0.01, 0.03, 0.02])
    with pytest.raises(ValueError, match=match):
        frame_periods(dt, 3)


def test_a_clock_with_jitter_is_one_call_bit_identical_to_a_call_per_sample() -> None:
    # A device clock stamps every frame a little differently (µs ticks, crystal error), so no
    # two consecutive steps are equal: the per-sample periods of MPICreep.direct/inverse give
    # exactly what a call per sample gives (one call for the whole stream, not one per run of
    # equal steps — one per frame on such a clock, the study's bottleneck).
    m = MPICreep.thesis()
    rng = np.random.default_rng(1)
    p = np.abs(rng.normal(8.0, 3.0, (200, 4)))
    steps = 0.01 * (1 + 1e-4 * rng.standard_normal(200))
    state = m.rest_state((4,))
    by_sample = np.concatenate([m.direct(p[k:k + 1], float(steps[k]), state) for k in range(200)])
    np.testing.assert_array_equal(m.direct(p, steps), by_sample)
    state = m.rest_state((4,))
    inv_by_sample = np.concatenate([m.inverse(by_sample[k:k + 1], float(steps[k]), state) for k in range(200)])
    np.testing.assert_array_equal(m.inverse(by_sample, steps), inv_by_sample)
    np.testing.assert_allclose(inv_by_sample, p, rtol=1e-9)


@pytest.mark.parametrize("dt, match", [(np.full(3, 0.01), "one per sample"), (np.array([0.01, -0.01] * 5), "positive"),
                                       (np.full((10, 1), 0.01), "one per sample"), (float("nan"), "positive")])
def test_bad_periods_are_one_clear_error(dt, match) -> None:
    with pytest.raises(ValueError, match=match):
        MPICreep.thesis().direct(np.ones((10, 2)), dt)

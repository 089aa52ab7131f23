"""psmat.sensor.stepping: the sensor model over missing frames (the chain's one policy)."""

from __future__ import annotations

import numpy as np
import pytest

from psmat.sensor import MPICreep, inverse_over_gaps, inverse_stepped, steps_over_gaps


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
    np.testing.assert_allclose(inverse_stepped(m, g, steps), p, rtol=1e-9, atol=1e-9)


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
    with pytest.raises(ValueError, match="one value per sample"):
        inverse_stepped(MPICreep.thesis(), np.ones((4, 2)) * 1e-3, [0.01, 0.01])

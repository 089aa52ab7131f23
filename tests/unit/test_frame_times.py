"""psmat.io.frame_times and run_end_period_s: frames that reached the host in one serial chunk
(one arrival time) spread back from it, checked against times worked out by hand."""

from __future__ import annotations

import numpy as np
import pytest

from psmat.io import frame_times, run_end_period_s


def test_runs_without_a_device_clock_are_spread_back_by_the_period() -> None:
    # lines sent every 0.5 s from 0; read two at a time, at the second's arrival
    host = [0.5, 0.5, 1.5, 1.5, 2.5, 2.5]
    assert run_end_period_s(host) == pytest.approx(0.5, abs=1e-15)  # (2.5 - 0.5) / (5 - 1)
    # the span of all frames over their count would say (2.5 - 0.5) / 5 = 0.4 s
    np.testing.assert_allclose(frame_times(host, period_s=0.5), [0.0, 0.5, 1.0, 1.5, 2.0, 2.5], atol=1e-12)
    # frames alone in their run stay at their arrival
    np.testing.assert_array_equal(frame_times([1.0, 2.0, 3.0], period_s=0.5), [1.0, 2.0, 3.0])


def test_a_run_never_reaches_back_past_the_run_before() -> None:
    # three frames at 1.1 would go back to 0.1 s with a 0.5 s period, before the frame at 1.0:
    # they are spread evenly over (1.0, 1.1] instead
    out = frame_times([1.0, 1.1, 1.1, 1.1], period_s=0.5)
    np.testing.assert_allclose(out, [1.0, 1.0 + 0.1 / 3, 1.0 + 0.2 / 3, 1.1], atol=1e-12)
    assert np.all(np.diff(out) > 0)


def test_a_run_spread_by_the_device_clock_never_reaches_back_either() -> None:
    # a frame that arrived late (0.3142 s), then two frames 10 ms apart on the device that arrived at 0.3146 s:
    # by the device clock the first of them would be at 0.3046 s, before the late one; spread evenly after it
    host = [0.2849, 0.3142, 0.3146, 0.3146]
    dev = [0, 10_000, 20_000, 30_000]
    out = frame_times(host, dev)
    np.testing.assert_allclose(out, [0.2849, 0.3142, 0.3142 + 0.0004 / 2, 0.3146], atol=1e-12)
    assert np.all(np.diff(out) > 0)
    # one that does not reach back keeps the device clock's spacing
    np.testing.assert_allclose(frame_times([0.28, 0.3146, 0.3146], [0, 20_000, 30_000]), [0.28, 0.3046, 0.3146],
                               atol=1e-12)


def test_a_run_of_the_next_call_never_reaches_back_past_the_last_one() -> None:
    # the same two calls: a late frame at 0.3142 s ends one chunk, the next chunk's run arrives at 0.3146 s
    first = frame_times([0.2849, 0.3142], [0, 10_000])
    second = frame_times([0.3146, 0.3146], [20_000, 30_000], after=float(first[-1]))
    np.testing.assert_allclose(second, [0.3142 + 0.0004 / 2, 0.3146], atol=1e-12)
    np.testing.assert_allclose(frame_times([0.3146, 0.3146], [20_000, 30_000]), [0.3046, 0.3146], atol=1e-12)


def test_the_device_clock_comes_before_the_period() -> None:
    host = [10.0, 10.0, 10.0, 11.0, 11.0]
    dev = [0, 10_000, 20_000, -1, 50_000]  # the second run has an unknown device time
    np.testing.assert_allclose(frame_times(host, dev, period_s=0.1), [9.98, 9.99, 10.0, 10.9, 11.0], atol=1e-12)


def test_bad_periods_and_undefined_estimates() -> None:
    for bad in (0.0, -0.5, float("nan"), float("inf")):
        with pytest.raises(ValueError, match="period_s"):
            frame_times([1.0, 1.0], period_s=bad)
    assert np.isnan(run_end_period_s([2.0, 2.0, 2.0]))  # one run: no two arrivals to measure
    assert np.isnan(run_end_period_s([2.0]))


def test_frames_without_a_time_are_left_out_of_both() -> None:
    nan = float("nan")
    # the finite arrivals 0.5, 0.5, 1.5, 1.5: run ends 0.5 (frame 1) and 1.5 (frame 3), 2 frames apart
    assert run_end_period_s([0.5, 0.5, nan, 1.5, 1.5]) == pytest.approx(0.5, abs=1e-15)
    # a frame without a time stays so, and the run after it reaches back to the last frame with one
    out = frame_times([1.0, nan, 1.2, 1.2], period_s=0.5)
    assert np.isnan(out[1])
    np.testing.assert_allclose(out[[0, 2, 3]], [1.0, 1.1, 1.2], atol=1e-12)


def test_clock_restarts_by_hand() -> None:
    from psmat.io import clock_restarts

    # stamps 0, 10, (unknown), 20 ms; then the box restarts at 1 ms; an unknown; then 2 ms
    assert clock_restarts([0, 10_000, -1, 20_000, 1_000, -1, 2_000]).tolist() == [4]
    assert clock_restarts([0, 10_000, 10_000, 20_000]).tolist() == []  # a stamp repeated is no restart
    assert clock_restarts([-1, -1]).tolist() == []

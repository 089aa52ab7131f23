"""The recorded times a playback releases frames at (psmat.acquire._playback.recorded_times).

Expected values are worked out by hand from the recorded clocks."""

from __future__ import annotations

import numpy as np
import pytest

from psmat.acquire._playback import recorded_times

NAN = float("nan")


def test_the_device_clock_paces_when_it_runs_forwards() -> None:
    host = np.array([10.0, 10.0, 10.05, 10.05])          # chunks share a host time
    dev = np.array([2_000_000, 2_010_000, 2_020_000, 2_030_000])
    t, clock = recorded_times(host, dev)
    assert clock == "device_time_us"
    np.testing.assert_array_equal(t, [0.0, 0.01, 0.02, 0.03])


def test_an_unknown_device_time_is_interpolated_between_its_neighbours() -> None:
    dev = np.array([-1, 1_000_000, -1, -1, 1_030_000, -1])  # invalid rows carry -1
    t, clock = recorded_times(np.full(6, NAN), dev)
    assert clock == "device_time_us"
    # index 0 held at the first known time, 2 and 3 a third of the way each, 5 held at the last
    np.testing.assert_allclose(t, [0.0, 0.0, 0.01, 0.02, 0.03, 0.03], atol=1e-12)


def test_a_device_clock_that_goes_back_gives_way_to_the_host_times() -> None:
    host = np.array([5.0, 5.1, 5.2, 5.3])
    dev = np.array([900_000, 1_000_000, 10_000, 20_000])  # the box restarted
    t, clock = recorded_times(host, dev)
    assert clock == "host_time_s"
    np.testing.assert_allclose(t, [0.0, 0.1, 0.2, 0.3])


def test_missing_host_times_are_interpolated_and_never_go_back() -> None:
    host = np.array([NAN, 3.0, NAN, 3.4, 3.3, NAN])  # a lost chunk, a step back
    t, clock = recorded_times(host, None)
    assert clock == "host_time_s"
    np.testing.assert_allclose(t, [0.0, 0.0, 0.2, 0.4, 0.4, 0.4])


@pytest.mark.parametrize("rate, clock, expected", [(50.0, "rate", [0.0, 0.02, 0.04]), (None, "none", [0, 0, 0])])
def test_without_any_time_the_rate_or_nothing(rate, clock, expected) -> None:
    t, got = recorded_times(np.full(3, NAN), np.full(3, -1), rate)
    assert got == clock
    np.testing.assert_allclose(t, expected)


def test_no_frames() -> None:
    t, clock = recorded_times(np.zeros(0), None)
    assert t.shape == (0,) and clock == "none"

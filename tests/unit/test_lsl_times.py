"""The clock arithmetic of the LSL support, by hand: the host clock against LSL's, and frames of
one serial chunk spread by the device clock. No LSL library needed (the clocks are injected)."""

from __future__ import annotations

import numpy as np
import pytest

from psmat.acquire import HostClock, LslClock, frame_times


class Ticker:
    """A clock that reads ``start``, then ``start + step``, ... (s)."""

    def __init__(self, start: float, step: float) -> None:
        self.t = start - step
        self.step = step

    def __call__(self) -> float:
        self.t += self.step
        return self.t


def test_the_offset_is_host_minus_the_middle_of_the_tightest_bracket() -> None:
    # monotonic clock shared: the host clock is wall0 + (mono - mono0) = 1000 + (mono - 5)
    mono = Ticker(5.0, 0.001)
    host = HostClock(wall=lambda: 1000.0, mono=mono)
    # LSL's clock reads 50.000, 50.010 around the host reading taken at mono 5.001 -> host 1000.001
    lsl = iter([50.000, 50.010])
    clock = LslClock(host, local_clock=lambda: next(lsl), readings=1)
    assert clock.offset_s == pytest.approx(1000.001 - 50.005, abs=1e-9)
    assert clock.uncertainty_s == pytest.approx(0.005, abs=1e-9)
    assert clock.to_lsl(1000.5) == pytest.approx(1000.5 - 949.996, abs=1e-9)
    assert clock.to_host(clock.to_lsl(1234.25)) == pytest.approx(1234.25, abs=1e-9)


def test_of_several_brackets_the_tightest_decides() -> None:
    host = HostClock(wall=lambda: 0.0, mono=iter([0.0, 10.0, 20.0, 30.0]).__next__)
    # brackets (1, 3) around host 10 -> offset 8, width 2; (20.5, 20.7) around host 20 -> offset -0.6,
    # width 0.2; (40, 45) around host 30 -> width 5
    lsl = iter([1.0, 3.0, 20.5, 20.7, 40.0, 45.0])
    clock = LslClock(host, local_clock=lambda: next(lsl), readings=3)
    assert clock.offset_s == pytest.approx(20.0 - 20.6, abs=1e-12)
    assert clock.uncertainty_s == pytest.approx(0.1, abs=1e-12)


def test_frames_of_one_chunk_are_spread_back_by_the_device_clock() -> None:
    host = [10.0, 10.0, 10.0, 10.05, 10.08, 10.08]
    dev = [0, 10_000, 20_000, 30_000, 40_000, 50_000]
    # the run at 10.0 ends at its arrival, 10 ms apart; 10.05 alone; the run at 10.08 too
    np.testing.assert_allclose(frame_times(host, dev), [9.98, 9.99, 10.0, 10.05, 10.07, 10.08], atol=1e-12)


def test_without_a_usable_device_clock_host_times_stay() -> None:
    host = [10.0, 10.0, 10.0, 11.0, 11.0]
    dev = [0, -1, 20_000, 50_000, 40_000]  # an unknown time in one run, a clock going back in the other
    np.testing.assert_array_equal(frame_times(host, dev), host)
    np.testing.assert_array_equal(frame_times(host), host)
    with pytest.raises(ValueError, match="shape"):
        frame_times(host, dev[:3])

"""psmat.balance.align: a known lag between a platform trace and a mat trace (docs/spec.md §7, §9)."""

from __future__ import annotations

import numpy as np
import pytest

from psmat.balance import align, find_platform_axes, orient_platform
from psmat.io import bds_trial


@pytest.fixture(scope="module")
def platform():
    rec = bds_trial(3)  # real human sway, 100 Hz, 60 s
    return rec.t, rec.cop_cm


def mat_view(platform, lag_s: float, rate_hz: float, start: float, seconds: float, gain=0.6, offset=(3.0, 7.0),
             noise_cm=0.0, seed=0):
    """What a mat on its own clock sees: cop(t) = gain · cop_ref(t + lag_s) + offset (+ noise)."""
    t_ref, c_ref = platform
    t = start + np.arange(0.0, seconds, 1.0 / rate_hz)
    c = np.column_stack([np.interp(t + lag_s, t_ref, c_ref[:, k]) for k in range(2)])
    c = gain * c + np.asarray(offset) + np.random.default_rng(seed).normal(0.0, noise_cm, c.shape)
    return t, c


def test_recovers_a_clock_offset_at_another_rate_below_one_sample(platform) -> None:
    # the mat's clock reads 1000.0 s when the platform's reads 2.3137 s: lag = -997.6863 s
    lag = 2.3137 - 1000.0
    t, c = mat_view(platform, lag, rate_hz=40.0, start=1000.0, seconds=50.0)
    a = align(*platform, t, c)
    assert a.lag_s == pytest.approx(lag, abs=1e-3)  # a tenth of a 100 Hz sample
    assert a.r > 0.999 and not a.manual
    assert a.fs_hz == pytest.approx(100.0)
    np.testing.assert_allclose(a.to_ref_time([1000.0]), [2.3137], atol=1e-3)


def test_noise_gain_and_a_faster_mat(platform) -> None:
    lag = -0.4567
    t, c = mat_view(platform, lag, rate_hz=165.0, start=5.0, seconds=40.0, gain=0.3, offset=(-2.0, 11.0),
                    noise_cm=0.02, seed=4)
    a = align(*platform, t, c)
    assert a.lag_s == pytest.approx(lag, abs=3e-3)
    assert a.fs_hz == pytest.approx(165.0, rel=1e-6)
    # white noise σ on a signal of SD s caps the correlation at s / sqrt(s² + σ²)
    t_ref, c_ref = platform
    s = 0.3 * np.array([np.interp(t + lag, t_ref, c_ref[:, k]) for k in range(2)]).std(axis=1)
    expected = s / np.hypot(s, 0.02)
    assert a.r_ml == pytest.approx(expected[0], abs=0.02)
    assert a.r_ap == pytest.approx(expected[1], abs=0.02)


def test_manual_override_reports_the_correlation_there(platform) -> None:
    lag = 1.25
    t, c = mat_view(platform, lag, rate_hz=50.0, start=0.0, seconds=30.0)
    right = align(*platform, t, c, lag_s=lag)
    wrong = align(*platform, t, c, lag_s=lag + 0.5)
    assert right.manual and right.lag_s == lag
    assert right.r == pytest.approx(1.0, abs=1e-3)
    assert wrong.r < right.r - 0.01


def test_max_lag_limits_the_search(platform) -> None:
    lag = 3.0
    t, c = mat_view(platform, lag, rate_hz=50.0, start=0.0, seconds=40.0)
    assert align(*platform, t, c, max_lag_s=4.0).lag_s == pytest.approx(lag, abs=1e-3)
    # the window is around what the clocks say (t_ref[0] - t[0] = 0.01 s), plus the sub-sample refinement
    clocks = platform[0][0] - t[0]
    assert abs(align(*platform, t, c, max_lag_s=1.0).lag_s - clocks) <= 1.0 + 1 / 100.0


@pytest.mark.parametrize("what, match", [("flat", "does not move"), ("short", "at least 8"),
                                         ("shape", "shape"), ("order", "increase")])
def test_bad_input_is_one_clear_error(platform, what, match) -> None:
    t, c = mat_view(platform, 0.0, rate_hz=50.0, start=0.0, seconds=20.0)
    if what == "flat":
        c[:, 1] = 1.0
    elif what == "short":
        t, c = t[:5], c[:5]
    elif what == "shape":
        c = c[:, :1]
    else:
        t = t[::-1].copy()
    with pytest.raises(ValueError, match=match):
        align(*platform, t, c)


def test_manual_lag_without_overlap_is_refused(platform) -> None:
    t, c = mat_view(platform, 0.0, rate_hz=50.0, start=0.0, seconds=20.0)
    with pytest.raises(ValueError, match="do not overlap"):
        align(*platform, t, c, lag_s=500.0)


def test_a_quiet_start_does_not_pull_the_peak_a_cycle_away() -> None:
    # The Rotation trial (thesis §3.2.1): quiet standing, then circles at about half a cycle
    # per second. Scored on the whole traces' standardisation, a lag that drops the quiet start
    # and matches the next cycle beat the true lag; the correlation on each lag's own overlap
    # peaks at the true one.
    rng = np.random.default_rng(3)
    fs = 100.0
    t_ref = np.arange(0.0, 30.0, 1 / fs)
    on = np.clip((t_ref - 6.0) / 2.0, 0.0, 1.0)  # quiet for 6 s, circles ramp in over 2 s
    w = 2 * np.pi * 0.45
    ref = np.column_stack([3.0 * on * np.cos(w * t_ref), 3.0 * on * np.sin(w * t_ref)])
    ref += 0.05 * rng.standard_normal(ref.shape)
    lag = 0.8
    t = np.arange(0.0, 26.0, 1 / 50.0)  # the mat: its own clock and rate, smaller and offset
    c = np.column_stack([np.interp(t + lag, t_ref, ref[:, k]) for k in range(2)]) * 0.7 + [5.0, -2.0]
    a = align(t_ref, ref, t, c)
    assert a.lag_s == pytest.approx(lag, abs=0.005)
    assert a.r > 0.99


@pytest.mark.parametrize("rate_hz, lag, gain, offset", [(10.0, 3.4321, 0.45, (1.5, -4.0)), (100.0, -12.3456, 0.8, (-6.0, 2.5))])
def test_the_thesis_rates_with_gains_and_offsets(platform, rate_hz, lag, gain, offset) -> None:
    # thesis §3.2.1: the first prototype, the commercial mat and the platform at 10 Hz; the
    # second prototype at 100 Hz. The platform is decimated to the mat's rate when it is 10 Hz.
    t_ref, c_ref = platform
    step = int(round(100.0 / rate_hz))
    ref = (t_ref[::step], c_ref[::step])
    # the mat's 45 s lie inside the platform's 60 s: from 5 s on the platform's clock
    t, c = mat_view(platform, lag, rate_hz=rate_hz, start=5.0 - lag, seconds=45.0, gain=gain, offset=offset)
    a = align(*ref, t, c)
    # below one sample: a tenth of the 10 Hz period, or of the 100 Hz one
    assert a.lag_s == pytest.approx(lag, abs=0.1 / rate_hz)
    assert a.r > 0.99


def test_orient_platform_by_hand() -> None:
    c = np.array([[1.0, 2.0], [3.0, -4.0]])
    assert orient_platform(c).tolist() == c.tolist()
    assert orient_platform(c, "x,-y").tolist() == [[1.0, -2.0], [3.0, 4.0]]
    assert orient_platform(c, "-y,x").tolist() == [[-2.0, 1.0], [4.0, 3.0]]
    assert orient_platform(c, "y,-x").tolist() == [[2.0, -1.0], [-4.0, -3.0]]
    with pytest.raises(ValueError, match="platform axes must be one of"):
        orient_platform(c, "x,z")


@pytest.mark.parametrize("axes", ["x,-y", "-x,y", "y,x", "-y,x"])
def test_a_platform_whose_axes_lie_otherwise_aligns_poorly_and_its_axes_are_found(platform, axes) -> None:
    """A platform whose A-P axis points the other way from the mat's: that component correlates at about
    -1 and cancels the other at the true lag, so the alignment is poor. Read with the axes that undo
    it, it is the mat's view again (the same lag)."""
    lag = 0.731
    t, c = mat_view(platform, lag, rate_hz=50.0, start=10.0, seconds=40.0)
    t_ref, c_ref = platform
    # the file as the platform wrote it: the inverse of orient_platform(., axes)
    undo = {"x,-y": "x,-y", "-x,y": "-x,y", "y,x": "y,x", "-y,x": "y,-x"}[axes]
    written = orient_platform(c_ref, undo)
    np.testing.assert_array_equal(orient_platform(written, axes), c_ref)
    assert align(t_ref, written, t, c).poor
    found, a = find_platform_axes(t_ref, written, t, c)
    assert found == axes and not a.poor and a.lag_s == pytest.approx(lag, abs=2e-3) and a.r > 0.999
    # another recording's sway (another BDS trial) aligns under no orientation
    other = bds_trial(11)
    assert find_platform_axes(other.t, other.cop_cm, t, c) is None

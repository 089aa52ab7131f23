"""psmat.posture.dataset: a posture study folder → Recordings (IECM g averaged over each IMU sample)."""

from __future__ import annotations

import numpy as np
import pytest

from psmat.posture.dataset import mean_over_samples


def test_mean_over_samples_by_hand() -> None:
    # 100 Hz source, 10 Hz destination: sample k averages the frames within ±50 ms of it
    t_src = np.arange(100) * 0.01 + 0.005  # frames mid-way between edges: no rounding at the borders
    x = np.arange(100, dtype=float)[:, None] * np.array([1.0, -2.0])
    t_dst = np.array([0.2, 0.3, 0.4])
    mean, n = mean_over_samples(t_src, x, t_dst)
    # sample 0.2: frames 15..24 (t in [0.15, 0.25)) → mean index 19.5
    assert list(n) == [10, 10, 10]
    np.testing.assert_allclose(mean[:, 0], [19.5, 29.5, 39.5])
    np.testing.assert_allclose(mean[:, 1], -2 * mean[:, 0])


def test_mean_over_samples_skips_nan_frames_and_marks_empty_samples() -> None:
    t_src = np.array([0.0, 0.1, 0.2, 0.3])
    x = np.array([[1.0], [np.nan], [3.0], [5.0]])
    mean, n = mean_over_samples(t_src, x, np.array([0.0, 0.25, 1.0]))
    # intervals: [-0.125, 0.125) holds frames 0 and 1 (NaN) → frame 0 only; [0.125, 0.625) frames 2
    # and 3; [0.625, 1.375) none
    assert list(n) == [1, 2, 0]
    assert mean[0, 0] == 1.0 and mean[1, 0] == 4.0 and np.isnan(mean[2, 0])


def test_mean_over_samples_rejects_unordered_times() -> None:
    with pytest.raises(ValueError, match="non-decreasing"):
        mean_over_samples(np.array([0.0, 0.2, 0.1]), np.zeros((3, 1)), np.array([0.1]))
    with pytest.raises(ValueError, match="increasing"):
        mean_over_samples(np.array([0.0, 0.1]), np.zeros((2, 1)), np.array([0.1, 0.1]))

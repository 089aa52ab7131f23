"""A posture session whose IMU samples reached the host two at a time (one serial chunk, one
arrival time: a busy host, a USB adapter's latency timer) gives the recording it gives without
the bursts (simulation). The reader stamps every sample of a chunk with the chunk's arrival;
before, equal IMU times made ``session_recording`` refuse the session ("destination times must be
increasing") and ``load_posture_study`` leave it out."""

from __future__ import annotations

import numpy as np
import pytest

from psmat.io import SessionWriter, load_session
from psmat.posture.data import session_recording

SECONDS = 12.0


@pytest.fixture(scope="module")
def session(tmp_path_factory):
    from psmat.synth import simulate_posture_study

    root = simulate_posture_study(tmp_path_factory.mktemp("bursts") / "study", subjects=1, days=1, seed=5,
                                  duration_s=SECONDS)
    return next((root / "sessions").glob("*.h5")), root


def _with_imu_bursts(src, dst):
    """``src`` rewritten with the IMU samples 2k and 2k + 1 stamped at 2k + 1's arrival."""
    s = load_session(src)
    imu = s.streams["imu"]
    host = np.asarray(imu.host_time_s, np.float64).copy()
    host[0:-1:2] = host[1::2][: host[0:-1:2].size]
    with SessionWriter(dst, s.frame_shape, s.device, calibration=s.calibration, metadata=s.metadata,
                       profile=s.profile) as w:
        st = w.add_stream("imu", kind="imu", shape=imu.counts.shape[1:], device=imu.device)
        st.append(imu.counts, host, imu.valid, seq=imu.seq, device_time_us=imu.device_time_us)
        w.append(s.counts, s.host_time_s, s.valid, seq=s.seq, device_time_us=s.device_time_us)
    return dst, host


def test_imu_samples_that_arrived_in_pairs_give_the_same_recording(session, tmp_path) -> None:
    src, root = session
    cal = next((root / "calibration").glob("*.json"))
    plain = session_recording(src, calibration=cal)
    path, host = _with_imu_bursts(src, tmp_path / "bursts.h5")
    assert np.sum(np.diff(host) == 0) > 10  # the bursts are there
    burst = session_recording(path, calibration=cal)
    # the same samples, each spread back from its pair's arrival by the IMU's own clock: off its own
    # arrival by the difference of two USB latencies the simulation draws (1 ms + an exponential
    # 1 ms each; this seed's largest difference is 6.8 ms), the second sample of a pair not at all
    assert burst.t_s.shape == plain.t_s.shape
    np.testing.assert_array_equal(burst.angles_rad, plain.angles_rad)
    assert np.max(np.abs(burst.t_s - plain.t_s)) < 0.01
    np.testing.assert_array_equal(burst.t_s[1::2], plain.t_s[1::2])
    # each sample averages the mat frames of its interval: the same frames but where an edge moved
    # past one of them (frames every 10 ms, edges moved by a few ms)
    rel = np.abs(burst.image.sum(axis=(1, 2)) / plain.image.sum(axis=(1, 2)) - 1)
    assert np.median(rel) < 1e-6 and np.max(rel) < 0.05

"""psmat.posture.load_posture_study: a posture study folder → Recordings (IECM g averaged over each IMU sample)."""

from __future__ import annotations

import numpy as np
import pytest

from psmat.posture.data import mean_over_samples


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


# ------------------------------------------------------------------ a simulated study (simulation)
SECONDS = 20.0


@pytest.fixture(scope="module")
def study(tmp_path_factory):
    from psmat.synth import simulate_posture_study

    return simulate_posture_study(tmp_path_factory.mktemp("posture") / "study", subjects=2, days=1, seed=11,
                                  duration_s=SECONDS)


@pytest.fixture(scope="module")
def loaded(study):
    from psmat.posture import load_posture_study

    return load_posture_study(study, workers=2, progress=False)


def _truth(study, stem: str):
    import json

    z = np.load(study / "truth" / "sessions" / f"{stem}.npz")
    noise = json.loads((study / "truth" / "study.json").read_text())["imu_device"]["noise_deg"]
    return z, np.asarray(noise)


def test_a_session_gives_the_imu_pitch_and_the_mat_load_on_one_time_base(study, loaded) -> None:
    r = loaded.recordings[0]
    z, noise = _truth(study, "P01_d1")
    assert r.subject == "P01" and r.day == 1 and r.image.shape[1:] == (16, 16)
    # the IMU samples, on the host clock, are the truth's samples
    k = np.searchsorted(z["imu_t_host_s"], r.t_s)
    np.testing.assert_allclose(z["imu_t_host_s"][k], r.t_s)
    # pitch = what a perfect sensor reads + drift + BNO055 noise (truth/study.json) + 1/16 deg steps
    read = z["angles_true_deg"][k, :, 2] + z["drift_deg"][k, :, 2]
    err = np.rad2deg(r.angles_rad) - read
    assert np.all(np.abs(err) < 6 * noise + 1 / 32)
    assert np.all(err.std(axis=0) < 1.5 * noise)
    # ~10 mat frames (100 Hz) averaged per 10 Hz sample, and their summed g follows the seat force
    assert 9.5 < r.meta["mat_frames_per_sample"] < 10.5
    force, _ = mean_over_samples(z["mat_t_host_s"], z["force_n"][:, None], r.t_s)
    assert np.corrcoef(force[:, 0], r.image.sum(axis=(1, 2)))[0, 1] > 0.95
    assert np.all(r.image >= 0)


def test_a_study_is_cached_per_session_and_recomputes_only_what_changed(study, loaded) -> None:
    from psmat.posture import load_posture_study

    first = loaded
    assert first.problems == [] and [r.subject for r in first.recordings] == ["P01", "P02"]
    again = load_posture_study(study, workers=1, progress=False)
    assert again.computed == 0
    for a, b in zip(first.recordings, again.recordings):
        np.testing.assert_array_equal(a.image, b.image)
        np.testing.assert_array_equal(a.angles_rad, b.angles_rad)
    # a changed calibration of P02's box reruns P02 only
    cal = next((study / "calibration").glob("*P02*.json"))
    cal.write_text(cal.read_text() + "\n")
    changed = load_posture_study(study, workers=1, progress=False)
    assert changed.computed == 1
    # the file renamed as Windows would not tell apart ("sim11-p02.json" for the box "SIM11-P02"): still
    # its box's calibration, the same inputs, nothing computed again (before: no calibration file)
    cal.rename(cal.with_name(cal.name.lower()))
    try:
        renamed = load_posture_study(study, workers=1, progress=False)
        assert renamed.problems == [] and renamed.computed == 0
    finally:
        cal.with_name(cal.name.lower()).rename(cal)
    # two spellings, neither the box's exactly: which is its own is not known, and the run says so
    # (before: neither, silently, and the session's stored calibration used)
    twin, other = cal.with_name(cal.name.lower()), cal.with_name(cal.name.capitalize())
    twin.write_bytes(cal.read_bytes())
    cal.rename(other)
    try:
        both = load_posture_study(study, workers=1, progress=False)
    finally:
        twin.unlink()
        other.rename(cal)
    assert both.problems == [f"P02_d1: 2 calibration files for box {cal.stem}: {other.name}, {twin.name}; which one "
                             "belongs to it is not known: keep one (neither is used)"]


def test_a_mat_recorded_apart_is_aligned_to_its_imu_log(study, loaded, tmp_path) -> None:
    from psmat.io import SessionWriter, load_session, write_imu_log
    from psmat.posture import load_posture_study

    s = load_session(study / "sessions" / "P02_d1.h5")
    mat_only = tmp_path / "P02_d1.h5"
    with SessionWriter(mat_only, s.frame_shape, device=s.device, metadata=s.metadata) as w:  # no calibration
        w.append(s.counts, s.host_time_s, s.valid, seq=s.seq, device_time_us=s.device_time_us)
    imu = s.streams["imu"]
    log = tmp_path / "P02_d1.txt"
    write_imu_log(log, imu.counts)  # the thesis' log: no time column, sample k at k / 10 Hz
    # a study folder finds the log beside the session as imu/<stem>.txt (docs/spec.md §6)
    apart = tmp_path / "apart"
    (apart / "sessions").mkdir(parents=True)
    (apart / "imu").mkdir()
    mat_only.rename(apart / "sessions" / mat_only.name)
    log.rename(apart / "imu" / log.name)
    # a Mac copying the study to a USB stick writes an AppleDouble "._NAME" beside each file: no data
    # (before: an unreadable session among the problems)
    (apart / "sessions" / "._P02_d1.h5").write_bytes(b"\x00\x05\x16\x07\x00\x02\x00\x00Mac OS X" + bytes(4000))
    # a study with calibrations, none of them this box's, and a session that stores none: said, as in a
    # balance study (before: the nominal circuit, unsaid)
    (apart / "calibration").mkdir()
    p01 = next((study / "calibration").glob("*P01*.json"))
    (apart / "calibration" / p01.name).write_bytes(p01.read_bytes())
    found = load_posture_study(apart, workers=1, progress=False)
    box = s.device["serial"]
    assert found.problems == [f"P02_d1: no calibration/{box}.json for its box {box!r}, and the session stores "
                              "none: the profile's nominal circuit is used"]
    assert len(found.recordings) == 1
    r = found.recordings[0]
    # t_imu = t_mat + lag: the log's 0 is the IMU's first sample, at host time imu.host_time_s[0]
    assert r.meta["aligned_by"].startswith("cross-correlation")
    assert abs(r.meta["lag_s"] - (-imu.host_time_s[0])) < 0.1  # one IMU sample
    together = loaded.recordings[1]
    n = min(r.n_samples, together.n_samples)
    shift = int(np.argmin(np.abs(together.t_s - r.t_s[0])))
    np.testing.assert_allclose(r.angles_rad[:n - shift], together.angles_rad[shift:n], atol=np.deg2rad(1e-4))
    # the log as a Windows tool names it ("P02_D1.TXT") is still the session's (before: "no IMU data"),
    # and a log left in a subfolder is said, not skipped unsaid
    (apart / "imu" / log.name).rename(apart / "imu" / "P02_D1.TXT")
    (apart / "imu" / "old").mkdir()
    write_imu_log(apart / "imu" / "old" / "P02_d2.txt", imu.counts[:10])
    again = load_posture_study(apart, workers=1, progress=False)
    assert again.problems == ["1 file(s) in subfolders are not read (imu/old/P02_d2.txt): a study's files sit "
                              "directly in sessions/ and imu/", found.problems[0]]
    assert again.computed == 0 and len(again.recordings) == 1  # the same log's bytes: read from the cache
    np.testing.assert_array_equal(again.recordings[0].angles_rad, r.angles_rad)


def test_a_session_from_a_narrower_adc_is_refused_with_the_reason(study, tmp_path) -> None:
    """A cushion read by a 10-bit board under its 12-bit profile: every empty cell would read as a loaded
    one and the network would learn from that (before: unsaid). The session is refused in one line, before
    its IMUs are looked for."""
    from psmat.io import SessionWriter, load_session
    from psmat.posture.data import session_recording

    s = load_session(study / "sessions" / "P01_d1.h5")
    ten = tmp_path / "P01_d1.h5"
    with SessionWriter(ten, s.frame_shape, device=s.device, calibration=s.calibration, metadata=s.metadata) as w:
        w.append((s.counts >> 2).astype(np.uint16), s.host_time_s, s.valid, seq=s.seq, device_time_us=s.device_time_us)
    with pytest.raises(ValueError, match=r"^P01_d1.h5: no count above 10\d\d in \d+ valid frames, where an empty cell "
                                         r"reads \d+ of 4095 \(12 bits\): is the board's ADC 10-bit\?"):
        session_recording(ten)

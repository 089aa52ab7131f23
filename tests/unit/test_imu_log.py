"""psmat.io.load_imu_log / write_imu_log: the thesis' spine-IMU text logs (docs/spec.md §6: one line per
sample, five decimals, spaces)."""

from __future__ import annotations

import re

import numpy as np
import pytest

from psmat.io import ImuLog, load_imu_log, write_imu_log
from psmat.io import SessionFormatError

FIVE_DECIMALS = re.compile(r"^-?\d+\.\d{5}$")


def angles(T: int, seed: int = 0) -> np.ndarray:
    """BNO055-like Euler angles: heading [0, 360), roll and pitch within ±90 degrees."""
    rng = np.random.default_rng(seed)
    a = rng.uniform(-90.0, 90.0, (T, 5, 3))
    a[:, :, 0] = rng.uniform(0.0, 360.0, (T, 5))
    return a


def test_round_trip_thesis_layout_five_decimals_and_a_10_hz_time_base(tmp_path) -> None:
    a = angles(37)
    path = write_imu_log(tmp_path / "imu.txt", a)
    lines = path.read_text().splitlines()
    assert len(lines) == 37
    for ln in lines:
        fields = ln.split(" ")
        assert len(fields) == 15 and all(FIVE_DECIMALS.match(f) for f in fields)
    log = load_imu_log(path)
    assert isinstance(log, ImuLog) and log.meta["layout"] == "angles"
    assert log.angles_deg.shape == (37, 5, 3) and log.valid.all()
    np.testing.assert_allclose(log.angles_deg, a, rtol=0, atol=5e-6)  # half of the fifth decimal
    np.testing.assert_allclose(log.t_s, np.arange(37) * 0.1)
    np.testing.assert_allclose(load_imu_log(path, rate_hz=12.5).t_s, np.arange(37) / 12.5)


def test_round_trip_with_a_time_column(tmp_path) -> None:
    a = angles(20, seed=1)
    t = 1000.0 + np.cumsum(np.full(20, 0.1)) + np.random.default_rng(2).uniform(-0.01, 0.01, 20)
    path = write_imu_log(tmp_path / "imu_t.txt", a, t_s=t)
    assert all(len(ln.split()) == 16 for ln in path.read_text().splitlines())
    log = load_imu_log(path, rate_hz=3.0)  # the file's times, not the rate, set the time base
    assert log.meta["layout"] == "time+angles" and log.valid.all()
    np.testing.assert_allclose(log.t_s, t, rtol=0, atol=5e-6)
    np.testing.assert_allclose(log.angles_deg, a, rtol=0, atol=5e-6)


def test_a_hand_written_line_is_read_sensor_by_sensor(tmp_path) -> None:
    line = " ".join(f"{100 * s + 10 * k + 0.12345:.5f}" for s in range(1, 6) for k in range(3))
    path = tmp_path / "one.txt"
    path.write_text(f"# heading roll pitch x 5\n\n{line}\n{line}\n")
    log = load_imu_log(path)
    assert log.n == 2  # the comment and the blank line are not samples
    np.testing.assert_allclose(log.angles_deg[0, 2], [300.12345, 310.12345, 320.12345])  # sensor 3
    np.testing.assert_allclose(log.pitch_deg[1], [120.12345, 220.12345, 320.12345, 420.12345, 520.12345])
    path.write_bytes(f"{line}\r\n{line}\r\n".encode("utf-8-sig"))  # saved again by an editor on Windows
    log = load_imu_log(path)  # (before: the first sample invalid, its first number "\ufeff100.12345")
    assert log.valid.all() and log.angles_deg[0, 0, 0] == pytest.approx(100.12345)


def test_a_malformed_line_costs_that_line_only_and_the_time_base_holds(tmp_path) -> None:
    a = angles(12, seed=3)
    a[9] = np.nan  # a dropout written by a simulator: "nan" fields
    path = write_imu_log(tmp_path / "imu.txt", a)
    raw = path.read_bytes().split(b"\n")
    raw[2] = raw[2].rsplit(b" ", 8)[0]                        # truncated after 7 numbers
    raw[5] = raw[5].replace(b" ", b" abc ", 1)                # a stray token
    raw[7] = raw[7][:3] + b"\xff" + raw[7][4:]                # a damaged byte
    path.write_bytes(b"\n".join(raw))
    log = load_imu_log(path)
    assert log.n == 12 and log.meta["layout"] == "angles"
    bad = [2, 5, 7, 9]
    assert np.flatnonzero(~log.valid).tolist() == bad
    assert sorted(log.meta["invalid_lines"]) == [k + 1 for k in bad]  # 1-based line numbers
    assert log.meta["invalid_lines"][3] == "7 numbers, expected 15"
    assert np.isnan(log.angles_deg[bad]).all()
    good = np.setdiff1d(np.arange(12), bad)
    np.testing.assert_allclose(log.angles_deg[good], a[good], rtol=0, atol=5e-6)
    np.testing.assert_allclose(log.t_s, np.arange(12) * 0.1)  # sample 10 is still at 1.0 s


def test_a_capture_started_mid_line_does_not_decide_the_layout(tmp_path) -> None:
    a = angles(6, seed=4)
    path = write_imu_log(tmp_path / "imu.txt", a)
    text = path.read_text()
    path.write_text(text[text.index(" ", 50):])  # the first line lost its start: fewer than 15 numbers
    log = load_imu_log(path)
    assert log.meta["layout"] == "angles"
    assert log.valid.tolist() == [False, True, True, True, True, True]
    np.testing.assert_allclose(log.angles_deg[1:], a[1:], rtol=0, atol=5e-6)


def test_one_damaged_time_costs_its_line_only(tmp_path) -> None:
    a = angles(10, seed=5)
    t = 20.0 + 0.1 * np.arange(10)
    path = write_imu_log(tmp_path / "imu_t.txt", a, t_s=t)
    lines = path.read_text().splitlines()
    assert lines[3].startswith("20.30000 ")
    lines[3] = "90.3" + lines[3][4:]  # one digit flipped: the time jumps ahead
    lines[0] = "x" + lines[0][1:]     # and the first line's time is unreadable
    path.write_text("\n".join(lines) + "\n")
    log = load_imu_log(path)
    assert np.flatnonzero(~log.valid).tolist() == [0, 3]
    assert "out of order" in log.meta["invalid_lines"][4]
    # the invalid lines' times, from their neighbours: linear inside, at the 0.1 s step before the first
    np.testing.assert_allclose(log.t_s, t, atol=1e-9)


@pytest.mark.parametrize("content, match", [
    (" ".join(["1.00000"] * 12) + "\n" + " ".join(["2.00000"] * 12) + "\n", r"bad\.txt:1: 12 numbers on the line"),
    ("# only a comment\n\n", "no samples"),
    ("", "no samples"),
    ("heading roll pitch\nfoo bar\n", r"bad\.txt:1: not a line of finite numbers"),
    (" ".join(["nan"] * 15) + "\n", r"bad\.txt:1: not a line of finite numbers"),
])
def test_other_files_are_refused_with_one_line_naming_file_and_line(tmp_path, content, match) -> None:
    path = tmp_path / "bad.txt"
    path.write_text(content)
    with pytest.raises(SessionFormatError, match=match) as err:
        load_imu_log(path)
    assert "\n" not in str(err.value) and str(path) in str(err.value)


def test_a_missing_file_and_a_bad_rate(tmp_path) -> None:
    with pytest.raises(FileNotFoundError, match="IMU log not found"):
        load_imu_log(tmp_path / "nope.txt")
    path = write_imu_log(tmp_path / "imu.txt", angles(3))
    with pytest.raises(ValueError, match="rate_hz"):
        load_imu_log(path, rate_hz=0.0)


@pytest.mark.parametrize("kwargs, match", [
    ({"angles_deg": np.zeros((4, 5, 2))}, "shape"),
    ({"angles_deg": np.zeros((0, 15))}, "shape"),
    ({"angles_deg": np.full((2, 15), np.inf)}, "non-finite"),
    ({"angles_deg": np.zeros((3, 15)), "t_s": [0.0, 0.1]}, "t_s must have shape"),
    ({"angles_deg": np.zeros((3, 15)), "t_s": [0.0, 0.2, 0.1]}, "increase"),
])
def test_write_refuses_bad_input(tmp_path, kwargs, match) -> None:
    with pytest.raises(ValueError, match=match):
        write_imu_log(tmp_path / "w.txt", **kwargs)

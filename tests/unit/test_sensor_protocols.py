"""Pneumatic protocols of thesis §2.4.2 / docs/spec.md §4: shapes, durations and levels from those numbers."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from conftest import load_reference

from psmat.sensor.protocols import (
    PROTOCOL_NAMES,
    Protocol,
    Segment,
    as_segments,
    ascending_hysteresis,
    descending_hysteresis,
    fast_cyclic,
    long_staircase,
    segments_from_pressure,
    standard_protocols,
)


def plateaus(p: np.ndarray) -> list[tuple[float, int]]:
    """Run-length encoding (level, n_samples)."""
    return [(float(k), len(list(g))) for k, g in itertools.groupby(p)]


def turning_points(levels: list[float]) -> list[float]:
    """Levels where the direction of change reverses, plus both ends."""
    out = [levels[0]]
    for a, b, c in zip(levels[:-2], levels[1:-1], levels[2:]):
        if (b - a) * (c - b) < 0:
            out.append(b)
    out.append(levels[-1])
    return out


def check_segments(pr: Protocol) -> None:
    """Segments tile the samples in order and carry the plateau's pressure."""
    assert pr.segments[0].start == 0 and pr.segments[-1].stop == pr.n_samples
    for a, b in zip(pr.segments[:-1], pr.segments[1:]):
        assert a.stop == b.start
    for s in pr.segments:
        assert np.all(pr.p_psi[s.start:s.stop] == s.level)
    np.testing.assert_allclose(pr.t_s, np.arange(pr.n_samples) * pr.dt_s)


# docs/spec.md §4 numbers
DESC_THESIS = [0, 32, 0, 28, 0, 24, 0, 20, 0, 16, 0, 12, 0, 8, 0, 4, 0]
ASC_THESIS = [0, 32, 4, 32, 0, 32, 8, 32, 0, 32, 12, 32, 0, 32, 16, 32, 0, 32, 20, 32, 0, 32, 24, 32, 0,
              32, 28, 32, 0]


def test_descending_reproduces_reference_exactly():
    ref = load_reference("mpi_creep_descending.json")
    pr = descending_hysteresis(repetitions=1)
    assert pr.dt_s == ref["dt"] == 0.5
    p_ref = np.asarray(ref["p_psi"], dtype=np.float64)
    assert pr.p_psi.shape == p_ref.shape
    assert np.array_equal(pr.p_psi, p_ref)


def test_descending_shape_from_spec():
    pr = descending_hysteresis(repetitions=1)
    assert pr.name == "descending_hysteresis"
    rl = plateaus(pr.p_psi)
    assert all(n == 12 for _, n in rl)  # 6 s at 2 Hz
    levels = [lv for lv, _ in rl]
    assert np.all(np.abs(np.diff(levels)) == 2.0)  # 2-psi steps
    assert turning_points(levels) == DESC_THESIS
    # one plateau per level visited: 1 + Σ peaks = 145 plateaus, 870 s
    assert len(rl) == 1 + sum(range(4, 33, 4)) == 145
    assert pr.duration_s == 145 * 6.0
    check_segments(pr)
    assert len(pr.segments) == 145
    # loop numbers: 8 loops, peaks 32 … 4
    peaks = {s.cycle: s.level for s in pr.segments if s.label == "up"}
    assert {c: max(s.level for s in pr.segments if s.cycle == c) for c in peaks} == {
        k: 32.0 - 4 * k for k in range(8)}
    assert {s.label for s in pr.segments} == {"rest", "up", "down"}


def test_descending_repetitions_concatenate():
    one = descending_hysteresis(repetitions=1)
    ten = descending_hysteresis()  # thesis: 10 repetitions
    assert ten.n_samples == 10 * one.n_samples
    assert ten.duration_s == 10 * 870.0
    for k in range(10):
        assert np.array_equal(ten.p_psi[k * one.n_samples:(k + 1) * one.n_samples], one.p_psi)
    assert sorted({s.repetition for s in ten.segments}) == list(range(10))
    check_segments(ten)


def test_ascending_shape_from_spec():
    pr = ascending_hysteresis(repetitions=1)
    assert pr.name == "ascending_hysteresis"
    rl = plateaus(pr.p_psi)
    assert all(n == 12 for _, n in rl)
    levels = [lv for lv, _ in rl]
    assert np.all(np.abs(np.diff(levels)) == 2.0)
    assert turning_points(levels) == ASC_THESIS
    # per loop with valley m: 16 up + (32-m)/2 down + (32-m)/2 up + 16 down plateaus
    expected = 1 + sum(16 + (32 - m) + 16 for m in range(4, 29, 4))
    assert len(rl) == expected == 337
    assert pr.duration_s == 337 * 6.0
    assert pr.p_psi.max() == 32.0 and pr.p_psi[0] == 0.0 and pr.p_psi[-1] == 0.0
    check_segments(pr)
    assert sorted({s.cycle for s in pr.segments}) == list(range(7))
    ten = ascending_hysteresis()
    assert ten.n_samples == 10 * pr.n_samples


def test_fast_cyclic_from_spec():
    for level in (5.0, 15.0):
        pr = fast_cyclic(level)
        assert pr.name == "fast_cyclic"
        assert pr.duration_s == 20 * (120 + 120) == 80 * 60
        loads = [s for s in pr.segments if s.label == "load"]
        rests = [s for s in pr.segments if s.label == "rest"]
        assert len(loads) == len(rests) == 20
        assert all(s.stop - s.start == 240 and s.level == level for s in loads)
        assert all(s.stop - s.start == 240 and s.level == 0.0 for s in rests)
        assert [s.cycle for s in loads] == list(range(20))
        check_segments(pr)
        assert set(np.unique(pr.p_psi)) == {0.0, level}


def test_long_staircase_from_spec():
    pr = long_staircase()
    assert pr.name == "long_staircase"
    assert pr.levels() == [0.0, 5.0, 15.0, 30.0, 15.0, 5.0, 0.0]
    assert all(s.stop - s.start == 25 * 60 * 2 for s in pr.segments)
    assert pr.duration_s == 7 * 25 * 60
    check_segments(pr)


def test_standard_protocols_and_names():
    std = standard_protocols()
    assert set(std) == {"fast_cyclic_5", "fast_cyclic_15", "long_staircase", "descending_hysteresis",
                        "ascending_hysteresis"}
    assert {p.name for p in std.values()} == set(PROTOCOL_NAMES)
    assert std["fast_cyclic_15"].params["level_psi"] == 15.0


def test_other_sampling_rates():
    pr = descending_hysteresis(repetitions=1, dt=0.1)
    assert pr.n_samples == 145 * 60
    assert np.array_equal(pr.p_psi[::5], descending_hysteresis(repetitions=1).p_psi)


@pytest.mark.parametrize("call", [
    lambda: fast_cyclic(5.0, on_s=120.2),           # not a whole number of samples
    lambda: fast_cyclic(0.0),                        # no load
    lambda: fast_cyclic(5.0, cycles=0),
    lambda: long_staircase(levels=(0, -5, 0)),
    lambda: long_staircase(levels=()),
    lambda: descending_hysteresis(step_psi=3.0),      # 32 is not a multiple of 3
    lambda: ascending_hysteresis(repetitions=0),
    lambda: descending_hysteresis(dt=0.0),
])
def test_invalid_arguments(call):
    with pytest.raises(ValueError):
        call()


def test_segments_from_pressure_and_as_segments():
    p = np.array([0, 0, 5, 5, 5, 0, np.nan, 2, 2], dtype=float)
    segs = segments_from_pressure(p)
    assert [(s.start, s.stop, s.level) for s in segs] == [(0, 2, 0.0), (2, 5, 5.0), (5, 6, 0.0), (7, 9, 2.0)]
    norm = as_segments([(2, 5, "load", 5.0), (0, 2, 0.0), Segment(5, 6, "rest", 0.0), (7, 9, "x")], p)
    assert [s.start for s in norm] == [0, 2, 5, 7]
    assert norm[3].level == 2.0 and norm[3].label == "x"
    with pytest.raises(ValueError, match="empty"):
        as_segments([(3, 3, 1.0)])
    with pytest.raises(ValueError, match="beyond"):
        as_segments([(0, 20, 1.0)], p)

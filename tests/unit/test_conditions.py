"""Events → conditions, the events CSV and the Romberg quotient (docs/spec.md §7 "Events, conditions, Romberg").

Every expectation is worked out by hand from the markers and numbers written in the test.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from psmat.balance import (UNMARKED, Condition, condition_spans, conditions, frame_clock, inside, load_events_csv,
                           romberg, romberg_role)


def test_each_marker_starts_a_condition_until_the_next_or_the_end() -> None:
    events = [(10.0, "eyes open"), (40.0, "eyes closed")]
    assert conditions(events, 0.0, 70.0) == [Condition("", 0.0, 10.0), Condition("eyes open", 10.0, 40.0),
                                             Condition("eyes closed", 40.0, 70.0)]


def test_markers_are_sorted_and_a_marker_at_the_start_leaves_no_unmarked_part() -> None:
    events = [(30.0, "EC"), (5.0, "EO")]
    assert conditions(events, 5.0, 60.0) == [Condition("EO", 5.0, 30.0), Condition("EC", 30.0, 60.0)]


def test_end_stop_off_close_the_current_condition_without_starting_one() -> None:
    events = [(1.0, "a"), (3.0, " END "), (4.0, "b"), (6.0, "Stop"), (7.0, "c"), (8.0, "off"), (9.0, "end")]
    out = conditions(events, 0.0, 10.0)
    assert out == [Condition("", 0.0, 1.0), Condition("a", 1.0, 3.0), Condition("b", 4.0, 6.0),
                   Condition("c", 7.0, 8.0)]
    assert [c.duration_s for c in out] == [1.0, 2.0, 2.0, 1.0]


def test_markers_outside_the_span_are_ignored_and_zero_lengths_dropped() -> None:
    events = [(-5.0, "before"), (2.0, "x"), (2.0, "y"), (12.0, "after"), (10.0, "at the end")]
    # x lasts 0 s (y at the same time) and "at the end" 0 s: both dropped
    assert conditions(events, 0.0, 10.0) == [Condition("", 0.0, 2.0), Condition("y", 2.0, 10.0)]
    assert conditions([], 3.0, 8.0) == [Condition("", 3.0, 8.0)]
    assert conditions([], 3.0, 3.0) == []


@pytest.mark.parametrize("events, t0, t1, message", [
    ([(math.nan, "x")], 0.0, 1.0, "event 0's time"),
    ([(1.0, 2)], 0.0, 1.0, "label must be a str"),
    ([(1.0,)], 0.0, 1.0, r"not a \(time, label\) pair"),
    ([], 5.0, 1.0, "before t0_s"),
    ([], 0.0, math.inf, "t1_s"),
])
def test_bad_events_or_span_are_one_line(events, t0, t1, message) -> None:
    with pytest.raises(ValueError, match=message) as e:
        conditions(events, t0, t1)
    assert "\n" not in str(e.value)


def test_events_csv_comma_and_semicolon(tmp_path: Path) -> None:
    a = tmp_path / "a.csv"
    a.write_text("time_s,label\n0.5,eyes open\n\n30.25, eyes closed \n", encoding="utf-8")
    assert load_events_csv(a) == [(0.5, "eyes open"), (30.25, "eyes closed")]
    b = tmp_path / "b.csv"
    b.write_text("\ufeffTime;Label\n1;EO\n2.5;\"EC; then\"\n", encoding="utf-8")
    assert load_events_csv(b) == [(1.0, "EO"), (2.5, "EC; then")]
    c = tmp_path / "c.csv"  # a European spreadsheet's export: semicolons, decimal commas, Windows line ends
    c.write_bytes("\ufefftime_s;label\r\n0,5;eyes open\r\n30,25;eyes closed\r\n".encode("utf-8"))
    assert load_events_csv(c) == [(0.5, "eyes open"), (30.25, "eyes closed")]


@pytest.mark.parametrize("encoding", ["cp1252", "utf-16"])
def test_events_csv_as_a_spreadsheet_saves_it(tmp_path: Path, encoding: str) -> None:
    """Excel's "CSV" on a western Windows is Windows-1252 (before: UnicodeDecodeError for "fermés");
    its "Unicode text" UTF-16 with tabs, and decimal commas in a European locale."""
    p = tmp_path / "ev.csv"
    sep = "\t" if encoding == "utf-16" else ";"
    p.write_bytes(f"time_s{sep}label\r\n0,5{sep}yeux ouverts\r\n30,25{sep}yeux fermés\r\n".encode(encoding))
    assert load_events_csv(p) == [(0.5, "yeux ouverts"), (30.25, "yeux fermés")]
    p.write_bytes(b"time_s,label\n0.5,a\x00\n")
    with pytest.raises(ValueError, match=r"ev.csv: is not text \(byte 0x00 at offset 18\)"):
        load_events_csv(p)


@pytest.mark.parametrize("text, message", [
    ("t,label\n1,a\n", "line 1: header"),
    ("time_s,label\n1,a\nabc,b\n", "line 3: time 'abc'"),
    ("time_s,label\n1,a,extra\n", "line 2: expected 2 fields"),
    ("time_s,label\n1,\n", "line 2: empty label"),
    ("time_s,label\ninf,a\n", "line 2: time 'inf' is not finite"),
    ("", "empty file"),
])
def test_a_bad_events_csv_is_one_line_naming_file_and_line(tmp_path: Path, text, message) -> None:
    p = tmp_path / "ev.csv"
    p.write_text(text, encoding="utf-8")
    with pytest.raises(ValueError, match=message) as e:
        load_events_csv(p)
    assert str(p) in str(e.value) and "\n" not in str(e.value)
    with pytest.raises(FileNotFoundError):
        load_events_csv(tmp_path / "missing.csv")


@pytest.mark.parametrize("label, role", [
    ("eyes open", "EO"), ("Eyes_Open", "EO"), ("EYES-OPEN", "EO"), ("eo", "EO"), (" open ", "EO"),
    ("eyes closed", "EC"), ("eyes__closed", "EC"), ("Ec", "EC"), ("CLOSED", "EC"),
    ("", None), ("eyes", None), ("open eyes", None), ("rotation", None),
])
def test_romberg_role(label, role) -> None:
    assert romberg_role(label) == role


def test_romberg_quotient_is_closed_over_open_for_shared_numbers() -> None:
    eo = {"velocity_cm_s": 0.5, "area95_cm2": 2.0, "path_cm": 0.0, "sd_ml_cm": math.nan, "only_eo": 1.0,
          "name": "x", "flag": True}
    ec = {"velocity_cm_s": 0.75, "area95_cm2": 5.0, "path_cm": 3.0, "sd_ml_cm": 1.0, "only_ec": 2.0,
          "name": "y", "flag": False}
    out = romberg(eo, ec)
    assert list(out) == ["romberg_velocity_cm_s", "romberg_area95_cm2", "romberg_path_cm", "romberg_sd_ml_cm"]
    assert out["romberg_velocity_cm_s"] == 1.5 and out["romberg_area95_cm2"] == 2.5
    assert math.isnan(out["romberg_path_cm"]) and math.isnan(out["romberg_sd_ml_cm"])
    assert math.isnan(romberg({"a": 1.0}, {"a": math.nan})["romberg_a"])


def test_frame_clock_interpolates_extends_and_lets_a_burst_stand_by_its_newest_frame() -> None:
    # frames 0.1 s apart on the frame clock; host times 2 s later, the third and fourth arriving together
    t = np.array([0.0, 0.1, 0.2, 0.3, 0.4])
    host = np.array([2.0, 2.1, 2.3, 2.3, 2.4])
    got = frame_clock([2.05, 2.3, 2.35, 1.0, 3.4], host, t)
    # 2.05: halfway frames 0-1; 2.3: the burst's newest (0.3); 2.35: halfway (2.3, 0.3)-(2.4, 0.4);
    # outside: the slope of the first and last points, (0.4 - 0.0) / (2.4 - 2.0) = 1
    np.testing.assert_allclose(got, [0.05, 0.3, 0.35, -1.0, 1.4])
    with pytest.raises(ValueError, match="fewer than two frames"):
        frame_clock([1.0], np.array([np.nan, 1.0]), np.array([0.0, 1.0]))


def test_condition_spans_start_at_the_window_and_make_labels_unique() -> None:
    events = [(-3.0, "EO"), (4.0, "EC"), (6.0, "EO"), (8.0, "end")]
    assert condition_spans(events, 0.0, 10.0) == [Condition("EO", 0.0, 4.0), Condition("EC", 4.0, 6.0),
                                                  Condition("EO (2)", 6.0, 8.0)]
    assert condition_spans([(2.0, "a")], 0.0, 5.0) == [Condition(UNMARKED, 0.0, 2.0), Condition("a", 2.0, 5.0)]
    assert condition_spans([(7.0, "after")], 0.0, 5.0) == []  # only an unmarked stretch: no condition
    assert condition_spans([], 0.0, 5.0) == []


def test_inside_shares_no_sample_between_spans_and_keeps_the_last() -> None:
    t = np.arange(11.0)  # 0 ... 10 s
    a, b = condition_spans([(0.0, "a"), (4.0, "b")], 0.0, 10.0)
    ia, ib = inside(t, a, 10.0), inside(t, b, 10.0)
    assert ia.sum() == 4 and ib.sum() == 7 and not np.any(ia & ib) and np.all(ia | ib)


def test_markers_on_another_clock_by_hand() -> None:
    from psmat.balance import NEAR_S, off_the_clock

    first, last = 1.7e9, 1.7e9 + 60.0  # a minute recorded, host clock from 1970
    assert off_the_clock([0.5, 15.0], first, last)  # seconds from the start
    assert not off_the_clock([first - 2.0, first + 30.0], first, last)  # pressed 2 s before, then during
    assert not off_the_clock([first - 2.0], first, last)  # one marker shortly before: on this clock
    assert not off_the_clock([last + NEAR_S], first, last)  # the hour's edge is in
    assert off_the_clock([last + NEAR_S + 1.0, first - NEAR_S - 1.0], first, last)
    assert not off_the_clock([], first, last)  # no markers: nothing to judge


def test_an_events_header_as_people_write_it(tmp_path: Path) -> None:
    """Before: "header must be time_s,label" for Time (s),Event; and a file in ms could not be used."""
    p = tmp_path / "ev.csv"
    p.write_text("Time (s),Event\n0.5,eyes open\n30.25,eyes closed\n")
    assert load_events_csv(p) == [(0.5, "eyes open"), (30.25, "eyes closed")]
    p.write_text("time_ms;Marker\n500;eyes open\n30250;eyes closed\n")
    assert load_events_csv(p) == [(0.5, "eyes open"), (30.25, "eyes closed")]
    p.write_text("time [h],label\n1,a\n")
    with pytest.raises(ValueError, match=r"line 1: unknown time unit 'h'"):
        load_events_csv(p)

"""psmat.study.find_study: a study folder's sessions paired with platform files and subjects,
problems reported per session (docs/spec.md §6), on real files."""

from __future__ import annotations

import numpy as np
import pytest

from psmat.io import SessionWriter
from psmat.study import find_study, read_subjects


def _session(path, subject, trial, frames=4):
    with SessionWriter(path, (4, 4), {"rows": 4, "cols": 4}, metadata={"subject": subject, "trial": trial}) as w:
        w.append(np.full((frames, 4, 4), 100, np.uint16), np.arange(frames) * 0.01, np.ones(frames, bool))


@pytest.fixture
def study(tmp_path):
    (tmp_path / "sessions").mkdir()
    (tmp_path / "forceplate").mkdir()
    (tmp_path / "subjects.csv").write_text("subject,weight_kg,height_cm\nS01,70.5,175\nS02,58,160\n")
    _session(tmp_path / "sessions" / "S01_right.h5", "S01", "right-leg")
    _session(tmp_path / "sessions" / "S02_left.h5", "S02", "left-leg")
    _session(tmp_path / "sessions" / "S03_rot.h5", "S03", "rotation")  # not in subjects.csv
    (tmp_path / "sessions" / "S04_bad.h5").write_bytes(b"not an HDF5 file at all")
    for stem in ("S01_right", "S03_rot", "S04_bad"):  # S02 has no platform file
        (tmp_path / "forceplate" / f"{stem}.csv").write_text("time,x,y\n0,0,0\n0.01,0.1,0.2\n")
    return tmp_path


def test_pairs_and_problems(study) -> None:
    lay = find_study(study)
    by = {i.stem: i for i in lay.items}
    assert sorted(by) == ["S01_right", "S02_left", "S03_rot", "S04_bad"]
    assert by["S01_right"].ok and by["S01_right"].subject == "S01" and by["S01_right"].trial == "right-leg"
    assert by["S01_right"].forceplate == study / "forceplate" / "S01_right.csv"
    assert by["S02_left"].problems == ["no force-platform file forceplate/S02_left.csv"]
    assert by["S03_rot"].problems == ["subject 'S03' is not in subjects.csv"]
    assert len(by["S04_bad"].problems) == 1 and by["S04_bad"].problems[0].startswith("unreadable session")
    assert lay.subjects["S01"].weight_kg == 70.5
    assert lay.subjects["S01"].weight_n == pytest.approx(70.5 * 9.80665)
    assert lay.subjects["S01"].extra == {"height_cm": "175"}
    assert lay.problems == []


def test_companion_files_gathered_on_windows(study) -> None:
    """Files gathered on Windows, which does not tell case apart (before: "no force-platform file"
    beside S02_LEFT.TXT); two platform files for one session are a problem, neither is used (before:
    the last in sorted order, silently); an id that differs only in case is pointed at."""
    fp = study / "forceplate"
    (fp / "S02_LEFT.TXT").write_text("time,x,y\n0,0,0\n0.01,0.1,0.2\n")
    (fp / "S01_right.txt").write_text("time,x,y\n0,0,0\n0.01,0.1,0.2\n")  # beside S01_right.csv
    (fp / "s03_rot.csv").write_text("time,x,y\n0,0,0\n0.01,0.1,0.2\n")  # beside S03_rot.csv: that one is it
    (study / "subjects.csv").write_text("subject,weight_kg\nS01,70.5\nS02,58\ns03,80\n")
    by = {i.stem: i for i in find_study(study).items}
    assert by["S02_left"].ok and by["S02_left"].forceplate == fp / "S02_LEFT.TXT"
    assert by["S01_right"].forceplate is None
    assert by["S01_right"].problems == ["2 force-platform files for session S01_right: S01_right.csv, S01_right.txt; "
                                        "which one belongs to it is not known: keep one"]
    assert by["S03_rot"].forceplate == fp / "S03_rot.csv"
    assert by["S03_rot"].problems == ["subject 'S03' is not in subjects.csv (ids are matched exactly; it has 's03')"]


@pytest.mark.parametrize("text, weights", [
    ("Subject,Weight (kg),Height (cm)\nS01,70.5,170\nS02,58,160\n", {"S01": 70.5, "S02": 58.0}),
    ("subject;Body weight [lb]\nS01;155,4\nS02;127,868\n", {"S01": 155.4 * 0.45359237, "S02": 127.868 * 0.45359237}),
    ("Participant ID,mass_kg\nS01,70.5\n", {"S01": 70.5}),
    ("subject,weight_st\nS01,11\n", {"S01": 11 * 14 * 0.45359237}),  # the stone: 14 lb
])
def test_a_subjects_header_as_people_write_it(tmp_path, text, weights) -> None:
    """Capitals, units in brackets, pounds (before: "needs a column 'subject'" for "Subject", and a
    file in pounds could not be used). 1 lb = 0.45359237 kg exactly (international avoirdupois pound)."""
    p = tmp_path / "subjects.csv"
    p.write_text(text)
    got = read_subjects(p)
    assert set(got) == set(weights)
    for sid, kg in weights.items():
        assert got[sid].weight_kg == pytest.approx(kg, rel=1e-12)


def test_a_macs_companion_files_are_no_data_and_subfolders_are_said(study) -> None:
    """A study copied by a Mac to a USB stick gets a "._NAME" AppleDouble file beside each file
    (before: a session "._S01_right", unreadable, with its own problems, and a platform file
    "._S01_right.csv" that made S01's two); files in subfolders were skipped unsaid."""
    for folder, name in (("sessions", "._S01_right.h5"), ("forceplate", "._S01_right.csv"), ("sessions", ".DS_Store")):
        (study / folder / name).write_bytes(b"\x00\x05\x16\x07\x00\x02\x00\x00Mac OS X        " + bytes(4000))
    (study / "sessions" / "old").mkdir()
    _session(study / "sessions" / "old" / "S05_rot.h5", "S05", "rotation")
    lay = find_study(study)
    by = {i.stem: i for i in lay.items}
    assert sorted(by) == ["S01_right", "S02_left", "S03_rot", "S04_bad"]
    assert by["S01_right"].ok and by["S01_right"].forceplate == study / "forceplate" / "S01_right.csv"
    assert lay.problems == ["1 file(s) in subfolders are not read (sessions/old/S05_rot.h5): a study's files "
                            "sit directly in sessions/, forceplate/ and events/"]


def test_names_that_differ_only_in_case_or_separators_are_said(study) -> None:
    """A trial typed "Right leg" in one session and "right-leg" in another is two trials in the summary
    (each with fewer subjects); nothing merges them behind the lab's back, but the run says so."""
    _session(study / "sessions" / "S02_right.h5", "S02", "Right leg")
    _session(study / "sessions" / "S02_rot.h5", "s02", "rotation")
    (study / "sessions" / "S01_right.h5").unlink()
    _session(study / "sessions" / "S01_right.h5", "S01", "right-leg")
    lay = find_study(study)
    assert {i.stem: i.trial for i in lay.items}["S02_right"] == "Right leg"  # kept as written
    assert lay.problems == [
        "trials 'Right leg', 'right-leg' differ only in case or separators: they are kept and summarised apart; if "
        "they are one, name them alike in the sessions' metadata",
        "subjects 'S02', 's02' differ only in case or separators: they are kept and summarised apart; if they are "
        "one, name them alike in the sessions' metadata"]


def test_a_box_without_its_calibration_is_said_and_case_is_forgiven(study) -> None:
    """calibration/<serial>.json: "box7.json" for the box "BOX7" (files gathered on Windows) is its
    file; a box of a study with calibrations but none of its own was processed on the profile's
    nominal circuit unsaid."""
    for stem, serial in (("S01_left", "BOX7"), ("S02_rot", "BOX9")):
        with SessionWriter(study / "sessions" / f"{stem}.h5", (4, 4), {"rows": 4, "cols": 4, "serial": serial},
                           metadata={"subject": stem[:3], "trial": stem[4:]}) as w:
            w.append(np.full((4, 4, 4), 100, np.uint16), np.arange(4) * 0.01, np.ones(4, bool))
        (study / "forceplate" / f"{stem}.csv").write_text("time,x,y\n0,0,0\n0.01,0.1,0.2\n")
    (study / "calibration").mkdir()
    (study / "calibration" / "box7.json").write_text("{}")
    lay = find_study(study)
    by = {i.stem: i for i in lay.items}
    assert by["S01_left"].ok and lay.calibrations["BOX7"] == study / "calibration" / "box7.json"
    assert by["S02_rot"].problems == ["no calibration/BOX9.json for its box 'BOX9' (calibration/ has box7.json), "
                                      "and the session stores none: the profile's nominal circuit is used"]
    # a session that stores its calibration is read with it: nothing to say
    with SessionWriter(study / "sessions" / "S02_rot.h5", (4, 4), {"rows": 4, "cols": 4, "serial": "BOX9"},
                       metadata={"subject": "S02", "trial": "rot"}, overwrite=True,
                       calibration={"r_o_ohm": 1000.0, "r_mux_ohm": 100.0, "r_adc_ohm": 1e8, "v_ref_volt": 3.3,
                                    "bits": 12}) as w:
        w.append(np.full((4, 4, 4), 100, np.uint16), np.arange(4) * 0.01, np.ones(4, bool))
    assert {i.stem: i for i in find_study(study).items}["S02_rot"].ok


def test_missing_subjects_file_is_a_study_problem_not_a_crash(study) -> None:
    (study / "subjects.csv").unlink()
    lay = find_study(study)
    assert any("subjects.csv" in p for p in lay.problems)
    assert all("not in subjects.csv" in " ".join(i.problems) for i in lay.items if i.stem != "S04_bad")


def test_a_subjects_file_as_a_lab_saves_it(study) -> None:
    """"Subjects.CSV" (Windows), a tab-separated "subjects.txt" (a spreadsheet's "Text (tab-delimited)"):
    read (before: "subjects.csv not found: no body weights"). Two of them: which holds the subjects is not
    known, and the run says so. A spreadsheet's own workbook, here or for a platform file, is not read, and
    the line says to save it as CSV (before: only "not found")."""
    text = (study / "subjects.csv").read_text()
    (study / "subjects.csv").rename(study / "Subjects.CSV")
    lay = find_study(study)
    assert lay.problems == [] and lay.subjects["S01"].weight_kg == 70.5
    (study / "Subjects.CSV").unlink()
    (study / "subjects.txt").write_text(text.replace(",", "\t"))
    lay = find_study(study)
    assert lay.problems == [] and lay.subjects["S02"].weight_kg == 58
    (study / "subjects.csv").write_text(text)
    assert find_study(study).problems == ["2 subjects files (subjects.csv, subjects.txt): which one holds the study's "
                                          "subjects is not known: keep one; no body weights"]
    (study / "subjects.csv").unlink()
    (study / "subjects.txt").unlink()
    (study / "subjects.xlsx").write_bytes(b"PK\x03\x04" + bytes(100))
    (study / "forceplate" / "S02_left.XLSX").write_bytes(b"PK\x03\x04" + bytes(100))
    lay = find_study(study)
    book = "is a spreadsheet workbook, which psmat does not read: save it as CSV (File > Save As > CSV) beside it"
    assert lay.problems == [f"{study / 'subjects.csv'} not found: no body weights; subjects.xlsx {book}"]
    by = {i.stem: i for i in lay.items}
    assert by["S02_left"].problems[-1] == f"no force-platform file forceplate/S02_left.csv; forceplate/S02_left.XLSX {book}"
    (study / "events").mkdir()
    (study / "events" / "S01_right.ods").write_bytes(b"PK\x03\x04" + bytes(100))  # an experimenter's log
    by = {i.stem: i for i in find_study(study).items}
    assert by["S01_right"].problems[0] == f"events file not used, no conditions: events/S01_right.ods {book}"
    assert by["S01_right"].events_unusable == by["S01_right"].problems[0]


@pytest.mark.parametrize("text, match", [
    ("subject,height_cm\nS01,170\n", "weight_kg"),
    ("subject,weight_kg\nS01,heavy\n", "not a number"),
    ("subject,weight_kg\nS01,70\nS01,71\n", "twice"),
    ("subject,weight_kg\nS01,7000\n", "expected kg"),
    # a header that leaves the weight unknown
    ("subject,weight\nS01,70\n", "the column 'weight' names no unit: call it weight_kg or weight_lb"),
    ("subject,weight_kg,weight_lb\nS01,70,154\n", "needs one column 'weight_kg'"),
    ("ID,weight_kg\nS01,70\n", "needs one column 'subject'"),
    ("subject,weight_lb\nS01,1200\n", "weight_lb of 'S01' is 1200 = 544.311 kg; expected kg in"),
])
def test_bad_subjects_file(tmp_path, text, match) -> None:
    p = tmp_path / "subjects.csv"
    p.write_text(text)
    with pytest.raises(ValueError, match=match):
        read_subjects(p)


def test_a_subjects_file_from_a_european_spreadsheet(tmp_path) -> None:
    """Semicolons between the fields, decimal commas, and the byte-order mark such a spreadsheet
    writes: the same subjects as the plain file (before: "needs a column 'subject'")."""
    plain, european = tmp_path / "plain.csv", tmp_path / "eu.csv"
    plain.write_text("subject,weight_kg,height_cm\nS01,67.5,175.5\nS02,80,181\n")
    european.write_bytes("\ufeffsubject;weight_kg;height_cm\nS01;67,5;175,5\nS02;80;181\n".encode())
    a, b = read_subjects(plain), read_subjects(european)
    assert {k: v.weight_kg for k, v in b.items()} == {k: v.weight_kg for k, v in a.items()} == {"S01": 67.5, "S02": 80.0}
    assert b["S01"].extra == {"height_cm": "175,5"}  # other columns kept as written


def test_no_sessions_folder(tmp_path) -> None:
    with pytest.raises(FileNotFoundError, match="sessions"):
        find_study(tmp_path)


def test_each_session_carries_its_box_serial_read_once_with_its_metadata(study) -> None:
    with SessionWriter(study / "sessions" / "S01_left.h5", (4, 4), {"rows": 4, "cols": 4, "serial": "BOX7"},
                       metadata={"subject": "S01", "trial": "left-leg"}) as w:
        w.append(np.full((3, 4, 4), 100, np.uint16), np.arange(3) * 0.01, np.ones(3, bool))
    by = {i.stem: i for i in find_study(study).items}
    assert by["S01_left"].serial == "BOX7"  # the key of its calibration file, calibration/BOX7.json
    assert by["S01_right"].serial is None  # no serial in the device description
    assert by["S04_bad"].serial is None  # unreadable

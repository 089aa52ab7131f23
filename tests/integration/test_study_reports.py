"""Per-subject HTML reports of a study (``psmat study run DIR --reports``; docs/spec.md §6 study layout,
§12), on a simulated study (``psmat.synth.simulate_study``: two volunteers, 20 s trials, the mat at
10 Hz) run by the real runner, the real chain and the real report writer.

What is checked comes from the study folder itself (its sessions' names, subjects.csv, the events
file the test writes), never from the report code: the pages exist, are self-contained, name their
subject and sessions, carry the events file's markers; report.md links exactly them; a rerun writes
nothing; a changed events file rewrites its subject's page alone; a page that cannot be made is one
problem line and the others are there.
"""

from __future__ import annotations

import csv
import re
import shutil
from pathlib import Path

import pytest

from psmat.cli import main
from psmat.io import load_session
from psmat.study import run_study
from psmat.synth import simulate_study

VARIANTS = ["PROP"]
MARKERS = ("quiet stance", "head turn")


def _events(root: Path, stem: str, labels: tuple[str, ...]) -> None:
    """events/<stem>.csv: markers 3 s and 9 s after the session's first frame, on its host clock."""
    t0 = float(load_session(root / "sessions" / f"{stem}.h5").host_time_s[0])
    (root / "events").mkdir(exist_ok=True)
    lines = ["time_s,label"] + [f"{t0 + dt!r},{label}" for dt, label in zip((3.0, 9.0), labels)]
    (root / "events" / f"{stem}.csv").write_text("\n".join(lines) + "\n")


def _run(root: Path, reports: bool = True):
    return run_study(root, workers=2, params={"variants": VARIANTS}, progress=False, reports=reports)


def _links(root: Path) -> list[str]:
    """The link targets of report.md's section "Per-subject reports" (none without it)."""
    text = (root / "results" / "report.md").read_text()
    m = re.search(r"^## Per-subject reports\n(.*?)(?=^## |\Z)", text, re.S | re.M)
    return [] if m is None else re.findall(r"^- \[[^\]]*\]\(([^)]+)\)$", m.group(1), re.M)


def _state(folder: Path) -> dict[str, tuple[int, bytes]]:
    return {p.name: (p.stat().st_mtime_ns, p.read_bytes()) for p in sorted(folder.glob("*.html"))}


@pytest.fixture(scope="module")
def study(tmp_path_factory) -> Path:
    root = simulate_study(tmp_path_factory.mktemp("rep") / "study", volunteers=2, duration_s=20, seed=5, rate_hz=10)
    _events(root, "V01_right-leg", MARKERS)
    assert main(["study", "run", str(root), "--workers", "2", "--quiet", "--variants", ",".join(VARIANTS),
                 "--reports"]) == 0
    return root


@pytest.fixture
def copy(study, tmp_path) -> Path:
    """A copy of the study and its results, for the tests that change it."""
    return Path(shutil.copytree(study, tmp_path / "study"))


def test_one_self_contained_page_per_subject_naming_its_sessions(study) -> None:
    with open(study / "subjects.csv", newline="") as fh:
        subjects = {r["subject"]: r for r in csv.DictReader(fh)}
    pages = study / "results" / "reports"
    assert sorted(p.name for p in pages.glob("*.html")) == [f"{s}.html" for s in sorted(subjects)]
    stems = sorted(p.stem for p in (study / "sessions").glob("*.h5"))
    for s, row in subjects.items():
        html = (pages / f"{s}.html").read_text()
        assert html.lstrip().lower().startswith("<!doctype html")
        assert not re.search(r"https?://", html), "a page fetches nothing from elsewhere"
        assert not re.search(r"""(src|href)\s*=\s*(?!["']?(data:|#))""", html), "every image is inline"
        assert re.search(rf"<h1>[^<]*\b{s}\b", html)
        assert f"{float(row['weight_kg']):g} kg" in html and f"{row['height_cm']} cm" in html
        own = [st for st in stems if st.startswith(f"{s}_")]
        assert len(own) == 3 and all(f"{st}.h5" in html for st in own)
        assert not any(f"{st}.h5" in html for st in stems if st not in own)
    # the events file of V01_right-leg cuts that session into its conditions in V01's page only
    assert all(label in (pages / "V01.html").read_text() for label in MARKERS)
    assert not any(label in (pages / "V02.html").read_text() for label in MARKERS)


def test_report_md_links_exactly_the_pages_and_they_resolve(study) -> None:
    results = study / "results"
    links = _links(study)
    assert links == ["reports/V01.html", "reports/V02.html"]
    assert all((results / link).is_file() for link in links)


def test_rerun_writes_nothing_and_a_changed_events_file_rewrites_its_subject_alone(copy) -> None:
    pages = copy / "results" / "reports"
    before = _state(pages)
    report = _run(copy)
    assert report.report_counts == (0, 2, 0) and report.problems == []
    assert _state(pages) == before
    _events(copy, "V02_left-leg", ("eyes open", "eyes closed"))
    report = _run(copy)
    assert report.report_counts == (1, 1, 0)
    after = _state(pages)
    assert after["V01.html"] == before["V01.html"]
    assert after["V02.html"][1] != before["V02.html"][1]
    assert "eyes closed" in after["V02.html"][1].decode()
    assert _links(copy) == ["reports/V01.html", "reports/V02.html"]


def test_without_reports_stale_pages_stay_on_disk_but_are_not_linked(copy) -> None:
    pages = copy / "results" / "reports"
    before = _state(pages)
    _events(copy, "V02_left-leg", ("a", "b"))  # V02's page no longer matches its inputs
    report = _run(copy, reports=False)
    assert report.report_counts is None
    assert _state(pages) == before
    assert _links(copy) == ["reports/V01.html"]
    report = _run(copy)
    assert report.report_counts == (1, 1, 0)
    assert _links(copy) == ["reports/V01.html", "reports/V02.html"]


def test_a_page_that_cannot_be_made_is_one_problem_line(copy) -> None:
    pages = copy / "results" / "reports"
    (pages / "V01.html").unlink()
    (copy / "sessions" / "V02_rotation.h5").write_bytes(b"not an HDF5 file\n" * 64)
    report = _run(copy)
    lines = [p for p in report.problems if p.startswith("report of ")]
    assert len(lines) == 1 and lines[0].startswith("report of V02 not written: ") and "\n" not in lines[0]
    assert report.report_counts == (1, 0, 1)
    assert (pages / "V01.html").is_file()
    assert _links(copy) == ["reports/V01.html"]
    assert lines[0] in (copy / "results" / "report.md").read_text()

"""Per-subject HTML reports of a study (``psmat study run DIR --reports``; docs/spec.md §6 study layout,
§12), on a simulated study (``psmat.synth.simulate_study``: two volunteers, 20 s trials, the mat at
10 Hz) run by the real runner, the real chain and the real report writer.

What is checked comes from the study folder itself (its sessions' names, subjects.csv, the events
file the test writes), never from the report code: the pages exist, are self-contained, name their
subject and sessions, carry the events file's markers; report.md links exactly them; a rerun writes
nothing; a changed events file rewrites its subject's page alone; a page that cannot be made is one
problem line and the others are there. Every page passes :func:`psmat.report.check_page`, and
the same page with anything a browser would run or fetch added is refused. On a real Dask
LocalCluster the pages are tasks of its workers (the scheduler's own record), sent back as
text, and are the pool's pages but for the time they were written.
"""

from __future__ import annotations

import csv
import re
import shutil
import sys
from pathlib import Path

import pytest
from dask_cluster import LOOPBACK_HTTP

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


_WRITTEN = re.compile(r"<td>written \(UTC\)</td><td>[^<]*</td>")


def test_every_page_passes_the_page_check_and_anything_a_browser_would_run_is_refused(study) -> None:
    from psmat.report import check_page

    page = (study / "results" / "reports" / "V01.html").read_text()
    assert check_page(page) == page and check_page((study / "results" / "reports" / "V02.html").read_text())
    added = {  # each a way to run or fetch something from a page, refused with one line
        "a script": ("<h1>", "<script>alert(1)</script><h1>"),
        "an event handler": ("<h1>", '<h1 onmouseover="alert(1)">'),
        "a link": ("<h1>", '<a href="https://example.org/">x</a><h1>'),
        "a frame": ("<h1>", '<iframe src="other.html"></iframe><h1>'),
        "an SVG": ("<h1>", '<svg onload="alert(1)"></svg><h1>'),
        "a refresh": ("<h1>", '<meta http-equiv="refresh" content="0;url=https://example.org/"><h1>'),
        "a style fetching": ("<style>", "<style>body{background:url(https://example.org/x.png)}"),
        "a script as image": ('src="data:image/png;base64,', 'src="javascript:alert(1);'),
        "an image of text": ('src="data:image/png;base64,', 'src="data:image/svg+xml;base64,'),
        "a comment": ("<h1>", "<!--[if IE]><script>alert(1)</script><![endif]--><h1>"),
    }
    for what, (old, new) in added.items():
        assert old in page, what
        with pytest.raises(ValueError) as err:
            check_page(page.replace(old, new, 1))
        assert "\n" not in str(err.value), what
    with pytest.raises(ValueError, match="must be text"):
        check_page(page.encode())


def _scripted(task):
    """On a worker: the page with a script added, sent back as a well-formed answer with a time."""
    from psmat.study._reports import render_page

    text, why = render_page(task)
    time = {"start": 0.0, "wall_s": 0.0, "cpu_s": 0.0, "pid": 1, "worker": "rogue"}
    return (None if text is None else text.replace("<h1>", "<script>alert(1)</script><h1>", 1), why), time


def test_on_a_dask_cluster_the_pages_are_made_by_its_workers_and_are_the_pools(study, copy, monkeypatch) -> None:
    distributed = pytest.importorskip("distributed")
    import cloudpickle

    from psmat.study import _cluster

    pages = copy / "results" / "reports"
    # the pool's pages, written from the study's folder (a page names its session files)
    pool = {p.name: p.read_text().replace(str(study), str(copy)) for p in sorted(pages.glob("*.html"))}
    shutil.rmtree(pages)
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None,
                                  scheduler_kwargs=LOOPBACK_HTTP) as c, \
            distributed.Client(c.scheduler_address) as client, distributed.get_task_stream(client) as stream:
        first = run_study(copy, scheduler=c.scheduler_address, params={"variants": VARIANTS}, progress=False,
                          reports=True)
        workers = set(client.scheduler_info()["workers"])
        dask = {p.name: p.read_text() for p in sorted(pages.glob("*.html"))}
        (copy / "sessions" / "V02_rotation.h5").write_bytes(b"not an HDF5 file\n" * 64)
        second = run_study(copy, scheduler=c.scheduler_address, params={"variants": VARIANTS}, progress=False,
                           reports=True)
        assert (pages / "V01.html").read_text() == dask["V01.html"]  # V02's failure leaves V01's page alone
        assert _links(copy) == ["reports/V01.html"]
        # a worker sending V01's page with a script in it: refused, nothing written
        cloudpickle.register_pickle_by_value(sys.modules[__name__])  # the workers need not import this file
        monkeypatch.setattr(_cluster, "run_page", _scripted)
        (pages / "V01.html").unlink()
        third = run_study(copy, scheduler=c.scheduler_address, params={"variants": VARIANTS}, progress=False,
                          reports=True)
    assert (first.reused, first.report_counts, first.problems) == (6, (2, 0, 0), [])
    assert sorted(dask) == sorted(pool) == ["V01.html", "V02.html"]
    for name in pool:  # the same page but for the time it was written
        assert str(copy / "sessions") in dask[name]
        assert len(_WRITTEN.findall(dask[name])) == 1
        assert _WRITTEN.sub("", dask[name]) == _WRITTEN.sub("", pool[name])
    made = [t["worker"] for t in stream.data if str(t["key"]).startswith("psmat-report-")]
    assert len(made) == 5 and set(made) <= workers  # two pages, V02's again, then both again
    # a page a worker cannot make: one problem line, the other page left as it was
    lines = [p for p in second.problems if p.startswith("report of ")]
    assert len(lines) == 1 and lines[0].startswith("report of V02 not written: ") and "\n" not in lines[0]
    assert second.report_counts == (0, 1, 1)
    assert "report of V01 not written: the cluster's result was refused: a page holds a <script> tag" in third.problems
    assert third.report_counts == (0, 0, 2) and not (pages / "V01.html").exists() and _links(copy) == []

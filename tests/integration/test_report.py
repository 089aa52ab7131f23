"""``psmat report`` and :func:`psmat.report.write_report` on real session files.

* A simulated 30 s standing session (``psmat.synth.simulate_study``, 50 Hz) with its force-platform
  file and markers "eyes open" at 0 s and "eyes closed" at 15 s: the page holds the version, units,
  its figures inline and no outside address; the lag it reports is the simulator's truth; the
  conditions last what the session's frame clock says; it renders in headless Chromium with no error
  and every image decoded; ``--pdf`` prints a PDF.
* An imported pressure session (``psmat.io.import_pressure``, a generic CSV written here) with two
  loaded cells whose pressures swing in antiphase: the CoP's ranges, the feet's force, peak and
  contact area in the page are the hand values.
* Bad inputs: one line, exit status 1 (as every command).
"""

from __future__ import annotations

import contextlib
import io
import json
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pytest

import psmat
from psmat.balance import descriptors
from psmat.cli import main
from psmat.io import import_pressure, load_session
from psmat.process import session_pressure
from psmat.balance import POOR_ALIGNMENT_R, descriptor_unit, ispgr
from psmat.report import ReportItem, write_report
from psmat.synth import simulate_study

RATE_HZ = 50.0
SECONDS = 30.0
SWITCH_S = 15.0


class _Tables(HTMLParser):
    """Every table of a page as rows of cell texts, and every image's ``src``."""

    def __init__(self) -> None:
        super().__init__()
        self.tables: list[list[list[str]]] = []
        self.images: list[str] = []
        self._row: list[str] | None = None
        self._cell: list[str] | None = None

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        if tag == "table":
            self.tables.append([])
        elif tag == "tr":
            self._row = []
        elif tag in ("td", "th"):
            self._cell = []
        elif tag == "img":
            self.images.append(dict(attrs).get("src") or "")

    def handle_endtag(self, tag: str) -> None:
        if tag in ("td", "th") and self._cell is not None and self._row is not None:
            self._row.append("".join(self._cell).strip())
            self._cell = None
        elif tag == "tr" and self._row is not None:
            self.tables[-1].append(self._row)
            self._row = None

    def handle_data(self, data: str) -> None:
        if self._cell is not None:
            self._cell.append(data)


def _parse(text: str) -> _Tables:
    p = _Tables()
    p.feed(text)
    return p


def _table(page: _Tables, first_header: str, nth: int = 0) -> dict[str, list[str]]:
    """The ``nth`` table whose first header cell is ``first_header``, as first cell -> the other cells."""
    found = [t for t in page.tables if t and t[0] and t[0][0] == first_header]
    return {row[0]: row[1:] for row in found[nth][1:]}


def _tables(page: _Tables, first_header: str) -> list[list[list[str]]]:
    return [t for t in page.tables if t and t[0] and t[0][0] == first_header]


@pytest.fixture(scope="module")
def study(tmp_path_factory) -> Path:
    return simulate_study(tmp_path_factory.mktemp("report") / "study", volunteers=1, duration_s=SECONDS, seed=11,
                          rate_hz=RATE_HZ)


@pytest.fixture(scope="module")
def made(study, tmp_path_factory):
    """``psmat report`` of the rotation trial with platform and markers, PDF asked for."""
    events = tmp_path_factory.mktemp("events") / "markers.csv"
    events.write_text(f"time_s,label\n0,eyes open\n{SWITCH_S},eyes closed\n", encoding="utf-8")
    session = study / "sessions" / "V01_rotation.h5"
    argv = ["report", str(session), "--platform", str(study / "forceplate" / "V01_rotation.csv"), "--events",
            str(events), "--events-from-start", "--pdf", "--subject", "V01"]
    return session, argv


@pytest.fixture(scope="module")
def ran(made):
    session, argv = made
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        status = main(argv)
    return session, status, out.getvalue(), err.getvalue()


def test_the_report_is_written_beside_the_session_and_its_path_printed(ran) -> None:
    session, status, out, err = ran
    assert status == 0, err
    html = session.with_name("V01_rotation.report.html")
    assert out.splitlines()[0] == str(html)
    assert html.is_file()


def test_the_page_holds_version_units_and_inline_figures_only(ran) -> None:
    session, *_ = ran
    text = session.with_name("V01_rotation.report.html").read_text(encoding="utf-8")
    assert psmat.__version__ in text
    for unit in ("kPa", "cm", "cm/s", "cm²", "Hz", "N·s", "kPa·s"):
        assert unit in text, unit
    page = _parse(text)
    assert len(page.images) >= 3  # pressure images, CoP, platform overlay
    assert all(src.startswith("data:image/png;base64,") for src in page.images)
    low = text.lower()
    assert "http://" not in low and "https://" not in low
    assert "<script" not in low and "<link" not in low and "url(" not in low
    assert "simulation" in text  # the session's metadata say psmat.synth wrote it


def test_what_was_recorded_is_what_the_simulation_wrote(ran) -> None:
    session, *_ = ran
    page = _parse(session.with_name("V01_rotation.report.html").read_text(encoding="utf-8"))
    rec = _table(page, "")
    assert rec["frames"] == [str(int(SECONDS * RATE_HZ))]
    assert rec["frame rate"] == [f"{RATE_HZ:.2f} Hz"]
    assert rec["duration"] == [f"{SECONDS:.2f} s"]
    assert "uncalibrated" in rec["pressure"][0]


def test_descriptors_all_72_with_units_and_sway_metrics(ran) -> None:
    session, *_ = ran
    page = _parse(session.with_name("V01_rotation.report.html").read_text(encoding="utf-8"))
    desc = _table(page, "descriptor")
    assert len(desc) == 72
    assert desc["confidence_ellipse_area_ML_AND_AP"][0] == "cm²"
    assert desc["critical_time_Diffusion_AP"][0] == "s"
    assert desc["mean_velocity_ML_AND_AP"][0] == "cm/s"
    sway = _table(page, "metric")
    assert sway["velocity_cm_s"][0] == "cm/s" and float(sway["velocity_cm_s"][1]) > 0


def test_the_platform_lag_is_the_simulators_truth(ran, study) -> None:
    session, *_ = ran
    page = _parse(session.with_name("V01_rotation.report.html").read_text(encoding="utf-8"))
    plat = {row[0]: row[1:] for t in page.tables for row in t if row and row[0].startswith(("lag", "Eu"))}
    truth = json.loads((study / "truth" / "sessions" / "V01_rotation.json").read_text())
    lag = float(plat["lag (platform time − mat time)"][0])
    assert lag == pytest.approx(truth["lag_s"], abs=1.0 / RATE_HZ)  # within one mat frame
    assert float(plat["Eu (eq. 3.1)"][0]) > 0 and plat["Eu (eq. 3.1)"][1] == "cm"


def test_conditions_from_markers_and_their_romberg_quotient(ran) -> None:
    session, *_ = ran
    host = load_session(session).host_time_s
    page = _parse(session.with_name("V01_rotation.report.html").read_text(encoding="utf-8"))
    cond = _tables(page, "condition")[0]
    header, rows = cond[0], {r[0]: r for r in cond[1:]}
    assert list(rows) == ["eyes open", "eyes closed"]
    assert rows["eyes open"][1] == "EO" and rows["eyes closed"][1] == "EC"
    k = header.index("duration (s)")
    assert float(rows["eyes open"][k]) == pytest.approx(SWITCH_S, rel=1e-3)
    assert float(rows["eyes closed"][k]) == pytest.approx(host[-1] - host[0] - SWITCH_S, rel=1e-3)
    assert rows["eyes open"][header.index("frames")] == str(int(SWITCH_S * RATE_HZ))
    assert rows["eyes open"][header.index("ISPGR")] == "short: 15.0 s < 25 s"  # 50 Hz is enough
    metrics = _table(page, "metric per condition")
    unit, eo, ec = metrics["velocity_cm_s"]
    quotient = float(_table(page, "quotient")["romberg_velocity_cm_s"][1])
    assert unit == "cm/s" and quotient == pytest.approx(float(ec) / float(eo), rel=2e-3)


def test_the_page_renders_in_headless_chromium_without_an_error(ran) -> None:
    import sys

    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
    from chromium import chromium_or_skip

    from psmat.bench.chromium import Chromium

    exe = chromium_or_skip()
    session, *_ = ran
    html = session.with_name("V01_rotation.report.html")
    with Chromium(exe, window=(1000, 800)) as browser:
        # before the page's own code could run: every error (a script's, a resource's) is recorded
        browser.send("Page.addScriptToEvaluateOnNewDocument", {"source": (
            "window.__errors = []; addEventListener('error', e => window.__errors.push(String(e.message || "
            "(e.target && (e.target.src || e.target.href)) || 'error')), true);"
            "const __ce = console.error; console.error = (...a) => { window.__errors.push(a.join(' ')); "
            "__ce(...a); };")})
        browser.navigate(html.resolve().as_uri())
        images = browser.evaluate("Array.from(document.images).map(i => [i.complete, i.naturalWidth])")
        errors = browser.evaluate("window.__errors")
        title = browser.evaluate("document.title")
    assert errors == []
    assert len(images) >= 3 and all(done and width > 0 for done, width in images)
    assert title == "psmat report: V01_rotation.h5"


def test_pdf_when_chromium_exists(ran) -> None:
    from psmat.bench.chromium import find_chromium

    session, status, out, err = ran
    pdf = session.with_name("V01_rotation.report.pdf")
    if find_chromium() is None:
        assert not pdf.exists() and "no PDF" in err
        pytest.skip("no Chromium on PATH: the report said so instead of a PDF")
    assert out.splitlines()[1] == str(pdf)
    assert pdf.read_bytes()[:5] == b"%PDF-"


# -- an imported session: values by hand ---------------------------------------------------------

PITCH_CM = 1.5
SHAPE = (6, 10)
LEFT, RIGHT = (1, 1), (4, 8)  # (row, column) of the two loaded cells
IMPORT_SECONDS = 10.0


@pytest.fixture(scope="module")
def imported(tmp_path_factory) -> Path:
    """Two cells: 10 ± 5 kPa in antiphase, a sine of 0.5 Hz sampled at 50 Hz (its peaks on samples)."""
    folder = tmp_path_factory.mktemp("imported")
    n = int(IMPORT_SECONDS * RATE_HZ)
    s = np.sin(2 * np.pi * 0.5 * np.arange(n) / RATE_HZ)
    frames = np.zeros((n, *SHAPE))
    frames[:, LEFT[0], LEFT[1]] = 10 + 5 * s
    frames[:, RIGHT[0], RIGHT[1]] = 10 - 5 * s
    csv = folder / "mat.csv"
    csv.write_text("\n".join(",".join(f"{v:g}" for v in f.ravel()) for f in frames) + "\n", encoding="utf-8")
    return import_pressure(csv, folder / "mat.h5", fmt="csv", shape=SHAPE, pitch_cm=PITCH_CM, rate_hz=RATE_HZ,
                           unit="kPa")


def test_session_pressure_takes_an_imported_sessions_kpa_as_stored(imported) -> None:
    rec = session_pressure(imported)
    assert rec.source.startswith("imported from csv")
    assert rec.pressure_kpa.dtype == np.float64 and rec.pressure_kpa.shape == (IMPORT_SECONDS * RATE_HZ, *SHAPE)
    assert rec.pressure_kpa[25, LEFT[0], LEFT[1]] == pytest.approx(15.0, rel=1e-6)  # sin = 1 at sample 25
    assert rec.pressure_kpa[25, RIGHT[0], RIGHT[1]] == pytest.approx(5.0, rel=1e-6)
    assert rec.geometry.pitch_cm == PITCH_CM and rec.usable.all()
    with pytest.raises(ValueError, match="no calibration"):
        session_pressure(imported, calibration="x.json")


def test_the_report_of_an_imported_session_gives_the_hand_values(imported, tmp_path) -> None:
    out = write_report(tmp_path / "imported.html", [ReportItem(imported, label="imported")],
                       params={"preset": None, "threshold_kpa": 4.0})  # below the 5 kPa trough: always loaded
    page = _parse(Path(out).read_text(encoding="utf-8"))
    # CoP = w·left + (1 − w)·right, w = (10 + 5 sin)/20 from 0.25 to 0.75: the range is half the distance
    sway = _table(page, "metric")
    assert float(sway["range_ml_cm"][1]) == pytest.approx(0.5 * (RIGHT[1] - LEFT[1]) * PITCH_CM, rel=1e-3)
    assert float(sway["range_ap_cm"][1]) == pytest.approx(0.5 * (RIGHT[0] - LEFT[0]) * PITCH_CM, rel=1e-3)
    regions = _table(page, "region")
    area_cm2 = PITCH_CM ** 2
    for side in ("left", "right"):
        cells, force, peak, contact = (float(v) for v in regions[side][:4])
        assert cells == 1
        assert force == pytest.approx(10.0 * area_cm2 * 0.1, rel=1e-3)  # 10 kPa on 2.25 cm² = 2.25 N (whole periods)
        assert peak == pytest.approx(15.0, rel=1e-3)
        assert contact == pytest.approx(area_cm2, rel=1e-3)
    rec = _table(page, "")
    assert rec["kind"] == ["pressure"]
    text = Path(out).read_text(encoding="utf-8")
    assert "short: 10.0 s &lt; 25 s" in text  # ISPGR: 10 s is under 25 s
    assert "simulation:" not in text


def test_a_marker_before_the_first_frame_names_the_condition_running_at_it(imported, tmp_path) -> None:
    # "eyes open" pressed 2 s before the recording began, "eyes closed" 5 s into it (of 10 s at 50 Hz):
    # the first 5 s are eyes open (250 frames), not unmarked, and a Romberg quotient exists
    out = write_report(tmp_path / "early.html", [ReportItem(imported, events=[(-2.0, "eyes open"), (5.0, "eyes closed")],
                                                            events_from_start=True)], params={"preset": None})
    page = _parse(Path(out).read_text(encoding="utf-8"))
    cond = _tables(page, "condition")[0]
    header, rows = cond[0], {r[0]: r for r in cond[1:]}
    assert list(rows) == ["eyes open", "eyes closed"]
    assert float(rows["eyes open"][header.index("start (s)")]) == 0.0
    assert float(rows["eyes open"][header.index("duration (s)")]) == pytest.approx(5.0, abs=1e-9)
    assert rows["eyes open"][header.index("frames")] == str(int(5.0 * RATE_HZ))
    assert "romberg_velocity_cm_s" in _table(page, "quotient")


def test_markers_in_seconds_from_the_start_without_the_flag_label_nothing(study, tmp_path) -> None:
    """The markers of the fixture above (0 and 15 s from the start) given as host-clock times, the
    flag forgotten: the recording's host clock counts from 1970, so none falls within an hour of it.
    They are not used, and the page says why; before, the marker at 15 s, before the recording on
    that clock, labelled the whole session "eyes closed"."""
    session = study / "sessions" / "V01_rotation.h5"
    out = write_report(tmp_path / "off.html", [ReportItem(session, events=[(0.0, "eyes open"), (SWITCH_S, "eyes closed")])],
                       params={"preset": None})
    text = Path(out).read_text(encoding="utf-8")
    page = _parse(text)
    assert not _tables(page, "condition")
    assert ("markers not used (markers given with the report (the session&#x27;s host clock): none within 1 h of the "
            "recording, so on another clock; seconds from the first frame are --events-from-start)") in text


def test_another_recordings_platform_file_is_said_to_align_poorly(study, tmp_path) -> None:
    """The rotation trial's page given the left-leg trial's platform file (a mix-up of names): their
    traces share no sway, and the page says so above the numbers that would otherwise read as a result."""
    session = study / "sessions" / "V01_rotation.h5"
    out = write_report(tmp_path / "mixup.html", [ReportItem(session, platform=study / "forceplate" / "V01_left-leg.csv")],
                       params={"preset": None})
    text = Path(out).read_text(encoding="utf-8")
    r = float(next(row[1] for t in _parse(text).tables for row in t if row and row[0] == "correlation at the lag"))
    assert r < POOR_ALIGNMENT_R
    assert (f"Poor alignment: the correlation at the best lag is {r:.2f}, below 0.6: the traces share no sway. Is "
            "V01_left-leg.csv this session&#x27;s platform file?") in text
    own = write_report(tmp_path / "own.html", [ReportItem(session, platform=study / "forceplate" / "V01_rotation.csv")],
                       params={"preset": None})
    assert "Poor alignment" not in Path(own).read_text(encoding="utf-8")


def test_a_platform_file_in_mm_read_as_cm_is_said_above_its_numbers(study, tmp_path) -> None:
    """A platform file whose header names no unit, written in mm: read as cm, ten times the mat's sway
    (before: its numbers beside the mat's as a result). The page says which unit fits."""
    plate = study / "forceplate" / "V01_rotation.csv"
    data = np.loadtxt(plate, delimiter=",", skiprows=1)
    in_mm = tmp_path / "in_mm.csv"
    np.savetxt(in_mm, np.c_[data[:, 0], data[:, 1:3] * 10, data[:, 3:]], delimiter=",", header="time,x,y,Fz",
               comments="")
    session = study / "sessions" / "V01_rotation.h5"
    out = write_report(tmp_path / "mm.html", [ReportItem(session, platform=in_mm)], params={"preset": None})
    text = Path(out).read_text(encoding="utf-8")
    said = text.split("The platform&#x27;s CoP spreads ")[1].split(" times the mat&#x27;s (about 1 expected): is "
                                                                 "in_mm.csv in mm, read as cm? (name the unit")
    assert len(said) == 2 and float(said[0]) > 4
    own = write_report(tmp_path / "own.html", [ReportItem(session, platform=plate)], params={"preset": None})
    assert "CoP spreads" not in Path(own).read_text(encoding="utf-8")


def test_a_platform_with_its_a_p_axis_reversed_is_named_and_turned(study, tmp_path) -> None:
    plate = study / "forceplate" / "V01_rotation.csv"
    data = np.loadtxt(plate, delimiter=",", skiprows=1)
    turned = tmp_path / "turned.csv"
    np.savetxt(turned, np.c_[data[:, 0], data[:, 1], -data[:, 2], data[:, 3:]], delimiter=",",
               header="time,x,y,Fz", comments="")
    session = study / "sessions" / "V01_rotation.h5"

    def page(platform, **params):
        out = write_report(tmp_path / "p.html", [ReportItem(session, platform=platform)], params={"preset": None, **params})
        text = Path(out).read_text(encoding="utf-8")
        Path(out).unlink()
        return text, {row[0]: row[1] for t in _parse(text).tables for row in t if row and row[0].startswith(("Eu", "lag"))}

    text, _ = page(turned)
    assert ("with the platform&#x27;s axes x,-y: they lie otherwise than the mat&#x27;s (psmat report "
            "--platform-axes=x,-y)") in text
    (text, fixed), (_, plain) = page(turned, platform_axes="x,-y"), page(plate)
    assert "Poor alignment" not in text and fixed == plain


def test_ispgr_and_descriptor_units_by_hand() -> None:
    assert ispgr(30.0, 50.0) == "ok"
    assert ispgr(20.0, 40.0) == "short: 20.0 s < 25 s; rate 40 Hz < 50 Hz"
    rng = np.random.default_rng(0)
    t = np.arange(0, 20, 0.02)
    walk = np.cumsum(rng.normal(0, 0.05, (t.size, 2)), axis=0)
    names = descriptors(t, walk[:, 0], walk[:, 1])
    units = {n: descriptor_unit(n) for n in names}  # a name without a unit is a KeyError
    assert len(units) == 72
    assert units["principal_sway_direction_ML_AND_AP"] == "deg" and units["LFS_ML_AND_AP"] == "1/cm"
    assert units["mean_distance_peak_Sway_Density"] == "cm" and units["mean_peak_Sway_Density"] == "s"
    assert units["total_power_Power_Spectrum_Density_AP"] == "cm²"
    # √(rms² + var(velocity)) adds cm² to (cm/s)²: its unit says so rather than claim cm
    assert units["phase_plane_parameter_ML"] == units["phase_plane_parameter_AP"] == "√(cm² + (cm/s)²)"


# -- bad input -----------------------------------------------------------------------------------


@pytest.mark.parametrize("extra, words", [
    (["--platform", "a.csv", "--platform", "b.csv"], "--platform given 2 time(s) for 1 session(s)"),
    (["--events", "missing.csv"], "no such file"),
    (["--threshold-kpa", "-1"], "--threshold-kpa: must be a finite number >= 0"),
    (["--threshold-kpa", "nan"], "--threshold-kpa: must be a finite number >= 0"),
])
def test_bad_input_is_one_line_and_status_1(study, capsys, extra, words) -> None:
    status = main(["report", str(study / "sessions" / "V01_left-leg.h5"), *extra, "-o", "x.html"])
    err = capsys.readouterr().err
    assert status == 1
    assert words in err and err.count("\n") == 1 and err.startswith("psmat report: ")


def test_a_file_that_is_no_session_and_an_existing_output_are_refused(tmp_path, capsys, study) -> None:
    bad = tmp_path / "bad.h5"
    bad.write_text("not a session\n")
    assert main(["report", str(bad), "-o", str(tmp_path / "r.html")]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "bad.h5" in err
    out = tmp_path / "exists.html"
    out.write_text("keep me")
    assert main(["report", str(study / "sessions" / "V01_left-leg.h5"), "-o", str(out)]) == 1
    assert "--overwrite" in capsys.readouterr().err and out.read_text() == "keep me"


def test_two_sessions_make_one_page_and_no_pdf_engine_is_one_line(study, tmp_path, monkeypatch) -> None:
    monkeypatch.setenv("PSMAT_CHROMIUM", str(tmp_path / "no-such-browser"))  # and WeasyPrint is not required
    items = [ReportItem(study / "sessions" / f"V01_{t}.h5", study / "forceplate" / f"V01_{t}.csv")
             for t in ("left-leg", "right-leg")]
    result = write_report(tmp_path / "two.html", items, title="two trials", pdf=True)
    text = Path(result).read_text(encoding="utf-8")
    assert text.count('<section id="session-') == 2
    assert "V01_left-leg.h5" in text and "V01_right-leg.h5" in text
    try:
        import weasyprint  # noqa: F401
    except ImportError:
        assert result.pdf is None and result.pdf_note.startswith("no PDF: neither Chromium")
        assert not (tmp_path / "two.pdf").exists()
    else:
        assert result.pdf == tmp_path / "two.pdf" and result.pdf_note == "PDF by WeasyPrint"


def test_the_ispgr_sentence_states_the_limits_it_checked(imported, tmp_path) -> None:
    # 10 s at 50 Hz checked against 5 s and 40 Hz: ok, and the page says which limits it used
    out = write_report(tmp_path / "limits.html", [imported],
                       params={"preset": None, "ispgr_min_duration_s": 5.0, "ispgr_min_rate_hz": 40.0})
    text = Path(out).read_text(encoding="utf-8")
    assert "at least 5 s, at least 40 Hz): <b>ok</b>" in text
    assert "at least 25 s" not in text

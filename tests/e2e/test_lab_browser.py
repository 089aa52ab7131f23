"""``psmat lab --simulate`` and its page in a real browser: headless Chromium over DevTools.

The server is the real command in a child process (the digital twin on a pseudo-terminal, the
real session writer); the page is the shipped one, loaded from the server with the token the
server printed. The page is driven as a person drives it (fill the fields, click the buttons)
and what it did is checked where it lands: the session file in the data folder.

``PSMAT_UPDATE_FIGURES=1`` writes the screenshot to docs/figures/lab.png (the README's);
otherwise it goes to a temporary folder.
"""

from __future__ import annotations

import json
import os
import struct
import time
from pathlib import Path

import numpy as np
import pytest
from chromium import Chromium, chromium_or_skip

pytest.importorskip("starlette", reason="psmat lab needs the lab extra (starlette, uvicorn)")
pytest.importorskip("uvicorn", reason="psmat lab needs the lab extra (starlette, uvicorn)")

from psmat.bench.lab_page import serve_lab  # noqa: E402
from psmat.io import load_session  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
FIGURE = ROOT / "docs" / "figures" / "lab.png"
#: how long the page may take to do what it is asked (s): a hang guard, not a performance claim
GUARD_S = 60.0

#: the page's element ids (psmat/lab/static/index.html), as the lab's tests and benchmark use them: selector -> tag
ELEMENTS = {"#raw": "CANVAS", "#pressure": "CANVAS", "#cop": "CANVAS", "#rates": None, "#subject": "INPUT",
            "#trial": "INPUT", "#note": None, "#record": "BUTTON", "button.marker[data-label]": "BUTTON",
            "#play": "BUTTON", "#pause": "BUTTON", "#seek": "INPUT", "#speed": "SELECT", "#sway": None}


@pytest.fixture(scope="module")
def lab(tmp_path_factory):
    """(server, browser, data folder): ``psmat lab --simulate`` with its page open in Chromium."""
    exe = chromium_or_skip()
    data = tmp_path_factory.mktemp("lab-data")
    with serve_lab(data) as server, Chromium(exe, timeout_s=GUARD_S) as browser:
        browser.navigate(server.url)
        yield server, browser, data


def _lab_state(browser: Chromium) -> dict:
    return browser.evaluate("JSON.parse(JSON.stringify(window.psmatLab || null))") or {}


def _set_field(browser: Chromium, selector: str, value: str) -> None:
    """Type ``value`` into a field as a person would: set it and fire input and change."""
    browser.evaluate(f"(() => {{ const e = document.querySelector({json.dumps(selector)});"
                     f" e.value = {json.dumps(value)};"
                     " e.dispatchEvent(new Event('input', {bubbles: true}));"
                     " e.dispatchEvent(new Event('change', {bubbles: true})); return e.value; })()")


def test_the_page_loads_with_its_controls(lab) -> None:
    _server, browser, _data = lab
    assert browser.evaluate("document.title") == "psmat lab"
    tags = browser.evaluate("(() => { const out = {}; for (const s of %s) { const e = document.querySelector(s);"
                           " out[s] = e ? e.tagName : null; } return out; })()" % json.dumps(list(ELEMENTS)))
    missing = [s for s, tag in tags.items() if tag is None]
    assert not missing, f"the page lacks {missing}"
    wrong = {s: tags[s] for s, tag in ELEMENTS.items() if tag is not None and tags[s] != tag}
    assert not wrong, f"elements of another kind than the plan's: {wrong}"
    assert browser.evaluate("document.querySelector('#seek').type") == "range"
    labels = browser.evaluate("[...document.querySelectorAll('button.marker[data-label]')].map(b => b.dataset.label)")
    assert labels and all(label.strip() for label in labels)


def test_the_page_connects_and_draws_frames(lab) -> None:
    _server, browser, _data = lab
    browser.wait_for("window.psmatLab && window.psmatLab.connected === true", timeout_s=GUARD_S)
    first = browser.wait_for("window.psmatLab.framesDrawn > 0 && window.psmatLab.framesDrawn", timeout_s=GUARD_S)
    time.sleep(2.0)
    later = browser.wait_for(f"window.psmatLab.framesDrawn > {first} && window.psmatLab.framesDrawn",
                             timeout_s=GUARD_S)
    assert later > first
    state = _lab_state(browser)
    assert state["connected"] is True
    assert isinstance(state["lastFrameDeviceTimeUs"], (int, float)) and state["lastFrameDeviceTimeUs"] >= 0
    # the raw image is not blank: the twin's swaying person loads some cells and not others
    colours = browser.evaluate(
        "(() => { const c = document.querySelector('#raw'); const d = c.getContext('2d')"
        ".getImageData(0, 0, c.width, c.height).data; const s = new Set();"
        " for (let i = 0; i < d.length; i += 4) s.add((d[i] << 16) | (d[i + 1] << 8) | d[i + 2]); return s.size; })()")
    assert colours > 2
    assert browser.evaluate("document.querySelector('#warnings').hidden") is True  # the twin: nothing went wrong


def test_a_click_on_record_records_the_trial_with_its_marker(lab) -> None:
    server, browser, data = lab
    browser.wait_for("window.psmatLab && window.psmatLab.framesDrawn > 0", timeout_s=GUARD_S)
    before = set(data.glob("*.h5"))
    _set_field(browser, "#subject", "s07")
    _set_field(browser, "#trial", "eyes-closed")
    browser.click("#record")
    _wait_recording(server, True)
    _wait_recorded(server, 20)  # frames before the marker
    label = browser.evaluate("document.querySelector('button.marker[data-label]').dataset.label")
    browser.click("button.marker[data-label]")
    _wait_marker_sent(server)
    _wait_recorded(server, server.api("/api/status")["record"]["frames"] + 20)  # and after it
    browser.click("#record")  # stop
    _wait_recording(server, False)
    new = sorted(set(data.glob("*.h5")) - before)
    assert len(new) == 1, f"one new session file expected in the data folder, found {new}"
    assert new[0].name.startswith("s07_eyes-closed_")
    s = load_session(new[0])
    assert s.complete
    assert len(s.counts) > 0 and s.valid.all()
    seq = np.asarray(s.seq)
    assert np.all(np.diff(seq) == 1), "frames lost between the device and the session file"
    # the twin's clock: frames on the grid of its 1/100 s timer (the psm16 profile's rate); a tick the
    # twin's thread ran late for is lost as a timer's missed interrupt would be (twin/serial_twin.py),
    # so a step is a whole number of periods, not always one (a loaded machine skips some)
    steps = np.diff(np.asarray(s.device_time_us)) / 1e4
    assert np.all(steps >= 1 - 1e-4) and np.allclose(steps, np.round(steps), atol=1e-4), steps
    # the marker, on the session's host clock, lies inside the recorded trial
    marks = [(t, text) for t, text in s.events if text == label]
    assert len(marks) == 1, s.events
    assert s.host_time_s[0] <= marks[0][0] <= s.host_time_s[-1]
    # the page shows the trial's sway metrics once stopped, and offers to record again
    cells = browser.wait_for("document.querySelector('#sway table') && "
                             "[...document.querySelectorAll('#sway td')].map(td => td.textContent)", timeout_s=GUARD_S)
    values = [float(c.split()[0]) for c in cells[1::2]]
    assert len(values) >= 2 and all(np.isfinite(values)) and all(v >= 0 for v in values), cells
    browser.wait_for("document.querySelector('#record').textContent.includes('Start')", timeout_s=GUARD_S)


def test_a_screenshot_of_the_page(lab, tmp_path) -> None:
    _server, browser, _data = lab
    browser.wait_for("window.psmatLab && window.psmatLab.framesDrawn > 10", timeout_s=GUARD_S)
    target = FIGURE if os.environ.get("PSMAT_UPDATE_FIGURES") == "1" else tmp_path / "lab.png"
    height = browser.evaluate("document.documentElement.scrollHeight")  # the whole page, controls included
    browser.set_viewport(1280, height)
    try:
        drawn = browser.evaluate("window.psmatLab.framesDrawn")  # a frame drawn at the new size
        browser.wait_for(f"window.psmatLab.framesDrawn > {drawn} + 2", timeout_s=GUARD_S)
        png = browser.screenshot(target).read_bytes()
    finally:
        browser.set_viewport(1280, 860)
    assert png[:8] == b"\x89PNG\r\n\x1a\n"
    assert struct.unpack(">II", png[16:24]) == (1280, height)


def _wait_recording(server, recording: bool) -> None:
    deadline = time.monotonic() + GUARD_S
    while server.api("/api/status").get("recording") is not recording:
        if time.monotonic() > deadline:
            pytest.fail(f"the server's status never said recording={recording} after the click")
        time.sleep(0.05)


def _wait_recorded(server, n: int) -> None:
    """Wait until the running recording holds at least ``n`` frames (not a fixed time: a loaded
    machine may deliver none in it)."""
    deadline = time.monotonic() + GUARD_S
    while ((server.api("/api/status").get("record") or {}).get("frames", 0)) < n:
        if time.monotonic() > deadline:
            pytest.fail(f"the recording never held {n} frames")
        time.sleep(0.05)


def _wait_marker_sent(server) -> None:
    """Markers go out with fetch(): wait until the running recording counts the event."""
    deadline = time.monotonic() + GUARD_S
    while (server.api("/api/status").get("record") or {}).get("events", 0) < 1:
        if time.monotonic() > deadline:
            pytest.fail("the marker never reached the recording")
        time.sleep(0.05)


# after the screenshot: the open-circuit step leaves a burst of noise in the page's CoP trace
def test_the_calibration_panel_walks_through_the_first_step(lab) -> None:
    server, browser, data = lab
    for sel in ("#calibrate", "#cal-step", "#cal-record", "#cal-finish", "#cal-cancel", "#cal-result"):
        assert browser.evaluate(f"!!document.querySelector({json.dumps(sel)})"), f"the page lacks {sel}"
    browser.click("#calibrate")
    step = browser.wait_for("document.querySelector('#cal-step').textContent.includes('Unplug') && "
                            "document.querySelector('#cal-step').textContent", timeout_s=GUARD_S)
    assert step.startswith("Step 1 of 5")   # the open step, then the four corners
    assert server.api("/api/status")["calibration"]["active"] is True
    browser.click("#cal-record")   # the twin unplugs its mat itself: the open circuit reads near full scale
    line = browser.wait_for("[...document.querySelectorAll('#cal-diag li')].map(li => li.textContent)"
                            ".find(t => t.startsWith('open:'))", timeout_s=GUARD_S)
    assert float(line.split("mean ")[1].split()[0]) > 0.99 * 4095, line
    assert "row 0 to column 0" in browser.evaluate("document.querySelector('#cal-step').textContent")
    browser.click("#cal-cancel")
    deadline = time.monotonic() + GUARD_S
    while server.api("/api/status")["calibration"] is not None:
        if time.monotonic() > deadline:
            pytest.fail("the server's calibration walk-through never ended after Cancel")
        time.sleep(0.05)
    assert not (data / "calibration").exists()   # cancelled: no file


def test_the_page_says_what_the_device_counters_say_went_wrong(tmp_path) -> None:
    """A do-it-yourself mat (the 10-bit arduino16 twin on a real pty) read under a 12-bit profile: its
    counts fit, every empty cell reads as a loaded one, and the page drew a pressed mat with nothing
    said. Now the page lists what psmat record would say after the recording, while the mat runs."""
    from csv_twin import csv_twin
    from psmat.bench.lab_page import LabServer
    from psmat.profile import load_profile

    exe = chromium_or_skip()
    wide = tmp_path / "arduino16-12bit.toml"
    wide.write_text(load_profile("arduino16").to_toml().replace("bits = 10", "bits = 12"), encoding="utf-8")
    with csv_twin(rate_hz=20) as port, \
            LabServer([port, "--profile", str(wide), "--no-browser", "--port", "0", "--data", str(tmp_path / "d")],
                      timeout_s=GUARD_S) as server, Chromium(exe, timeout_s=GUARD_S) as browser:
        browser.navigate(server.url)
        # the band and its items read at one moment: the line counts the frames, which go on arriving
        shown, items = browser.wait_for(
            "(() => { const w = document.querySelector('#warnings');"
            " return !w.hidden && [w.textContent,"
            " [...document.querySelectorAll('#warnings li')].map(li => li.textContent)]; })()", timeout_s=GUARD_S)
    assert len(items) == 1 and items[0] in shown
    assert items[0].startswith("no count above 10") and items[0].endswith(
        "(12 bits): is the board's ADC 10-bit? Every cell then reads as loaded: record with --bits 10 (or a "
        "profile with bits = 10)")

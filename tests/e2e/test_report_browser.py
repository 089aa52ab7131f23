"""A ``psmat report`` page looked at in a real browser: headless Chromium over DevTools.

The session is a simulated Romberg trial (``psmat.synth.simulate_study(..., romberg=True)``: an
eyes-open then an eyes-closed BDS trial in one mat session with its markers) with its force-platform
file; the page is the one :func:`psmat.report.write_report` writes. It must render with every image
decoded, no script or resource error, its sections in the order the report writes them, and the
screenshot must be a PNG of the viewport's size.

``PSMAT_UPDATE_FIGURES=1`` writes the screenshot to docs/figures/report.png (docs/clinical.md's);
otherwise it goes to a temporary folder.
"""

from __future__ import annotations

import os
import struct
from pathlib import Path

import pytest
from chromium import Chromium, chromium_or_skip

from psmat.report import ReportItem, write_report
from psmat.synth import simulate_study

ROOT = Path(__file__).resolve().parents[2]
FIGURE = ROOT / "docs" / "figures" / "report.png"
#: the viewport, CSS px: the screenshot's size (the top of the page: the recording, pressure, CoP)
WINDOW = (1000, 1640)
#: how long the page may take to load (s): a hang guard, not a performance claim
GUARD_S = 60.0
#: the section headings the report writes for a standing session with a platform and markers, in order
SECTIONS = ["What was recorded", "Pressure", "Centre of pressure", "Sway metrics", "Posturography descriptors",
            "Regions", "Conditions", "Force platform", "Processing parameters"]


@pytest.fixture(scope="module")
def page(tmp_path_factory) -> Path:
    root = simulate_study(tmp_path_factory.mktemp("report-browser") / "study", volunteers=1, duration_s=10.0,
                          seed=3, rate_hz=50.0, romberg=True)
    item = ReportItem(root / "sessions" / "V01_romberg.h5", root / "forceplate" / "V01_romberg.csv")
    return Path(write_report(root / "V01_romberg.report.html", [item], subject="V01 (simulation)"))


def test_the_report_renders_and_its_screenshot_is_taken(page, tmp_path) -> None:
    exe = chromium_or_skip()
    target = FIGURE if os.environ.get("PSMAT_UPDATE_FIGURES") == "1" else tmp_path / "report.png"
    with Chromium(exe, window=WINDOW, timeout_s=GUARD_S) as browser:
        # before the page could run anything: every error (a script's, a resource's) is recorded
        browser.send("Page.addScriptToEvaluateOnNewDocument", {"source": (
            "window.__errors = []; addEventListener('error', e => window.__errors.push(String(e.message || "
            "(e.target && (e.target.src || e.target.href)) || 'error')), true);"
            "const __ce = console.error; console.error = (...a) => { window.__errors.push(a.join(' ')); "
            "__ce(...a); };")})
        browser.navigate(page.resolve().as_uri())
        browser.wait_for("document.readyState === 'complete' && Array.from(document.images).every(i => i.complete)",
                         timeout_s=GUARD_S)
        images = browser.evaluate("Array.from(document.images).map(i => [i.naturalWidth, i.naturalHeight])")
        errors = browser.evaluate("window.__errors")
        headings = browser.evaluate("Array.from(document.querySelectorAll('h3')).map(h => h.textContent)")
        simulated = browser.evaluate("document.body.innerText.includes('simulation')")
        png = browser.screenshot(target).read_bytes()
    assert errors == []
    assert len(images) >= 3 and all(w > 0 and h > 0 for w, h in images), images  # pressure, CoP, overlay
    found = [next((k for k, h in enumerate(headings) if h.startswith(s)), None) for s in SECTIONS]
    assert None not in found, dict(zip(SECTIONS, found))
    assert found == sorted(found), headings
    assert simulated  # the session's metadata say a simulator wrote it, and the page says so
    assert png[:8] == b"\x89PNG\r\n\x1a\n"
    assert struct.unpack(">II", png[16:24]) == WINDOW

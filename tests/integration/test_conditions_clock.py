"""The report and the study put the same frames in a condition (docs/spec.md §7 "Events,
conditions, Romberg"): both bring the markers from the host clock to the frame clock with
:func:`psmat.balance.frame_clock` and cut them with :func:`psmat.balance.condition_spans`.

A simulated 10 s mat session (``psmat.synth.simulate_study``, 50 Hz) is written again with a
regular device clock (frame k at k · 20 ms) and host arrival times in bursts: frames 5j … 5j + 4
arrive together at 100.1 + 0.1·j s. "eyes open" is pressed before the recording (100 s), "eyes
closed" at the arrival of the burst of frames 250–254 (105.1 s): the newest frame the host had
then is 254, at 5.08 s on the frame clock. So by hand: eyes open = frames 0–253 (254 frames,
5.08 s), eyes closed = frames 254–499 (246 frames, 9.98 − 5.08 = 4.90 s). Cut on host arrival
times instead, eyes open would hold 250 frames and last 5.0 host seconds.
"""

from __future__ import annotations

from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pytest

from psmat.io import SessionWriter, load_session
from psmat.report import ReportItem, write_report
from psmat.study import process_trial
from psmat.synth import simulate_study

N, STEP_S, BURST = 500, 0.02, 5
EVENTS = [(100.0, "eyes open"), (105.1, "eyes closed")]
EXPECTED = {"eyes open": (254, 5.08), "eyes closed": (246, 4.90)}  # frames, duration (s, frame clock)


class _Cells(HTMLParser):
    """Every table row of a page as its cells' texts."""

    def __init__(self) -> None:
        super().__init__()
        self.rows: list[list[str]] = []
        self._cell: list[str] | None = None

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        if tag == "tr":
            self.rows.append([])
        elif tag in ("td", "th"):
            self._cell = []

    def handle_endtag(self, tag: str) -> None:
        if tag in ("td", "th") and self._cell is not None:
            self.rows[-1].append("".join(self._cell).strip())
            self._cell = None

    def handle_data(self, data: str) -> None:
        if self._cell is not None:
            self._cell.append(data)


@pytest.fixture(scope="module")
def bursty(tmp_path_factory) -> Path:
    root = simulate_study(tmp_path_factory.mktemp("bursts") / "study", volunteers=1, duration_s=N * STEP_S, seed=3,
                          rate_hz=1 / STEP_S)
    s = load_session(root / "sessions" / "V01_left-leg.h5")
    assert s.n_frames >= N and s.device_time_us is not None
    k = np.arange(N)
    host = 100.1 + 0.1 * (k // BURST)
    out = tmp_path_factory.mktemp("bursty") / "bursty.h5"
    with SessionWriter(out, s.counts.shape[1:], device=s.device, calibration=s.calibration, metadata=s.metadata,
                       profile=s.profile) as w:
        w.append(s.counts[:N], host, np.ones(N, bool), seq=k, device_time_us=k * round(STEP_S * 1e6))
    return out


def test_the_report_and_the_study_put_the_same_frames_in_each_condition(bursty, tmp_path) -> None:
    page = write_report(tmp_path / "r.html", [ReportItem(bursty, events=EVENTS)], params={"preset": None})
    p = _Cells()
    p.feed(Path(page).read_text(encoding="utf-8"))
    header = next(r for r in p.rows if r and r[0] == "condition")
    rows = {r[0]: r for r in p.rows if r and r[0] in EXPECTED}
    assert list(rows) == ["eyes open", "eyes closed"]
    for label, (frames, duration) in EXPECTED.items():
        assert rows[label][header.index("frames")] == str(frames)
        assert float(rows[label][header.index("duration (s)")]) == pytest.approx(duration, abs=1e-6)
    assert float(rows["eyes closed"][header.index("start (s)")]) == pytest.approx(5.08, abs=1e-6)

    study = process_trial(bursty, None, "V01", "left-leg", None, {"variants": ["PROP"], "preprocess": None},
                          events=EVENTS)
    durations = {r["condition"]: r["duration_s"] for r in study if r["variant"] == "PROP" and r["condition"]}
    assert list(durations) == ["eyes open", "eyes closed"]
    for label, (_, duration) in EXPECTED.items():
        assert durations[label] == pytest.approx(duration, abs=1e-6)

"""``psmat lab``: the real server in a subprocess, over real HTTP and WebSocket on loopback.

``psmat lab --simulate --no-browser --port 0 --data DIR`` serves the digital twin; the tests
read the page's address from its first line of output. Without the token nothing answers
and nothing is written; with it a trial is recorded with markers and its file checked
against what the device counted; a client that never reads its WebSocket costs the recording
nothing (every frame between the first and the last is in the file, seq without a gap);
a request naming a path outside the data folder stays inside it or is refused.
"""

from __future__ import annotations

import base64
import json
import os
import re
import signal
import socket
import subprocess
import sys
import time
import urllib.error
import urllib.request
from pathlib import Path
from typing import Any

import numpy as np
import pytest

pytest.importorskip("starlette")
pytest.importorskip("uvicorn")
websockets_sync = pytest.importorskip("websockets.sync.client")

from psmat.io import journal_path, load_session  # noqa: E402
from psmat.process import session_clock  # noqa: E402

from conftest import child_preexec  # noqa: E402
from csv_twin import csv_twin  # noqa: E402
from small_disk import small_disk  # noqa: E402

URL = re.compile(r"^http://127\.0\.0\.1:(\d+)/\?token=([A-Za-z0-9_-]{43})$")
#: element ids the page must have (the lab's contract with the browser tests and the benchmark)
PAGE_IDS = ("raw", "pressure", "cop", "rates", "subject", "trial", "note", "record", "sessions", "play", "pause",
            "seek", "speed", "sway", "calibrate", "cal-step", "cal-record", "cal-finish", "cal-cancel", "cal-result")


class Lab:
    """A running ``psmat lab`` subprocess: its address, token and data folder."""

    def __init__(self, data: Path, *extra: str, source: tuple[str, ...] = ("--simulate",)) -> None:
        self.data = data
        self.proc = subprocess.Popen([sys.executable, "-m", "psmat", "lab", *source, "--no-browser", "--port", "0",
                                      "--data", str(data), *extra], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                     text=True, preexec_fn=child_preexec())
        line = self.proc.stdout.readline().strip()
        m = URL.match(line)
        if not m:
            self.proc.kill()
            raise AssertionError(f"first line {line!r}; stderr: {self.proc.stderr.read()}")
        self.url, self.port, self.token = line, int(m.group(1)), m.group(2)
        self.base = f"http://127.0.0.1:{self.port}"

    def request(self, method: str, path: str, body: dict | None = None, token: str | None = "") -> tuple[int, dict]:
        """(status, JSON body); ``token`` "" uses the lab's, None sends none."""
        tok = self.token if token == "" else token
        headers = {"Content-Type": "application/json"}
        if tok is not None:
            headers["Authorization"] = f"Bearer {tok}"
        data = None if body is None else json.dumps(body).encode()
        req = urllib.request.Request(self.base + path, data=data, method=method, headers=headers)
        try:
            with urllib.request.urlopen(req, timeout=60) as resp:
                raw = resp.read()
                status = resp.status
        except urllib.error.HTTPError as exc:
            with exc:  # the error response holds the connection: closed here, not by the garbage collector
                raw, status = exc.read(), exc.code
        try:
            return status, json.loads(raw)
        except ValueError:
            return status, {"_text": raw.decode("utf-8", "replace")}

    def get_text(self, path: str) -> tuple[int, str]:
        try:
            with urllib.request.urlopen(self.base + path, timeout=30) as resp:
                return resp.status, resp.read().decode()
        except urllib.error.HTTPError as exc:
            with exc:
                return exc.code, exc.read().decode()

    def stop(self) -> int:
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)
            try:
                self.proc.wait(30)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        self.proc.stdout.close()
        self.proc.stderr.close()
        return self.proc.returncode


@pytest.fixture(scope="module")
def lab(tmp_path_factory: pytest.TempPathFactory):
    data = tmp_path_factory.mktemp("lab") / "data"
    lab = Lab(data)
    yield lab
    lab.stop()


def _wait_frames(lab: Lab, n: int) -> dict:
    """The status once the device has delivered at least ``n`` frames."""
    for _ in range(600):
        status, st = lab.request("GET", "/api/status")
        assert status == 200
        if st["device"]["counters"]["frames"] >= n:
            return st
        time.sleep(0.05)
    raise AssertionError(f"fewer than {n} frames: {st}")


def test_first_line_is_the_address_with_a_fresh_token(lab: Lab) -> None:
    assert lab.port > 0 and URL.match(lab.url)


def test_without_the_token_nothing_answers_and_nothing_is_written(lab: Lab) -> None:
    before = sorted(os.listdir(lab.data))
    for token in (None, "wrong" + lab.token[5:]):
        for method, path, body in (("GET", "/api/status", None), ("GET", "/api/sessions", None),
                                   ("POST", "/api/record/start", {"subject": "nope", "trial": "t", "note": ""}),
                                   ("POST", "/api/marker", {"label": "x"}), ("POST", "/api/record/stop", {}),
                                   ("POST", "/api/replay/open", {"session": "x.h5"}), ("GET", "/", None),
                                   ("GET", "/static/app.js", None)):
            status, out = lab.request(method, path, body, token=token)
            assert status == 401, (method, path, status, out)
    for query in ("", "?token=", f"?token={lab.token[:-1]}"):
        assert lab.get_text("/" + query)[0] == 401
        status_line = _handshake_status(lab.port, query)   # a raw handshake, its socket closed here
        assert status_line.startswith((b"HTTP/1.1 403", b"HTTP/1.1 401")), status_line
    assert sorted(os.listdir(lab.data)) == before
    status, st = lab.request("GET", "/api/status")
    assert status == 200 and st["recording"] is False


def test_page_and_assets_are_served_with_the_token(lab: Lab) -> None:
    status, html = lab.get_text(f"/?token={lab.token}")
    assert status == 200
    for ident in PAGE_IDS:
        assert f'id="{ident}"' in html, ident
    assert html.count('class="marker"') == 9 and 'data-label="' in html
    assert "http://" not in html and "https://" not in html   # nothing from elsewhere: works offline
    for name, needle in (("app.js", "window.psmatLab"), ("style.css", "canvas")):
        status, text = lab.get_text(f"/static/{name}?token={lab.token}")
        assert status == 200 and needle in text
    for name in ("framesDrawn", "lastFrameDeviceTimeUs", "lastLatencyMs", "connected"):
        assert name in lab.get_text(f"/static/app.js?token={lab.token}")[1]
    assert lab.get_text(f"/static/../_app.py?token={lab.token}")[0] == 404


def test_websocket_delivers_display_frames(lab: Lab) -> None:
    _wait_frames(lab, 20)
    with websockets_sync.connect(f"ws://127.0.0.1:{lab.port}/ws?token={lab.token}", open_timeout=10) as ws:
        hello = json.loads(ws.recv(timeout=10))
        assert hello["type"] == "hello" and hello["status"]["device"]["shape"] == [16, 16]
        frames = [json.loads(ws.recv(timeout=10)) for _ in range(5)]
    seqs = [f["seq"] for f in frames]
    assert all(f["type"] == "frame" for f in frames) and seqs == sorted(seqs) and len(set(seqs)) == 5
    for f in frames:
        r, c = f["shape"]
        counts = np.frombuffer(base64.b64decode(f["counts"]), "<u2")
        pressure = np.frombuffer(base64.b64decode(f["pressure"]), "<f4")
        assert (r, c) == (16, 16) and counts.size == pressure.size == r * c
        assert counts.max() <= 4095 and [int(counts.min()), int(counts.max())] == f["counts_range"]
        assert np.all(np.isfinite(pressure)) and pressure.min() >= 0 and pressure.max() > 0   # someone stands
        x0, x1, y0, y1 = f["extent_cm"]   # the CoP of a person standing on the mat lies on the mat
        assert f["cop_cm"] is not None and x0 <= f["cop_cm"][0] <= x1 and y0 <= f["cop_cm"][1] <= y1


def _handshake_status(port: int, query: str) -> bytes:
    """The status line the server answers a WebSocket handshake on ``/ws{query}`` with (the socket is
    closed before returning: a refused client library handshake may leave its socket to the collector)."""
    key = base64.b64encode(os.urandom(16)).decode()
    with socket.create_connection(("127.0.0.1", port), timeout=10) as s:
        s.sendall((f"GET /ws{query} HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nUpgrade: websocket\r\n"
                   f"Connection: Upgrade\r\nSec-WebSocket-Key: {key}\r\nSec-WebSocket-Version: 13\r\n\r\n").encode())
        head = b""
        while b"\r\n" not in head:
            chunk = s.recv(1)
            if not chunk:
                break
            head += chunk
    return head


def _stalled_client(port: int, token: str) -> socket.socket:
    """A WebSocket client that completes the handshake and then never reads (a tiny receive buffer)."""
    s = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    s.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 2048)
    s.connect(("127.0.0.1", port))
    key = base64.b64encode(os.urandom(16)).decode()
    s.sendall((f"GET /ws?token={token} HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nUpgrade: websocket\r\n"
               f"Connection: Upgrade\r\nSec-WebSocket-Key: {key}\r\nSec-WebSocket-Version: 13\r\n\r\n").encode())
    head = b""
    while b"\r\n\r\n" not in head:
        head += s.recv(1)
    assert head.startswith(b"HTTP/1.1 101"), head
    return s


def test_a_trial_with_markers_is_recorded_whole_while_a_client_never_reads(lab: Lab) -> None:
    _wait_frames(lab, 20)
    stalled = _stalled_client(lab.port, lab.token)
    try:
        status, st = lab.request("GET", "/api/status")
        assert st["clients"] >= 1
        status, started = lab.request("POST", "/api/record/start",
                                      {"subject": "P01", "trial": "eyes-open", "note": "quiet stance, é"})
        assert status == 201, started
        path = Path(started["session"])
        assert path.parent == lab.data.resolve() and path.name.startswith("P01_eyes-open_")
        status, again = lab.request("POST", "/api/record/start", {"subject": "P01", "trial": "t2", "note": ""})
        assert status == 409, again   # one writer per session
        times = []
        for label in ("eyes closed", "eyes open"):
            st = _wait_frames(lab, lab.request("GET", "/api/status")[1]["device"]["counters"]["frames"] + 50)
            status, out = lab.request("POST", "/api/marker", {"label": label})
            assert status == 200 and out["label"] == label
            times.append(out["host_time_s"])
        _wait_frames(lab, lab.request("GET", "/api/status")[1]["device"]["counters"]["frames"] + 100)
        status, stopped = lab.request("POST", "/api/record/stop", {})
        assert status == 200, stopped
    finally:
        stalled.close()
    assert stopped["session"] == str(path) and stopped["events"] == 2
    s = load_session(path)
    assert s.complete and not journal_path(path).exists()
    assert s.n_frames == stopped["frames"] >= 200   # the test waited for 200 frames of the device while recording
    # every frame the device sent between the first and the last recorded one is in the file
    np.testing.assert_array_equal(s.seq, s.seq[0] + np.arange(s.n_frames))
    assert s.valid.all() and s.counters["dropped_frames"] == 0
    assert stopped["device_counters"]["dropped_wire"] == 0
    ev_times = [t for t, _ in s.events]
    labels = [label for _, label in s.events]
    assert labels == ["eyes closed", "eyes open"]
    np.testing.assert_allclose(ev_times, times)
    assert s.host_time_s[0] < ev_times[0] < ev_times[1] < s.host_time_s[-1]
    assert s.metadata["subject"] == "P01" and s.metadata["trial"] == "eyes-open"
    assert s.metadata["note"] == "quiet stance, é"
    assert s.profile is not None and s.profile["name"] == "psm16"
    sway = stopped["sway"]["metrics"]
    assert sway is not None and sway["path_cm"] > 0 and sway["sd_ml_cm"] > 0 and sway["area95_cm2"] > 0
    (lab.data / f"._{path.name}").write_bytes(b"\x00\x05\x16\x07Mac OS X" + bytes(4000))  # a Mac's copy beside it
    status, listed = lab.request("GET", "/api/sessions")
    assert path.name in [r["name"] for r in listed["sessions"]]
    assert f"._{path.name}" not in [r["name"] for r in listed["sessions"]]  # (before: listed, and replay failed)
    status, st = lab.request("GET", "/api/status")
    assert st["recording"] is False and st["device"]["counters"]["connected"]   # the server lived on


def test_requests_cannot_leave_the_data_folder(lab: Lab) -> None:
    outside = lab.data.parent
    before = sorted(os.listdir(outside))
    status, started = lab.request("POST", "/api/record/start", {"subject": "../../x", "trial": "/etc/y", "note": ""})
    assert status == 201
    status, stopped = lab.request("POST", "/api/record/stop", {})
    assert status == 200
    p = Path(stopped["session"])
    assert p.parent == lab.data.resolve() and p.is_file()
    assert sorted(os.listdir(outside)) == before
    assert load_session(p).metadata["subject"] == "../../x"   # kept as typed, in the metadata only
    for name in ("../../etc/passwd", "/etc/passwd", "..", ".", "", f"../{lab.data.name}/../x.h5"):
        status, out = lab.request("POST", "/api/replay/open", {"session": name})
        assert status in (400, 403, 404), (name, status, out)
    link = lab.data / "link.h5"
    link.symlink_to(outside / "elsewhere.h5")
    status, out = lab.request("POST", "/api/replay/open", {"session": "link.h5"})
    assert status == 403, out
    link.unlink()


def test_state_errors_are_refused_with_one_line(lab: Lab) -> None:
    for path, body in (("/api/record/stop", {}), ("/api/marker", {"label": "x"}), ("/api/replay/play", {})):
        status, out = lab.request("POST", path, body)
        assert status == 409 and "\n" not in out["error"]
    status, out = lab.request("POST", "/api/record/start", {"subject": 3, "trial": "t", "note": ""})
    assert status == 400 and "subject" in out["error"]
    req = urllib.request.Request(lab.base + "/api/marker", data=b"{not json", method="POST",
                                 headers={"Authorization": f"Bearer {lab.token}"})
    with pytest.raises(urllib.error.HTTPError) as bad:
        urllib.request.urlopen(req, timeout=30)
    with bad.value:  # the error response holds the connection: closed here, not by the garbage collector
        assert bad.value.code == 400


def test_a_recorded_session_replays_through_the_page_api(lab: Lab) -> None:
    pytest.importorskip("psmat.acquire._playback")
    status, listed = lab.request("GET", "/api/sessions")
    name = next(r["name"] for r in listed["sessions"] if r["name"].startswith("P01_"))
    s = load_session(lab.data / name)
    status, rep = lab.request("POST", "/api/replay/open", {"session": name, "speed": 2})
    assert status == 200, rep
    try:
        assert rep["name"] == name and rep["duration_s"] > 0
        with websockets_sync.connect(f"ws://127.0.0.1:{lab.port}/ws?token={lab.token}", open_timeout=10) as ws:
            assert json.loads(ws.recv(timeout=10))["type"] == "hello"
            f = json.loads(ws.recv(timeout=10))
        assert s.seq[0] <= f["seq"] <= s.seq[-1]   # frames of the recording, not of the live mat
        for action, body in (("pause", {}), ("seek", {"t_s": 0.5}), ("speed", {"speed": 0.5}), ("play", {})):
            status, out = lab.request("POST", f"/api/replay/{action}", body)
            assert status == 200, (action, out)
        assert out["speed"] == 0.5 and out["paused"] is False
        status, out = lab.request("POST", "/api/replay/seek", {"t_s": -1})
        assert status == 400
        status, st = lab.request("GET", "/api/status")
        assert st["source"] == "replay" and st["replay"]["name"] == name
    finally:
        status, out = lab.request("POST", "/api/replay/close", {})
    assert status == 200
    assert lab.request("GET", "/api/status")[1]["source"] == "live"


def test_sigterm_while_recording_closes_the_file(tmp_path: Path) -> None:
    lab = Lab(tmp_path / "data")
    try:
        _wait_frames(lab, 10)
        status, started = lab.request("POST", "/api/record/start", {"subject": "S", "trial": "T", "note": ""})
        assert status == 201
        _wait_frames(lab, lab.request("GET", "/api/status")[1]["device"]["counters"]["frames"] + 50)
    finally:
        code = lab.stop()
    assert code == 128 + signal.SIGTERM
    p = Path(started["session"])
    s = load_session(p)
    assert s.complete and s.n_frames > 0 and not journal_path(p).exists()


def test_a_recording_that_fills_the_disk_is_said_and_its_journal_kept(tmp_path: Path) -> None:
    """The data folder on a disk that fills: before, the page went on saying "recording ... frames"
    while the file took nothing more, and stopping answered 500 with a traceback in the server's log.
    Now the status says why the file stopped, stopping answers 507 with the reason, the journal keeps
    the frames, and the server lives on."""
    with small_disk(tmp_path / "small", 160) as data:
        lab = Lab(data)
        try:
            _wait_frames(lab, 10)
            status, started = lab.request("POST", "/api/record/start", {"subject": "S", "trial": "T", "note": ""})
            assert status == 201, started
            for _ in range(1200):  # the disk fills after about a thousand 16x16 frames
                st = lab.request("GET", "/api/status")[1]
                if st["record"]["stopped"]:
                    break
                time.sleep(0.05)
            assert st["recording"] and st["record"]["stopped"] == "no space left on the disk", st
            status, out = lab.request("POST", "/api/record/stop", {})
            assert status == 507 and "(no space left on the disk)" in out["error"] and "journal" in out["error"], out
            path = Path(started["session"])
            assert journal_path(path).is_file() and not path.exists()
            status, st = lab.request("GET", "/api/status")
            assert status == 200 and st["recording"] is False and st["device"]["counters"]["connected"]
        finally:
            lab.stop()


def test_a_wider_board_under_the_profile_is_said_while_the_mat_runs(tmp_path: Path) -> None:
    """A 12-bit board (the psm16 twin speaking csv on a real pty) read with the 10-bit arduino16 profile:
    every frame is an invalid row. The status lists the reasons with what to check, as psmat record says
    after a recording (before: only the counters)."""
    with csv_twin("--profile", "psm16", rate_hz=50) as port:
        lab = Lab(tmp_path / "data", source=(port, "--profile", "arduino16"))
        try:
            for _ in range(600):
                st = lab.request("GET", "/api/status")[1]
                if st["device"]["counters"]["invalid"] >= 20:
                    break
                time.sleep(0.05)
            warnings = lab.request("GET", "/api/status")[1]["device"]["warnings"]
        finally:
            lab.stop()
    assert len(warnings) == 1 and warnings[0].startswith("invalid rows by reason, since the port opened: range ")
    assert "counts above 1023, the most 10 bits hold: is the board's ADC wider (the profile's bits, --bits)?" \
        in warnings[0]


def test_the_bits_the_warning_names_are_an_option_of_the_lab(tmp_path: Path) -> None:
    """The lab's ADC lines say which --bits to use; the lab took no --bits (only a profile file did).
    The same 12-bit board read with the 10-bit arduino16 profile and --bits 12: its frames are valid,
    nothing is said, and the device reads with the 12-bit profile."""
    with csv_twin("--profile", "psm16", rate_hz=50) as port:
        lab = Lab(tmp_path / "data", "--bits", "12", source=(port, "--profile", "arduino16"))
        try:
            st = _wait_frames(lab, 40)
        finally:
            lab.stop()
    counters = st["device"]["counters"]
    # at most the first line, cut where the port opened mid-line, is invalid (not one row per frame)
    assert counters["frames"] >= 40 and counters["invalid"] <= 1, counters
    assert st["device"]["warnings"] == []


def test_a_replay_refuses_the_options_of_a_live_mat_in_one_line(tmp_path: Path) -> None:
    session = tmp_path / "s.h5"
    subprocess.run([sys.executable, "-m", "psmat", "record", "--simulate", "--seconds", "1", "--out", str(session)],
                   check=True, capture_output=True, timeout=120)
    for extra in (["--bits", "10"], ["--shape", "8x8", "--protocol", "csv"]):
        r = subprocess.run([sys.executable, "-m", "psmat", "lab", "--replay", str(session), "--no-browser", "--port",
                            "0", "--data", str(tmp_path / "d"), *extra], capture_output=True, text=True, timeout=60)
        assert r.returncode == 1 and r.stdout == "" and len(r.stderr.strip().splitlines()) == 1, r.stderr
        assert r.stderr.startswith(f"psmat lab: {', '.join(x for x in extra if x.startswith('--'))}: a replay's "
                                   f"shape, protocol, ADC bits and rate are the session's ({session}); leave")
    assert not (tmp_path / "d").exists()  # refused before the data folder is made


def _status_until(lab: Lab, ok, what: str) -> dict:
    """The lab's status once ``ok(status)`` holds (a hang guard, not a time expectation)."""
    for _ in range(1200):
        st = lab.request("GET", "/api/status")[1]
        if ok(st):
            return st
        time.sleep(0.05)
    raise AssertionError(f"{what}: {st}")


def _recorded(st: dict) -> int:
    """Frames in the running recording, from a status."""
    return int((st.get("record") or {}).get("frames", 0))


def _recording_behind_a_link(tmp_path: Path, twin: Any, link: Path, frames: int, *args: str) -> Lab:
    """A lab reading the board of the context ``twin`` through the symlink ``link`` (as udev's by-id name),
    recording, with ``frames`` recorded; the board is then stopped (its pty closed) on leaving ``twin``."""
    with twin as port:
        os.symlink(port, link)
        lab = Lab(tmp_path / "data", *args, source=(str(link),))
        try:
            _wait_frames(lab, 10)
            status, started = lab.request("POST", "/api/record/start", {"subject": "P01", "trial": "t", "note": ""})
            assert status == 201, started
            _status_until(lab, lambda st: _recorded(st) >= frames, "the recording took no frame")
        except BaseException:
            lab.stop()
            raise
    return lab


def test_a_cable_pulled_and_put_back_is_reopened_and_said(tmp_path: Path) -> None:
    """A mat's USB cable pulled during a trial and put back: the board's port vanishes, then comes back at
    the same path (as udev's /dev/serial/by-id link does). Before, the lab's device was gone for good: no
    frame until the lab was restarted. Now the port is re-opened, the page says the port is lost while it
    is and when and for how long it was after, and the recording running keeps the frames on both sides."""
    link = tmp_path / "ttyMAT"
    lab = _recording_behind_a_link(tmp_path, csv_twin(rate_hz=50), link, 20, "--profile", "arduino16")
    try:   # the first board is gone (its simulator stopped: the pty closed) and its link points nowhere
        lost = _status_until(lab, lambda st: not st["device"]["counters"]["connected"], "the port was never lost")
        warning = _status_until(lab, lambda st: any(" is lost since " in w for w in st["device"]["warnings"]),
                                "no line while the port is lost")["device"]["warnings"]
        assert [w for w in warning if w.startswith(f"{link} is lost since ")] and any(
            "is the board's USB cable plugged in and the board powered? Frames resume when it is back" in w
            for w in warning), warning
        assert lost["recording"] is True
        _status_until(lab, lambda st: st["time_s"] - (st["device"]["counters"]["lost_at"] or st["time_s"]) >= 3.0,
                      "the port came back by itself")   # out for 3 s at least, as a cable pulled is
        before = _recorded(lab.request("GET", "/api/status")[1])
        with csv_twin(rate_hz=50) as second:
            tmp = tmp_path / "new-link"
            os.symlink(second, tmp)
            os.replace(tmp, link)   # the board is back, at the same path
            back = _status_until(lab, lambda st: st["device"]["counters"]["reconnects"] == 1
                                 and _recorded(st) >= before + 20, "not re-opened, or nothing recorded after")
            status, stopped = lab.request("POST", "/api/record/stop", {})
            assert status == 200, stopped
    finally:
        lab.stop()
    said = [w for w in back["device"]["warnings"] if w.startswith(f"{link} was lost and found again 1 time since it "
                                                                  "opened, the last at ")]
    assert len(said) == 1 and said[0].endswith(" s: a recording running then has no frames for that time"), \
        back["device"]["warnings"]
    # the line being sent when the port vanished may be cut (one invalid row allowed per loss) and the one
    # each opening cuts is no row: no "invalid rows" line
    assert not [w for w in back["device"]["warnings"] if w.startswith("invalid rows")], back["device"]["warnings"]
    lost_at, away_s = back["device"]["counters"]["last_gap"]
    assert away_s > 0 and back["device"]["counters"]["connected"] and back["device"]["counters"]["lost_at"] is None
    s = load_session(Path(stopped["session"]))
    assert s.complete and s.n_frames == stopped["frames"] >= before + 20
    # the frames of both boards, those of the first received before the port was lost, the second's after it
    # was found again (away_s later)
    t = s.host_time_s
    first_board, second_board = t[t <= lost_at], t[t > lost_at]
    assert len(first_board) == before >= 20 and len(second_board) >= 20
    assert second_board[0] >= lost_at + away_s   # one clock, the frames' host clock
    # processed, the time out is one long period, not a stretch of every period: 50 Hz is 0.02 s (a twin
    # that falls behind on a busy machine drops ticks: more), where one line through the first and the last
    # stamp gave every period (3 s + the frames' time) / frames, 0.06 s or more
    clock = session_clock(s)
    assert clock.gaps == 1 and clock.periods_s.max() >= 1.0 and np.median(clock.periods_s) < 0.04


def _at_the_rate_asked(steps: list[int]) -> None:
    """Device-clock steps (µs) that end at the 50 Hz asked: the last 30 are mostly 20 000 µs. Before them
    may come frames at the twin's own 100 Hz (10 000 µs): it streams from power-up, and what it sent before
    the rate was asked waits in its pty until the reader drains it (on a busy machine, into the recording).
    Every step is whole periods: a twin that falls behind on a busy machine drops ticks, keeping its grid."""
    assert len(steps) >= 30 and all(x > 0 and x % 10_000 == 0 for x in steps), steps
    assert int(np.median(steps[-30:])) == 20_000, steps


def test_the_rate_is_asked_of_a_box_and_refused_for_a_csv_mat(tmp_path: Path) -> None:
    """--rate with a live PORT was silently ignored (only the twin's rate took it). Now a v1/v2 box is asked
    for it: its frames come at that rate by the box's own clock (device time 20 000 µs apart at 50 Hz, the
    twin serving 100 Hz until asked); a csv mat, which takes no commands, is refused in one line."""
    from csv_twin import box_twin

    with box_twin(rate_hz=100) as port:
        lab = Lab(tmp_path / "data", "--rate", "50", source=(port,))
        try:
            _wait_frames(lab, 10)
            status, started = lab.request("POST", "/api/record/start", {"subject": "P01", "trial": "t", "note": ""})
            assert status == 201, started
            # past what the twin's pty kept from before the rate was asked (64 KiB: at most ~125 frames)
            _status_until(lab, lambda st: int((st.get("record") or {}).get("frames", 0)) >= 160, "nothing recorded")
            status, stopped = lab.request("POST", "/api/record/stop", {})
            assert status == 200, stopped
        finally:
            lab.stop()
    s = load_session(Path(stopped["session"]))
    _at_the_rate_asked(np.diff(s.device_time_us).tolist())
    assert s.device["rate"] == 50   # what the box was set to, stored with the session
    with csv_twin(rate_hz=50) as port:
        r = subprocess.run([sys.executable, "-m", "psmat", "lab", port, "--protocol", "csv", "--rate", "50",
                            "--no-browser", "--port", "0", "--data", str(tmp_path / "d")],
                           capture_output=True, text=True, timeout=60)
    assert r.returncode == 1 and r.stdout == "" and r.stderr == (
        "psmat lab: a csv mat takes no commands: it keeps its own rate (--rate only with --simulate or a v1/v2 "
        "box)\n")
    assert not (tmp_path / "d").exists()


def test_a_box_found_again_is_asked_for_the_rate_again(tmp_path: Path) -> None:
    """A box that lost power with its cable starts again at its own rate: before, the lab re-opened it and
    sent START only, and a recording asked for 50 Hz went on at 100 Hz after the gap, unsaid. Now the rate
    asked is asked again: after the restart the device clock's frames are 20 000 µs apart again."""
    from csv_twin import box_twin

    link = tmp_path / "ttyPSM"
    lab = _recording_behind_a_link(tmp_path, box_twin(rate_hz=100), link, 160, "--rate", "50")
    try:
        _status_until(lab, lambda st: not st["device"]["counters"]["connected"], "the port was never lost")
        before = _recorded(lab.request("GET", "/api/status")[1])
        with box_twin(rate_hz=100) as second:   # powered up again: 100 Hz until asked
            os.symlink(second, tmp_path / "new-link")
            os.replace(tmp_path / "new-link", link)
            # the twin's pty keeps what it sent before the port was opened again (64 KiB: at most ~125 frames):
            # wait past them
            _status_until(lab, lambda st: st["device"]["counters"]["reconnects"] == 1 and _recorded(st) >= before + 170,
                          "not re-opened, or nothing recorded after")
            status, stopped = lab.request("POST", "/api/record/stop", {})
            assert status == 200, stopped
    finally:
        lab.stop()
    s = load_session(Path(stopped["session"]))
    steps = np.diff(s.device_time_us)
    restart = np.flatnonzero(steps <= 0)   # the second box's clock starts again
    assert len(restart) == 1 and restart[0] + 1 == before
    # on each side what the box sent at its own 100 Hz before the rate asked (again) took effect, kept in
    # the twin's pty, then the rate asked
    _at_the_rate_asked(steps[:restart[0]].tolist())
    _at_the_rate_asked(steps[restart[0] + 1:].tolist())

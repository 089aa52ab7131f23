"""The DevTools driver (:mod:`psmat.bench.chromium`) on a real headless Chromium and a real HTTP server."""

from __future__ import annotations

import http.server
import os
import shutil
import signal
import struct
import subprocess
import sys
import tempfile
import textwrap
import threading
import time
from pathlib import Path

import pytest

from chromium import Chromium, ChromiumError, chromium_or_skip
from hang_guard import HANG_GUARD_S

PAGE = b"""<!doctype html><title>driver check</title>
<button id="b" onclick="window.clicks = (window.clicks || 0) + 1">b</button>
<div style="position:fixed;left:0;top:40px;width:50px;height:50px;background:rgb(255,0,0)"></div>"""


@pytest.fixture
def server():
    class Handler(http.server.BaseHTTPRequestHandler):
        def do_GET(self) -> None:  # noqa: N802 - the stdlib's name
            self.send_response(200)
            self.send_header("Content-Type", "text/html")
            self.send_header("Content-Length", str(len(PAGE)))
            self.end_headers()
            self.wfile.write(PAGE)

        def log_message(self, *args) -> None:
            pass

    httpd = http.server.ThreadingHTTPServer(("127.0.0.1", 0), Handler)
    thread = threading.Thread(target=httpd.serve_forever, daemon=True)
    thread.start()
    yield f"http://127.0.0.1:{httpd.server_address[1]}/"
    httpd.shutdown()
    httpd.server_close()


def _group_gone(pgid: int) -> bool:
    try:
        os.killpg(pgid, 0)
    except ProcessLookupError:
        return True
    return False


def test_the_driver_loads_evaluates_clicks_and_shoots(server, tmp_path) -> None:
    exe = chromium_or_skip()
    browser = Chromium(exe, window=(320, 200))
    try:
        browser.navigate(server)
        assert browser.evaluate("document.title") == "driver check"
        assert browser.evaluate("[1, 2 + 3, {a: 'x'}]") == [1, 5, {"a": "x"}]
        browser.click("#b")
        browser.click("#b")
        assert browser.evaluate("window.clicks") == 2
        with pytest.raises(ChromiumError, match="no element matches #missing"):
            browser.click("#missing")
        with pytest.raises(ChromiumError, match="boom"):
            browser.evaluate("(() => { throw new Error('boom') })()")
        png = browser.screenshot(tmp_path / "shot" / "page.png").read_bytes()
        assert png[:8] == b"\x89PNG\r\n\x1a\n"
        width, height = struct.unpack(">II", png[16:24])  # the IHDR chunk
        assert (width, height) == (320, 200)
    finally:
        browser.close()
    assert _group_gone(browser.pid), "a Chromium process outlived close()"
    browser.close()  # twice is harmless


def test_the_browser_leaves_nothing_in_the_temporary_folder(monkeypatch) -> None:
    """Chromium makes its own temporary folder (org.chromium.Chromium.XXXXXX, its single-instance socket),
    which a browser ended by a signal, as close() ends it, leaves behind: hundreds of them piled up in /tmp
    over the test runs before it was made inside the driver's folder."""
    exe = chromium_or_skip()
    # a short path: the browser's socket path must fit in 107 bytes (a longer TMPDIR keeps the inherited one)
    tmp = Path(tempfile.mkdtemp(prefix="pc-", dir="/tmp"))
    try:
        monkeypatch.setenv("TMPDIR", str(tmp))  # the system's temporary folder, for the driver and the browser
        monkeypatch.setattr(tempfile, "tempdir", None)  # read again from TMPDIR
        browser = Chromium(exe, window=(320, 200))
        try:
            assert browser.evaluate("1 + 1") == 2
            ours = list(tmp.iterdir())  # the driver's folder alone, the browser's own inside it
            assert len(ours) == 1 and ours[0].name.startswith("psmat-chromium-"), ours
            assert list(ours[0].glob("org.chromium.Chromium.*"))
        finally:
            browser.close()
        assert list(tmp.iterdir()) == []
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def test_a_refused_address_is_a_clear_error(tmp_path) -> None:
    exe = chromium_or_skip()
    import socket

    with socket.socket() as s:  # a port nobody listens on
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    with Chromium(exe) as browser:
        with pytest.raises(ChromiumError, match="failed: net::ERR_CONNECTION_REFUSED"):
            browser.navigate(f"http://127.0.0.1:{port}/")
    assert _group_gone(browser.pid)


#: a process that opens the driver, says the browser's process group, and waits to be killed
OPENER = textwrap.dedent("""
    import sys, time
    from psmat.bench.chromium import Chromium
    browser = Chromium(sys.argv[1])
    print(browser.pid, flush=True)
    time.sleep(600)
""")


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="PR_SET_PDEATHSIG is Linux's")
def test_no_browser_outlives_a_process_killed_outright() -> None:
    exe = chromium_or_skip()
    opener = subprocess.Popen([sys.executable, "-c", OPENER, exe], stdout=subprocess.PIPE, text=True,
                              cwd=Path(__file__).parent)
    pgid = None
    try:
        pgid = int(opener.stdout.readline())
        assert not _group_gone(pgid)
        os.kill(opener.pid, signal.SIGKILL)  # close() never runs
        opener.wait(timeout=HANG_GUARD_S)
        deadline = time.monotonic() + HANG_GUARD_S
        while not _group_gone(pgid) and time.monotonic() < deadline:
            time.sleep(0.1)
        assert _group_gone(pgid), "Chromium outlived the process that drove it"
    finally:
        opener.kill()
        opener.wait()
        opener.stdout.close()
        if pgid is not None and not _group_gone(pgid):
            os.killpg(pgid, signal.SIGKILL)

"""The lab benchmark's browser side: ``psmat lab --simulate`` in a child process, its page in headless Chromium.

:func:`serve_lab` starts the server (``python -m psmat lab --simulate --no-browser --port 0``)
and reads the URL from the first line it prints; :func:`measure_page` opens that URL in a
:class:`~psmat.bench.chromium.Chromium`, starts a recording through the JSON API, and for a
fixed time samples what the page exposes in ``window.psmatLab``:

* ``framesDrawn`` at the start and the end of the window: frames drawn per second;
* ``arrivalLatenciesMs``: the latency from each frame message's device time to its arrival in
  the page (``Date.now()`` in the WebSocket's message handler). The page maps the device clock
  onto the host's wall clock with the offset of the least-delayed frame so far (the smallest
  ``host_time_s`` - device time of the messages the server sent), so the figure is the delay
  beyond the fastest frame's link transit: reading, queueing for the display, processing,
  the WebSocket and the page's event loop;
* ``lastFrameDeviceTimeUs`` and ``lastLatencyMs`` every ``poll_s``: the time from the server
  receiving the frame (its host time) to the page drawing it, one sample per distinct frame seen;
* the CPU time of the server's process (and its children) and of the browser's processes
  (psutil), over the same window: CPU % of one core.

The recording is then stopped and its frames counted in the session file.
"""

from __future__ import annotations

import json
import math
import os
import queue
import signal
import subprocess
import sys
import threading
import time
import urllib.request
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any
from urllib.parse import parse_qs, urlsplit

__all__ = ["LabServer", "PageRun", "serve_lab", "measure_page", "cpu_seconds"]

#: what the benchmark reads from the page in one evaluation: frames drawn, the device time and
#: latency of the last frame drawn, the arrival latencies since the previous read (taken out)
_SAMPLE_JS = ("(() => { const s = window.psmatLab || {}; return [s.framesDrawn ?? null, "
              "s.lastFrameDeviceTimeUs ?? null, s.lastLatencyMs ?? null, "
              "s.arrivalLatenciesMs ? s.arrivalLatenciesMs.splice(0) : null]; })()")


@dataclass
class PageRun:
    """What one run of the page measured.

    Attributes
    ----------
    rate_hz : float
        The simulated mat's frame rate (frames/s).
    seconds : float
        Length of the measured window (s).
    drawn_per_s : float
        Frames the page drew per second over the window.
    latency_ms : list of float
        A frame's device time (on the host clock) to its arrival in the page (ms), every message.
    drawn_latency_ms : list of float
        The server's receipt of a frame (its host time) to the page drawing it (ms), sampled.
    server_cpu_pct, browser_cpu_pct : float
        CPU time over the window / its length, in % of one core.
    recorded_frames : int
        Frames in the session file the recording wrote.
    recorded_s : float
        The recording's length from its first to its last frame's host time (s).
    server_rates : dict
        ``rates`` of the server's ``/api/status`` at the end of the window.
    """

    rate_hz: float
    seconds: float
    drawn_per_s: float = math.nan
    latency_ms: list[float] = field(default_factory=list)
    drawn_latency_ms: list[float] = field(default_factory=list)
    server_cpu_pct: float = math.nan
    browser_cpu_pct: float = math.nan
    recorded_frames: int = 0
    recorded_s: float = math.nan
    server_rates: dict[str, Any] = field(default_factory=dict)


class LabServer:
    """A running ``psmat lab`` child process; a context manager that stops it (SIGINT, then SIGKILL).

    Parameters
    ----------
    argv : list of str
        The options after ``psmat lab``.
    timeout_s : float
        How long the server may take to print its URL (s; a hang guard).
    """

    def __init__(self, argv: list[str], timeout_s: float = 60.0) -> None:
        self.argv = [sys.executable, "-m", "psmat", "lab", *argv]
        self.lines: queue.Queue[str] = queue.Queue()
        self.output: list[str] = []
        self.errors: list[str] = []
        self.proc = subprocess.Popen(self.argv, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
                                     stderr=subprocess.PIPE, text=True, bufsize=1,
                                     start_new_session=sys.platform != "win32")
        self._reader = threading.Thread(target=self._read, name="lab-output", daemon=True)
        self._reader.start()
        self._err_reader = threading.Thread(target=self._read_errors, name="lab-errors", daemon=True)
        self._err_reader.start()
        try:
            first = self.lines.get(timeout=timeout_s)
        except queue.Empty:
            self.stop()
            raise RuntimeError(f"psmat lab printed nothing within {timeout_s:g} s") from None
        if not first.startswith("http"):
            self.stop()
            tail = " | ".join((self.output + self.errors)[-5:])
            raise RuntimeError(f"psmat lab did not start (its first line is not a URL): {tail}")
        self.url = first.strip().split()[0]
        parts = urlsplit(self.url)
        self.base = f"{parts.scheme}://{parts.netloc}"
        self.token = parse_qs(parts.query).get("token", [""])[0]

    def _read(self) -> None:
        assert self.proc.stdout is not None
        for line in self.proc.stdout:
            self.output.append(line.rstrip("\n"))
            self.lines.put(line)
        self.lines.put("")  # the end: a wait for the first line ends too

    def _read_errors(self) -> None:
        assert self.proc.stderr is not None
        for line in self.proc.stderr:
            self.errors.append(line.rstrip("\n"))

    def api(self, path: str, body: dict[str, Any] | None = None, timeout_s: float = 30.0) -> Any:
        """GET ``path`` (or POST ``body`` as JSON) with the token; the decoded JSON answer."""
        data = None if body is None else json.dumps(body).encode()
        req = urllib.request.Request(self.base + path, data=data, method="GET" if body is None else "POST",
                                     headers={"Authorization": f"Bearer {self.token}",
                                              "Content-Type": "application/json"})
        with urllib.request.urlopen(req, timeout=timeout_s) as r:
            return json.load(r)

    def stop(self, grace_s: float = 10.0) -> int | None:
        """Ask the server to stop (SIGINT: it closes its device and recording), kill it if it lingers."""
        if self.proc.poll() is None:
            try:
                if sys.platform == "win32":  # pragma: no cover
                    self.proc.terminate()
                else:
                    os.killpg(self.proc.pid, signal.SIGINT)
                self.proc.wait(grace_s)
            except subprocess.TimeoutExpired:
                if sys.platform != "win32":
                    os.killpg(self.proc.pid, signal.SIGKILL)
                self.proc.kill()
                self.proc.wait(grace_s)
            except ProcessLookupError:
                pass
        self._reader.join(grace_s)
        self._err_reader.join(grace_s)
        for pipe in (self.proc.stdout, self.proc.stderr):
            if pipe is not None:
                pipe.close()
        return self.proc.returncode

    def __enter__(self) -> LabServer:
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()


def serve_lab(data_dir: str | os.PathLike[str], *extra: str, timeout_s: float = 60.0) -> LabServer:
    """``psmat lab --simulate --no-browser --port 0 --data DATA_DIR [extra...]``, started; see :class:`LabServer`."""
    return LabServer(["--simulate", "--no-browser", "--port", "0", "--data", os.fspath(data_dir), *extra],
                     timeout_s=timeout_s)


def cpu_seconds(pid: int) -> float:
    """User + system CPU time (s) of the process ``pid`` and its living children (psutil)."""
    import psutil

    total = 0.0
    try:
        root = psutil.Process(pid)
        procs = [root, *root.children(recursive=True)]
    except psutil.NoSuchProcess:
        return math.nan
    for p in procs:
        try:
            t = p.cpu_times()
            total += t.user + t.system
        except psutil.NoSuchProcess:
            pass
    return total


def measure_page(server: LabServer, browser: Any, rate_hz: float, *, seconds: float, warmup_s: float = 1.0,
                 poll_s: float = 0.02) -> PageRun:
    """Open the lab page, record, and measure the page and the server for ``seconds`` (see the module).

    Parameters
    ----------
    server : LabServer
        A running lab server on a simulated mat at ``rate_hz``.
    browser : Chromium
        A started browser (:class:`psmat.bench.chromium.Chromium`).
    rate_hz : float
        The simulated mat's rate (frames/s), reported with the run.
    seconds, warmup_s, poll_s : float
        Measured window, time before it (page up, recording started), and the sampling interval (s).
    """
    run = PageRun(rate_hz=rate_hz, seconds=seconds)
    browser.navigate(server.url)
    browser.wait_for("!!(window.psmatLab && window.psmatLab.connected && window.psmatLab.framesDrawn > 0)")
    started = server.api("/api/record/start", {"subject": "bench", "trial": f"{rate_hz:g}hz", "note": ""})
    time.sleep(warmup_s)
    seen: dict[Any, float] = {}
    arrivals: list[float] = []
    c0_server, c0_browser = cpu_seconds(server.proc.pid), cpu_seconds(browser.pid)
    t0 = time.monotonic()
    drawn0 = browser.evaluate(_SAMPLE_JS)[0]  # also empties the arrivals before the window
    while time.monotonic() - t0 < seconds:
        time.sleep(poll_s)
        _drawn, device_us, latency, arrived = browser.evaluate(_SAMPLE_JS)
        if device_us is not None and latency is not None and math.isfinite(latency):
            seen.setdefault(device_us, float(latency))
        arrivals.extend(float(x) for x in arrived or ())
    drawn1 = browser.evaluate(_SAMPLE_JS)[0]
    t1 = time.monotonic()
    c1_server, c1_browser = cpu_seconds(server.proc.pid), cpu_seconds(browser.pid)
    elapsed = t1 - t0
    run.seconds = elapsed
    run.drawn_per_s = (drawn1 - drawn0) / elapsed if drawn0 is not None and drawn1 is not None else math.nan
    run.server_cpu_pct = 100.0 * (c1_server - c0_server) / elapsed
    run.browser_cpu_pct = 100.0 * (c1_browser - c0_browser) / elapsed
    run.latency_ms = arrivals
    run.drawn_latency_ms = list(seen.values())
    run.server_rates = dict(server.api("/api/status").get("rates", {}))
    stopped = server.api("/api/record/stop", {})
    session = stopped.get("session") or started.get("session")
    if session:
        from ..io import load_session

        path = Path(session)
        s = load_session(path)
        run.recorded_frames = int(len(s.counts))
        if len(s.host_time_s) > 1:
            run.recorded_s = float(s.host_time_s[-1] - s.host_time_s[0])
    return run

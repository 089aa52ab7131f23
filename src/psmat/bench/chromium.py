"""A small driver for headless Chromium through its DevTools protocol, for the lab benchmark and tests.

:class:`Chromium` starts ``chromium --headless=new --remote-debugging-port=0`` with a user data
folder of its own (a temporary one), reads the port Chromium chose from the
``DevToolsActivePort`` file it writes there, and connects to the blank page's target over a
WebSocket (the ``websockets`` package's synchronous client). Each call is one DevTools command,
answered by the reply that carries its id; events met on the way are kept for
:meth:`Chromium.navigate`, which waits for ``Page.loadEventFired``.

The browser runs in a process group of its own (``/usr/bin/chromium`` is a shell script that
starts the real binary, which starts its renderers): :meth:`Chromium.close` ends the whole
group (SIGTERM, then SIGKILL after a grace time) and removes the user data folder, so no
Chromium process outlives the driver. On Linux the browser also gets SIGTERM when the thread that
started it ends, the process killed outright included (``psmat._orphans.parent_death_preexec``;
the script execs the binary, which ends its own children), so a benchmark or test killed with
``kill -9`` leaves no browser running. Only the standard library and ``websockets``.
"""

from __future__ import annotations

import base64
import contextlib
import itertools
import json
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
import urllib.request
from pathlib import Path
from types import TracebackType
from typing import Any

from .._browser import CANDIDATES, find_chromium
from .._orphans import parent_death_preexec

__all__ = ["Chromium", "ChromiumError", "find_chromium", "CANDIDATES"]

#: what Chromium adds to its TMPDIR for its single-instance socket, and the longest path a Unix socket takes
_SOCKET_IN_TMP = "/org.chromium.Chromium.XXXXXX/SingletonSocket"
_SOCKET_PATH_MAX = 107


class ChromiumError(RuntimeError):
    """Chromium could not be started or driven, or a script threw in the page."""


class Chromium:
    """One headless Chromium with one page, driven over DevTools; a context manager.

    Parameters
    ----------
    executable : str, optional
        The browser; default :func:`find_chromium`.
    window : (int, int)
        Viewport width and height (CSS px), which is also a screenshot's size.
    timeout_s : float
        How long a start, a command or a page load may take before :class:`ChromiumError` (s).
        A hang guard, not a performance claim.

    Raises
    ------
    ChromiumError
        No browser found, or it did not come up.
    """

    def __init__(self, executable: str | None = None, *, window: tuple[int, int] = (1280, 860),
                 timeout_s: float = 60.0) -> None:
        exe = executable or find_chromium()
        if exe is None:
            raise ChromiumError(f"no Chromium found (tried $PSMAT_CHROMIUM, {', '.join(CANDIDATES)} on PATH)")
        self.timeout_s = float(timeout_s)
        self._ids = itertools.count(1)
        self._events: list[dict[str, Any]] = []
        self._ws: Any = None
        self._stack = contextlib.ExitStack()
        self._dir = tempfile.mkdtemp(prefix="psmat-chromium-")
        self._log = open(os.path.join(self._dir, "chromium.log"), "wb")  # noqa: SIM115 - closed in close()
        argv = [exe, "--headless=new", "--no-sandbox", "--disable-gpu", "--remote-debugging-port=0",
                f"--user-data-dir={self._dir}/profile", f"--window-size={window[0]},{window[1]}",
                "--no-first-run", "--no-default-browser-check", "--hide-scrollbars", "--mute-audio",
                "--disable-dev-shm-usage", "--disable-background-timer-throttling",
                "--disable-renderer-backgrounding", "--disable-backgrounding-occluded-windows", "about:blank"]
        # the browser's own temporary folder (org.chromium.Chromium.XXXXXX, its single-instance socket, which
        # a browser ended by a signal leaves behind) made in ours and removed with it, where the socket's
        # path fits in a Unix socket address (107 bytes; Chromium aborts on a longer one)
        env = dict(os.environ)
        if len(os.fsencode(self._dir)) + len(_SOCKET_IN_TMP) <= _SOCKET_PATH_MAX:
            env["TMPDIR"] = self._dir
        self._proc = subprocess.Popen(argv, stdin=subprocess.DEVNULL, stdout=self._log, stderr=subprocess.STDOUT,
                                      env=env,
                                      start_new_session=sys.platform != "win32", preexec_fn=parent_death_preexec())
        try:
            self._connect(window)
        except BaseException:
            self.close()
            raise

    # -- start -----------------------------------------------------------------------------------

    def _connect(self, window: tuple[int, int]) -> None:
        from websockets.sync.client import connect

        port_file = Path(self._dir, "profile", "DevToolsActivePort")
        deadline = time.monotonic() + self.timeout_s
        while True:
            text = port_file.read_text() if port_file.exists() else ""
            if text.count("\n") >= 1 and text.split("\n", 1)[0].strip().isdigit():
                port = int(text.split("\n", 1)[0])
                break
            if self._proc.poll() is not None:
                raise ChromiumError(f"Chromium exited with status {self._proc.returncode}: {self._log_tail()}")
            if time.monotonic() > deadline:
                raise ChromiumError(f"Chromium wrote no DevToolsActivePort within {self.timeout_s:g} s: "
                                    f"{self._log_tail()}")
            time.sleep(0.05)
        page = None
        while page is None:
            with urllib.request.urlopen(f"http://127.0.0.1:{port}/json/list", timeout=self.timeout_s) as r:
                targets = json.load(r)
            page = next((t for t in targets if t.get("type") == "page" and t.get("url") == "about:blank"), None)
            if page is None:
                if time.monotonic() > deadline:
                    raise ChromiumError(f"no about:blank page among Chromium's targets: {targets}")
                time.sleep(0.05)
        # entered as a context manager: websockets >= 17.1 deprecates a bare connect()
        self._ws = self._stack.enter_context(
            connect(page["webSocketDebuggerUrl"], max_size=None, open_timeout=self.timeout_s))
        self.send("Page.enable")
        self.send("Runtime.enable")
        self.set_viewport(*window)

    def _log_tail(self, n: int = 5) -> str:
        try:
            self._log.flush()
            lines = Path(self._dir, "chromium.log").read_text(errors="replace").strip().splitlines()
        except OSError:
            return "(no log)"
        return " | ".join(lines[-n:]) or "(empty log)"

    # -- the protocol ----------------------------------------------------------------------------

    def send(self, method: str, params: dict[str, Any] | None = None) -> dict[str, Any]:
        """Send one DevTools command and return its ``result``.

        Parameters
        ----------
        method : str
            E.g. ``"Page.navigate"``.
        params : dict, optional
            The command's parameters.

        Raises
        ------
        ChromiumError
            The browser answered with an error, or nothing within ``timeout_s``.
        """
        if self._ws is None:
            raise ChromiumError("the browser is closed")
        msg_id = next(self._ids)
        self._ws.send(json.dumps({"id": msg_id, "method": method, "params": params or {}}))
        deadline = time.monotonic() + self.timeout_s
        while True:
            left = deadline - time.monotonic()
            if left <= 0:
                raise ChromiumError(f"no answer to {method} within {self.timeout_s:g} s")
            try:
                msg = json.loads(self._ws.recv(timeout=left))
            except TimeoutError:
                continue
            if msg.get("id") == msg_id:
                if "error" in msg:
                    raise ChromiumError(f"{method}: {msg['error'].get('message')} {msg['error'].get('data', '')}")
                return msg.get("result", {})
            if "method" in msg:
                self._events.append(msg)

    def _wait_event(self, method: str, since: int) -> dict[str, Any]:
        deadline = time.monotonic() + self.timeout_s
        while True:
            for ev in self._events[since:]:
                if ev["method"] == method:
                    return ev
            since = len(self._events)
            left = deadline - time.monotonic()
            if left <= 0:
                raise ChromiumError(f"no {method} within {self.timeout_s:g} s")
            try:
                msg = json.loads(self._ws.recv(timeout=min(left, 0.5)))
            except TimeoutError:
                continue
            if "method" in msg:
                self._events.append(msg)

    def navigate(self, url: str) -> None:
        """Open ``url`` in the page and wait for its load event.

        Raises
        ------
        ChromiumError
            The navigation failed (``errorText``: refused connection, bad address) or never loaded.
        """
        since = len(self._events)
        result = self.send("Page.navigate", {"url": url})
        if result.get("errorText"):
            raise ChromiumError(f"navigating to {url.split('?')[0]} failed: {result['errorText']}")
        self._wait_event("Page.loadEventFired", since)

    def evaluate(self, js: str, *, await_promise: bool = False) -> Any:
        """Evaluate the expression ``js`` in the page and return its value (by value: JSON-like).

        Raises
        ------
        ChromiumError
            The script threw; the message is the page's.
        """
        result = self.send("Runtime.evaluate", {"expression": js, "returnByValue": True,
                                                "awaitPromise": await_promise, "userGesture": True})
        if "exceptionDetails" in result:
            details = result["exceptionDetails"]
            text = details.get("exception", {}).get("description") or details.get("text", "")
            raise ChromiumError(f"the page threw: {text}")
        return result.get("result", {}).get("value")

    def wait_for(self, js: str, *, timeout_s: float | None = None, interval_s: float = 0.05) -> Any:
        """Evaluate ``js`` until its value is truthy, and return that value.

        Raises
        ------
        ChromiumError
            Still falsy after ``timeout_s`` (default the driver's; a hang guard).
        """
        deadline = time.monotonic() + (self.timeout_s if timeout_s is None else timeout_s)
        while True:
            value = self.evaluate(js)
            if value:
                return value
            if time.monotonic() > deadline:
                raise ChromiumError(f"still {value!r} after {timeout_s or self.timeout_s:g} s: {js}")
            time.sleep(interval_s)

    def click(self, selector: str) -> None:
        """Click the first element matching the CSS ``selector`` (``element.click()`` in the page).

        Raises
        ------
        ChromiumError
            No element matches.
        """
        sel = json.dumps(selector)
        self.evaluate(f"(() => {{ const e = document.querySelector({sel});"
                      f" if (!e) throw new Error('no element matches ' + {sel}); e.click(); return true; }})()")

    def set_viewport(self, width: int, height: int) -> None:
        """Resize the page's viewport (CSS px; a screenshot's size)."""
        self.send("Emulation.setDeviceMetricsOverride",
                  {"width": int(width), "height": int(height), "deviceScaleFactor": 1, "mobile": False})

    def screenshot(self, path: str | os.PathLike[str]) -> Path:
        """Write the page's viewport as a PNG file at ``path`` (its folder is created); the path."""
        data = self.send("Page.captureScreenshot", {"format": "png"})["data"]
        out = Path(path)
        out.parent.mkdir(parents=True, exist_ok=True)
        out.write_bytes(base64.b64decode(data))
        return out

    # -- end -------------------------------------------------------------------------------------

    @property
    def pid(self) -> int:
        """The process id of the browser's launcher (the leader of its process group)."""
        return self._proc.pid

    def close(self, grace_s: float = 5.0) -> None:
        """Close the connection, end the browser's whole process group, remove its user data folder.

        Safe to call twice.
        """
        if self._ws is not None:
            self._ws = None
            try:
                self._stack.close()
            except Exception:  # noqa: BLE001 - the browser may be gone already
                pass
        if self._proc.poll() is None or sys.platform != "win32":
            self._end_group(grace_s)
        if not self._log.closed:
            self._log.close()
        shutil.rmtree(self._dir, ignore_errors=True)

    def _end_group(self, grace_s: float) -> None:
        if sys.platform == "win32":  # pragma: no cover - no process groups
            self._proc.kill()
            self._proc.wait(grace_s)
            return
        pgid = self._proc.pid  # start_new_session: the launcher leads the group
        for sig, wait_s in ((signal.SIGTERM, grace_s), (signal.SIGKILL, grace_s)):
            try:
                os.killpg(pgid, sig)
            except ProcessLookupError:
                break
            deadline = time.monotonic() + wait_s
            while time.monotonic() < deadline and _group_alive(pgid):
                if self._proc.poll() is None:
                    try:
                        self._proc.wait(0.05)
                    except subprocess.TimeoutExpired:
                        pass
                else:
                    time.sleep(0.05)
            if not _group_alive(pgid):
                break
        if self._proc.poll() is None:
            self._proc.wait(grace_s)

    def __enter__(self) -> Chromium:
        return self

    def __exit__(self, et: type[BaseException] | None, ev: BaseException | None, tb: TracebackType | None) -> None:
        self.close()


def _group_alive(pgid: int) -> bool:
    """Whether any process of the group ``pgid`` is left (zombies of others' children included)."""
    try:
        os.killpg(pgid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True

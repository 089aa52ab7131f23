"""The lab's web application (Starlette): the page, the JSON API and the display WebSocket.

Every request and WebSocket passes :class:`TokenGuard` first: without the server's token
(``?token=`` or ``Authorization: Bearer``) an HTTP request gets 401 and a WebSocket handshake
is refused (403), before any route runs. The routes:

=========================  ==========================================================
``GET /``                  the page (``static/index.html``, its asset links carrying the token)
``GET /static/NAME``       ``app.js``, ``style.css``
``GET /api/status``        device, counters, rates, recording, replay (:meth:`LabSession.status`)
``POST /api/record/start`` ``{"subject", "trial", "note"}`` → ``{"session", "name"}``
``POST /api/marker``       ``{"label"}`` → ``{"label", "host_time_s"}``
``POST /api/record/stop``  → ``{"session", "name", "frames", "events", ..., "sway"}``
``GET /api/sessions``      ``{"sessions": [{"name", "session", "bytes", "modified_utc"}]}``
``POST /api/replay/open``  ``{"session", "speed"?}``; ``/play``, ``/pause``, ``/seek {"t_s"}``,
                           ``/speed {"speed"}``, ``/close``
``POST /api/calibrate/...`` the box's calibration walk-through (:mod:`._calibrate`): ``start``
                           ``{"pairs"?, "seconds"?}`` → the steps; ``step`` ``{"step": "open"}``
                           or ``{"step": "short", "row", "col"}`` → its diagnostics; ``finish``
                           → ``{"path", "r_adc_ohm", "r_mux_ohm", ...}``; ``cancel``
``WS /ws``                 display messages (:mod:`._display`), newest only
=========================  ==========================================================

Errors are ``{"error": "one line"}`` with 400 (bad input), 403 (a path outside the data
folder), 404, 409 (the state does not allow it: a second recording, no recording, a calibration
while recording or replaying, a step that read nothing), 501 (no
playback in this installation).
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import threading
from pathlib import Path
from typing import Any

from starlette.applications import Starlette
from starlette.concurrency import run_in_threadpool
from starlette.middleware import Middleware
from starlette.requests import Request
from starlette.responses import JSONResponse, Response
from starlette.routing import Route, WebSocketRoute
from starlette.websockets import WebSocket, WebSocketDisconnect

from .._atomic import no_space
from ..io import SessionNotCompleted
from ._replay import PlaybackUnavailable
from ._security import PathRefused, request_token, token_matches
from ._session import LabConflict, LabSession, trial_sway

__all__ = ["build_app", "TokenGuard", "ClientHub", "STATIC_DIR"]

#: the page's files, shipped in the wheel
STATIC_DIR = Path(__file__).resolve().parent / "static"
_ASSETS = {"app.js": "text/javascript; charset=utf-8", "style.css": "text/css; charset=utf-8"}
_NO_STORE = {"Cache-Control": "no-store", "Referrer-Policy": "no-referrer", "X-Content-Type-Options": "nosniff"}


class TokenGuard:
    """ASGI middleware: a request or WebSocket without the token goes no further (401 / 403)."""

    def __init__(self, app: Any, token: str) -> None:
        self.app = app
        self.token = token

    async def __call__(self, scope: dict[str, Any], receive: Any, send: Any) -> None:
        if scope["type"] not in ("http", "websocket"):
            await self.app(scope, receive, send)
            return
        headers = {k.decode("latin-1").lower(): v.decode("latin-1") for k, v in scope.get("headers", [])}
        given = request_token(scope.get("query_string", b""), headers.get("authorization"))
        if token_matches(self.token, given):
            await self.app(scope, receive, send)
            return
        if scope["type"] == "websocket":
            await send({"type": "websocket.close", "code": 1008, "reason": "token required"})
            return
        body = json.dumps({"error": "the lab's token is required: ?token=... or Authorization: Bearer ..."}).encode()
        await send({"type": "http.response.start", "status": 401,
                    "headers": [(b"content-type", b"application/json"), (b"www-authenticate", b"Bearer"),
                                (b"content-length", str(len(body)).encode()), (b"cache-control", b"no-store")]})
        await send({"type": "http.response.body", "body": body})


class ClientHub:
    """The WebSocket clients waiting for display messages: each has an event set when a newer
    message is there; a client that does not read keeps only the newest (nothing queues)."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._events: set[asyncio.Event] = set()
        self.loop: asyncio.AbstractEventLoop | None = None

    def add(self, ev: asyncio.Event) -> None:
        with self._lock:
            self._events.add(ev)

    def remove(self, ev: asyncio.Event) -> None:
        with self._lock:
            self._events.discard(ev)

    def notify(self, text: str) -> None:
        """Called from the display worker thread."""
        loop = self.loop
        if loop is None or loop.is_closed():
            return
        with self._lock:
            events = list(self._events)
        for ev in events:
            with contextlib.suppress(RuntimeError):  # the loop closed meanwhile
                loop.call_soon_threadsafe(ev.set)

    @property
    def clients(self) -> int:
        with self._lock:
            return len(self._events)


def _error(status: int, exc: BaseException | str) -> JSONResponse:
    return JSONResponse({"error": " ".join(str(exc).split())}, status_code=status, headers=_NO_STORE)


def _status_of(exc: BaseException) -> int:
    if isinstance(exc, PathRefused):
        return 403
    if isinstance(exc, FileNotFoundError):
        return 404
    if isinstance(exc, LabConflict):
        return 409
    if isinstance(exc, PlaybackUnavailable):
        return 501
    if isinstance(exc, (ValueError, TypeError)):
        return 400
    if isinstance(exc, SessionNotCompleted):  # its journal keeps the frames (psmat repair)
        return 507 if no_space(exc) else 500
    raise exc


async def _body(request: Request) -> dict[str, Any]:
    raw = await request.body()
    if not raw.strip():
        return {}
    try:
        data = json.loads(raw)
    except (ValueError, UnicodeDecodeError):
        raise ValueError("the request body must be JSON") from None
    if not isinstance(data, dict):
        raise ValueError("the request body must be a JSON object")
    return data


def build_app(lab: LabSession, token: str, hub: ClientHub | None = None) -> Starlette:
    """The Starlette application of ``lab``, guarded by ``token``.

    ``hub`` receives the display messages (``lab``'s ``publish`` should call ``hub.notify``);
    a new one is made when not given. Closing the application (its lifespan's end) closes
    ``lab``: a running recording is written to its file.
    """
    hub = hub or ClientHub()

    async def call(fn: Any, *args: Any, ok: int = 200) -> Response:
        try:
            result = await run_in_threadpool(fn, *args)
        except Exception as exc:  # noqa: BLE001 - mapped to a status, or raised again
            return _error(_status_of(exc), exc)
        return JSONResponse(result, status_code=ok, headers=_NO_STORE)

    async def page(request: Request) -> Response:
        html = (STATIC_DIR / "index.html").read_text(encoding="utf-8").replace("__TOKEN__", token)
        host = request.headers.get("host", "")
        csp = (f"default-src 'self'; script-src 'self'; style-src 'self'; img-src 'self' data:; "
               f"connect-src 'self' ws://{host}; frame-ancestors 'none'; base-uri 'none'")
        return Response(html, media_type="text/html; charset=utf-8",
                        headers={**_NO_STORE, "Content-Security-Policy": csp})

    async def asset(request: Request) -> Response:
        name = request.path_params["name"]
        if name not in _ASSETS:
            return _error(404, f"no asset {name!r}")
        return Response((STATIC_DIR / name).read_bytes(), media_type=_ASSETS[name], headers=_NO_STORE)

    async def status(request: Request) -> Response:
        def get() -> dict[str, Any]:
            return {**lab.status(), "clients": hub.clients}
        return await call(get)

    async def record_start(request: Request) -> Response:
        try:
            body = await _body(request)
        except ValueError as exc:
            return _error(400, exc)

        def start() -> dict[str, Any]:
            path = lab.start_recording(body.get("subject", ""), body.get("trial", ""), body.get("note", ""))
            return {"session": str(path), "name": path.name}
        return await call(start, ok=201)

    async def marker(request: Request) -> Response:
        try:
            body = await _body(request)
        except ValueError as exc:
            return _error(400, exc)

        def mark() -> dict[str, Any]:
            label = body.get("label")
            return {"label": label, "host_time_s": lab.add_marker(label)}
        return await call(mark)

    async def record_stop(request: Request) -> Response:
        def stop() -> dict[str, Any]:
            out = lab.stop_recording()
            out["sway"] = trial_sway(out["session"])
            return out
        return await call(stop)

    async def sessions(request: Request) -> Response:
        return await call(lambda: {"sessions": lab.sessions(), "data_dir": str(lab.data_dir)})

    async def replay(request: Request) -> Response:
        action = request.path_params["action"]
        try:
            body = await _body(request)
        except ValueError as exc:
            return _error(400, exc)
        if action == "open":
            name = body.get("session")
            if not isinstance(name, str):
                return _error(400, "replay/open needs {\"session\": NAME}")
            return await call(lab.open_replay, name, body.get("speed", 1.0))
        if action == "close":
            return await call(lambda: (lab.close_replay(), {"replay": None})[1])
        if action in ("play", "pause"):
            return await call(lab.replay_do, action)
        if action in ("seek", "speed"):
            key = "t_s" if action == "seek" else "speed"
            if key not in body:
                return _error(400, f"replay/{action} needs {{\"{key}\": number}}")
            return await call(lab.replay_do, action, body[key])
        return _error(404, f"no replay action {action!r}")

    async def calibrate(request: Request) -> Response:
        action = request.path_params["action"]
        try:
            body = await _body(request)
        except ValueError as exc:
            return _error(400, exc)
        if action == "start":
            return await call(lab.calibrate_start, body.get("pairs"), body.get("seconds", 1.0))
        if action == "step":
            return await call(lab.calibrate_step, body.get("step"), body.get("row"), body.get("col"))
        if action == "finish":
            return await call(lab.calibrate_finish)
        if action == "cancel":
            return await call(lab.calibrate_cancel)
        return _error(404, f"no calibrate action {action!r}")

    async def ws(websocket: WebSocket) -> None:
        await websocket.accept()
        hub.loop = asyncio.get_running_loop()
        ev = asyncio.Event()
        gone = asyncio.Event()
        hub.add(ev)

        async def listen() -> None:
            try:
                while True:
                    msg = await websocket.receive()
                    if msg["type"] == "websocket.disconnect":
                        break
            except (WebSocketDisconnect, RuntimeError):
                pass
            finally:
                gone.set()
                ev.set()

        listener = asyncio.create_task(listen())
        try:
            await websocket.send_text(json.dumps({"type": "hello", "status": await run_in_threadpool(lab.status)}))
            if lab.latest is not None:
                ev.set()
            sent: str | None = None
            while True:
                await ev.wait()
                ev.clear()
                if gone.is_set():
                    break
                # the newest message; not the one just sent again: lab.latest changes before the hub's
                # notice reaches this loop, so a notice can come for a message already read and sent
                text = lab.latest
                if text is not None and text is not sent:
                    await websocket.send_text(text)
                    sent = text
        except (WebSocketDisconnect, RuntimeError, OSError):
            pass
        finally:
            hub.remove(ev)
            listener.cancel()
            with contextlib.suppress(BaseException):
                await listener

    @contextlib.asynccontextmanager
    async def lifespan(app: Starlette) -> Any:
        hub.loop = asyncio.get_running_loop()
        try:
            yield
        finally:
            await run_in_threadpool(lab.close)

    routes = [Route("/", page), Route("/static/{name}", asset), Route("/api/status", status),
              Route("/api/record/start", record_start, methods=["POST"]), Route("/api/marker", marker, methods=["POST"]),
              Route("/api/record/stop", record_stop, methods=["POST"]), Route("/api/sessions", sessions),
              Route("/api/replay/{action}", replay, methods=["POST"]),
              Route("/api/calibrate/{action}", calibrate, methods=["POST"]), WebSocketRoute("/ws", ws)]
    app = Starlette(routes=routes, middleware=[Middleware(TokenGuard, token=token)], lifespan=lifespan)
    app.state.lab = lab
    app.state.hub = hub
    return app

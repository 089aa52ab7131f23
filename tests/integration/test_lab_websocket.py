"""The lab's WebSocket feed (psmat.lab._app) on a real uvicorn server and a real client: each display message
goes to a client once. A lab whose display worker changes ``latest`` before the hub's notice reaches the
client's loop used to send that message twice: the loop read the new message early, then the late notice
sent it again (seen as a repeated ``seq`` in tests/e2e/test_cli_lab.py on a loaded machine)."""

from __future__ import annotations

import asyncio
import json
import socket
import threading
import time
from typing import Any

import pytest

pytest.importorskip("starlette")
uvicorn = pytest.importorskip("uvicorn")
websockets_sync = pytest.importorskip("websockets.sync.client")

from psmat.lab import new_token  # noqa: E402
from psmat.lab._app import ClientHub, build_app  # noqa: E402

from hang_guard import HANG_GUARD_S  # noqa: E402


class _Lab:
    """What the WebSocket route reads of a lab: its status and its newest display message."""

    def __init__(self) -> None:
        self.latest: str | None = None

    def status(self) -> dict[str, Any]:
        return {"device": None}

    def close(self) -> None:
        pass


def _message(seq: int) -> str:
    return json.dumps({"type": "frame", "seq": seq})


@pytest.fixture
def served():
    lab, hub, token = _Lab(), ClientHub(), new_token()
    sock = socket.socket()
    sock.bind(("127.0.0.1", 0))
    server = uvicorn.Server(uvicorn.Config(build_app(lab, token, hub), log_level="warning", ws="websockets-sansio",
                                           lifespan="on"))
    thread = threading.Thread(target=server.run, kwargs={"sockets": [sock]}, daemon=True)
    thread.start()
    deadline = time.monotonic() + HANG_GUARD_S
    while not server.started:
        assert time.monotonic() < deadline and thread.is_alive(), "the server did not start"
        time.sleep(0.02)
    try:
        yield lab, hub, f"ws://127.0.0.1:{sock.getsockname()[1]}/ws?token={token}"
    finally:
        server.should_exit = True
        thread.join(HANG_GUARD_S)
        sock.close()


def _until_client(hub: ClientHub) -> None:
    deadline = time.monotonic() + HANG_GUARD_S
    while hub.clients == 0:
        assert time.monotonic() < deadline, "the client never joined the hub"
        time.sleep(0.01)


def _first_message(ws: Any, lab: _Lab, hub: ClientHub) -> None:
    """The hello, then message 1 published and received, on a client that has joined the hub."""
    assert json.loads(ws.recv(timeout=HANG_GUARD_S))["type"] == "hello"
    _until_client(hub)
    lab.latest = _message(1)
    hub.notify(lab.latest)
    assert json.loads(ws.recv(timeout=HANG_GUARD_S))["seq"] == 1


def test_a_notice_for_a_message_already_sent_sends_nothing(served) -> None:
    lab, hub, url = served
    with websockets_sync.connect(url, open_timeout=HANG_GUARD_S) as ws:
        _first_message(ws, lab, hub)
        # the late notice of the race: for message 1, which the client's loop already read and sent
        hub.notify(lab.latest)
        with pytest.raises(TimeoutError):
            ws.recv(timeout=0.5)
        lab.latest = _message(2)
        hub.notify(lab.latest)
        assert json.loads(ws.recv(timeout=HANG_GUARD_S))["seq"] == 2


def test_a_client_that_does_not_read_gets_the_newest_message_only(served) -> None:
    lab, hub, url = served
    with websockets_sync.connect(url, open_timeout=HANG_GUARD_S) as ws:
        _first_message(ws, lab, hub)
        for seq in range(2, 30):  # many messages before the loop runs: one send, of the newest
            lab.latest = _message(seq)
            hub.notify(lab.latest)
        got = [json.loads(ws.recv(timeout=HANG_GUARD_S))["seq"]]
        with pytest.raises(TimeoutError):
            while True:
                got.append(json.loads(ws.recv(timeout=0.5))["seq"])
        assert got[-1] == 29 and len(got) == len(set(got)) and got == sorted(got)


def test_the_hub_counts_its_clients_and_ignores_notices_before_any_loop() -> None:
    # notify from a thread with no loop set yet is a no-op, not an error (the display worker may publish
    # before the first client connects)
    hub = ClientHub()
    hub.notify("x")
    ev = asyncio.Event()
    hub.add(ev)
    assert hub.clients == 1
    hub.remove(ev)
    assert hub.clients == 0

"""``psmat lab``: the lab app - acquire, watch, mark, record and replay in a web browser.

``psmat lab PORT`` reads a mat on a serial port, ``psmat lab --simulate`` serves the digital twin
of the profile and reads that, ``psmat lab --replay FILE`` plays a recorded session back. The
server runs in this process: the device's reader thread feeds a running recording directly
(a slow or absent browser costs display frames only), a worker thread processes the newest
frames for the page (raw counts, pressure, centre of pressure) at most ``--display-rate``
times a second, and the page (a local web page, no internet needed) starts and stops trials
(subject, trial, note), marks events (buttons and keys 1-9; stored in the session file), shows
the trial's sway metrics when it stops, and lists and replays the data folder's sessions. Its
"Calibrate the box" panel walks through the open/short calibration of the electronics
(docs/spec.md §2; as ``psmat calibrate``; with ``--simulate`` the twin sets up each step itself)
and writes ``DATA/calibration/<serial>.json``; the trials recorded afterwards store it.

Security: the server listens on 127.0.0.1 (this machine only) unless ``--host`` says otherwise
(a warning is printed then: anyone who can reach the port and learns the token can record and
read the data folder). A random token is made at every start and required by every request;
the first line printed is the page's address with it (open it, or let the command open the
browser). Every file the server reads or writes lies inside the data folder (``--data``),
whatever a request asks for.

Ctrl-C (or SIGTERM) stops the server; a recording that is running is closed into its file first.
"""

from __future__ import annotations

import argparse
from typing import Any

from . import _args, _profile_args

NAME = "lab"
HELP = "the lab app in a web browser: live mat (PORT), twin (--simulate) or replay (--replay FILE); record, mark"


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("device_port", nargs="?", default=None, metavar="PORT",
                   help="the mat's serial port (/dev/ttyACM0, COM4, a pty) or a pyserial URL such as "
                        "socket://127.0.0.1:5555")
    p.add_argument("--simulate", action="store_true", help="serve the digital twin of the profile and read it")
    p.add_argument("--replay", type=_args.input_file, default=None, metavar="FILE",
                   help="play a recorded session back instead of reading a mat")
    _profile_args.add_profile_argument(p)
    _profile_args.add_mat_overrides(p)
    p.add_argument("--scene", default="sway",
                   help="with --simulate: the twin's scene, sway, quiet, single-leg or sitting")
    p.add_argument("--rate", type=_args.rate_hz, default=None,
                   help="frame rate (Hz): with --simulate the twin's; with PORT asked of a v1/v2 box, a whole "
                        "number 1 ... 1000, as psmat record does (a csv mat takes no commands); default: the "
                        "profile's for the twin, the box's own for a box")
    p.add_argument("--speed", type=_args.speed, default=1.0,
                   help="with --replay: recorded seconds played per second (2 = twice as fast)")
    p.add_argument("--data", default="psmat_data", metavar="DIR",
                   help="the data folder: sessions are recorded, listed and replayed here and nowhere else "
                        "(created if missing)")
    p.add_argument("--host", default="127.0.0.1",
                   help="address to listen on; anything but a loopback address exposes the lab to the network "
                        "(a warning is printed)")
    p.add_argument("--port", type=_args.tcp_port, default=8765,
                   help="TCP port to listen on (0: a free one, named in the first line printed)")
    p.add_argument("--display-rate", type=_args.rate_hz, default=30,
                   help="most display updates per second sent to the page (Hz)")
    p.add_argument("--no-browser", action="store_true", help="do not open a web browser on the page")


def _start_source(args: argparse.Namespace, lab: Any, stack: Any) -> None:
    """Open what the lab shows first (the twin and its reader, a mat, or a replay) and attach it."""
    import sys

    from ..acquire import open_device

    if args.replay:
        from pathlib import Path

        lab.replay_file(Path(args.replay).resolve(), args.speed)
        return
    prof = _profile_args.resolve(args, "psm")
    port = args.device_port
    fixture = None
    if args.simulate:
        from ..twin import CalibrationFixture, PsmSource, SerialTwin

        rate, note = _profile_args.twin_rate_hz(args.rate, prof)
        if note:
            print(f"psmat lab: {note}", file=sys.stderr)
        if problem := _args.twin_shape_problem(tuple(prof.shape)):
            raise ValueError(problem)
        # the scene behind the calibration set-ups (mode "mat" passes it through), as psmat calibrate --simulate
        fixture = CalibrationFixture(PsmSource.named(args.scene, rate, profile=prof))
        twin = SerialTwin("psm", rate, prof.protocol, source=fixture, shape=tuple(prof.shape)).start()
        stack.callback(twin.stop)
        port = twin.port
        print(f"psmat lab: simulated mat ({prof.name}, {args.scene}, {prof.protocol}, {twin.rate_hz:g} Hz) on {port}",
              file=sys.stderr, flush=True)
    # a lab runs all day: a cable pulled and put back (the board's port back at the same path) is re-opened,
    # however long it stayed away, and the page says so (psmat.acquire.link_line)
    dev = open_device(port, "psm", prof.protocol, tuple(prof.shape), baudrate=prof.baudrate, bits=prof.bits,
                      row_order=prof.row_order, col_order=prof.col_order, reconnect=True, reconnect_attempts=None)
    stack.callback(dev.close)
    if args.rate is not None and not args.simulate:
        dev.set_rate(args.rate)   # a whole number of frames/s, or ValueError; a csv mat was refused before
    dev.start()
    lab.attach_live(dev, prof, f"{port}{' (twin)' if args.simulate else ''}", simulated=bool(args.simulate),
                    set_fixture=(lambda mode: setattr(fixture, "mode", mode)) if args.simulate else None)


def run(args: argparse.Namespace) -> int:
    import contextlib
    import socket
    import sys
    from pathlib import Path

    def err(msg: str) -> None:
        print(f"psmat lab: {msg}", file=sys.stderr, flush=True)

    given = [x for x in (args.device_port, args.simulate or None, args.replay) if x]
    if len(given) != 1:
        err("give one of PORT, --simulate or --replay FILE")
        return 1
    if args.replay:
        from ._replay import REPLAY_FIXED

        fixed = [opt for opt, attr in REPLAY_FIXED if getattr(args, attr, None) is not None]
        if fixed:
            err(f"{', '.join(fixed)}: a replay's shape, protocol, ADC bits and rate are the session's "
                f"({args.replay}); leave {'them' if len(fixed) > 1 else 'it'} out")
            return 1
    if args.rate is not None and args.device_port:
        try:
            csv = _profile_args.resolve(args, "psm").protocol == "csv"
        except ValueError:
            csv = False   # said when the source is opened
        if csv:
            err("a csv mat takes no commands: it keeps its own rate (--rate only with --simulate or a v1/v2 box)")
            return 1
    try:
        import uvicorn

        from ..lab import ClientHub, LabSession, build_app, is_loopback, new_token
    except ImportError as exc:
        err(f"the lab app needs starlette, uvicorn and websockets (pip install 'psmat[lab]'): {exc}")
        return 1
    import serial

    from ..acquire import AcquireError

    data = Path(args.data)
    try:
        data.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        err(f"cannot use the data folder {data}: {exc}")
        return 1
    if not is_loopback(args.host):
        err(f"warning: listening on {args.host}, not this machine only: anyone who reaches port {args.port} and "
            "learns the token can record and read the data folder")
    try:
        sock = socket.socket(socket.AF_INET6 if ":" in args.host else socket.AF_INET, socket.SOCK_STREAM)
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        sock.bind((args.host, args.port))
        sock.listen(128)   # connections wait from now on, before the server runs
    except OSError as exc:
        err(f"cannot listen on {args.host}:{args.port}: {exc}")
        return 1
    token = new_token()
    hub = ClientHub()
    lab = LabSession(data, display_hz=float(args.display_rate), publish=hub.notify)
    with contextlib.ExitStack() as stack:   # closed in reverse: the lab (recording), then devices, twin
        stack.callback(sock.close)
        try:
            _start_source(args, lab, stack)
        except (serial.SerialException, OSError, AcquireError, ValueError) as exc:
            err(f"cannot open the source: {' '.join(str(exc).split())}")
            return 1
        stack.callback(lab.close)
        host, port = sock.getsockname()[:2]
        shown = f"[{host}]" if ":" in host else host
        url = f"http://{shown}:{port}/?token={token}"
        print(url, flush=True)   # the first line of stdout: the page's address with the token
        print(f"psmat lab: data folder {lab.data_dir}; Ctrl-C stops (a running recording is saved first)",
              file=sys.stderr, flush=True)
        if not args.no_browser:
            import webbrowser

            with contextlib.suppress(Exception):
                webbrowser.open(url)
        config = uvicorn.Config(build_app(lab, token, hub), log_level="warning", ws="websockets-sansio",
                                lifespan="on", timeout_graceful_shutdown=3)
        server = uvicorn.Server(config)
        server.run(sockets=[sock])
    return 0

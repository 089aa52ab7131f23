"""``psmat view``: a live window on a mat - raw image, pressure, centre-of-pressure trace.

``psmat view PORT`` reads a mat on a serial port; ``psmat view --simulate`` serves the
digital twin on a pseudo-terminal and reads that; ``psmat view S.h5`` replays a recorded
session (:func:`psmat.acquire.open_playback`) at its recorded times, ``--speed X`` times as
fast, drawn with the profile stored in the session (else one rebuilt from it, or ``--profile``); its
status line says ``replay of S.h5 at X×``. A recording that was not closed (its journal only)
is not replayed: one line says ``psmat repair S.h5`` finishes it. The window shows the equivalent
conductance G (mS, crosstalk included), the pressure (kPa) after IECM and the inverse sensor
model, and the last 10 s of the CoP (M-L and A-P, cm); the title line shows the port, the
frames/s received, invalid and lost frames, the processing rate and the display rate.

Closing the window (or Ctrl-C) stops and closes the device; a port that vanishes ends the
view with a message and exit status 3; an error a person can fix (no port, no display, a
port that cannot be opened) is one line and status 1, as in every command. Without a display, ``--seconds S --save out.png``
renders headless (MPLBACKEND=Agg) and writes a screenshot (without ``--seconds`` it runs
until Ctrl-C).

The mat is described by its profile (``--profile NAME|FILE``, default ``psm16``, or
``arduino16`` with ``--protocol csv``; docs/spec.md §5 "Device profiles"): its protocol, shape,
ADC bits, line speed and wire order open the port, its geometry places the images and the CoP
(cm), its circuit turns counts into conductance, and ``--simulate`` serves a twin of it.
``--protocol``, ``--shape`` and ``--bits`` override the profile's. With neither ``--shape``
nor ``--profile``, a mat whose IDENTIFY reports another shape is read with that shape.
"""

from __future__ import annotations

import argparse
from typing import Any

from . import _args, _profile_args

NAME = "view"
HELP = "live window on a mat (PORT) or the digital twin (--simulate): raw image, pressure, CoP"

#: exit status when the port vanished
EXIT_DISCONNECTED = 3


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("port", nargs="?", default=None, help="the mat's serial port (/dev/ttyACM0, COM4, a pty), a "
                   "pyserial URL such as socket://127.0.0.1:5555, or a recorded session file (S.h5) to replay")
    p.add_argument("--speed", type=_args.speed, default=None,
                   help="with a session file as PORT: replay speed, recorded seconds per second (2 = twice as "
                        "fast; default 1)")
    p.add_argument("--simulate", action="store_true", help="view the digital twin instead of a mat")
    _profile_args.add_profile_argument(p)
    p.add_argument("--rate", type=_args.positive_int, default=None,
                   help="with --simulate: the twin's frame rate (frames/s; default: the profile's)")
    p.add_argument("--protocol", choices=("v1", "v2", "csv"), default=None,
                   help="the mat's frame format (docs/protocol.md): v1, v2, or csv (the text lines of a "
                        "do-it-yourself mat; default: the profile's)")
    p.add_argument("--scene", default="sway",
                   help="with --simulate: the twin's scene, sway, quiet, single-leg or sitting")
    p.add_argument("--shape", type=_args.shape, default=None,
                   help="the mat's rows x columns, e.g. 16x16 (default: the profile's; without --profile, what "
                        "the mat reports, else the profile's)")
    p.add_argument("--bits", type=_args.bits, default=None,
                   help="ADC resolution of a csv mat: a count above 2**bits - 1 is an invalid frame (default: the "
                        "profile's; v1/v2 mats carry 12-bit counts)")
    p.add_argument("--decimate", type=_args.positive_int, default=1, help="process and draw every Nth frame")
    p.add_argument("--seconds", type=_args.seconds, default=None,
                   help="close after this long (s; default: when the window is closed)")
    p.add_argument("--save", type=_args.figure_file, default=None, metavar="PNG",
                   help="write a screenshot of the figure at the end (its suffix names the format: .png, .pdf, ...)")
    p.add_argument("--overwrite", action="store_true", help="replace an existing screenshot file")
    p.add_argument("--no-iecm", action="store_true",
                   help="raw image and raw centre of pressure (CoP) only, without IECM (crosstalk removal), for "
                        "slow machines")
    p.add_argument("--g-rest", type=_args.conductance, default=1e-7,
                   help="conductance of an unloaded cell, subtracted before the sensor model (S)")
    p.add_argument("--interval", type=_args.seconds, default=0.05, help="pause between redraws (s)")


def _pick_backend(args: argparse.Namespace) -> tuple[bool, str | None]:
    """Choose a matplotlib backend: (interactive, error message or None)."""
    import os
    import sys

    import matplotlib

    from ..live.view import NON_INTERACTIVE

    if os.environ.get("MPLBACKEND"):
        interactive = matplotlib.get_backend().lower() not in NON_INTERACTIVE
    else:
        display = sys.platform in ("win32", "darwin") or bool(os.environ.get("DISPLAY")
                                                             or os.environ.get("WAYLAND_DISPLAY"))
        interactive = False
        if display:
            for name in ("TkAgg", "QtAgg"):
                try:
                    matplotlib.use(name, force=True)
                    import matplotlib.pyplot as plt

                    plt.figure().clear()
                    plt.close("all")
                    interactive = True
                    break
                except Exception:  # noqa: BLE001 - backend or toolkit unavailable
                    continue
        if not interactive:
            matplotlib.use("Agg", force=True)  # headless: only useful with --save
    if not interactive and not args.save:
        why = "no display" if not os.environ.get("MPLBACKEND") else f"backend {matplotlib.get_backend()!r}"
        return False, (f"cannot open a window ({why}; TkAgg or QtAgg is needed). Render headless instead: "
                       "MPLBACKEND=Agg psmat view ... --seconds 5 --save view.png")
    return interactive, None


def _check_files(args: argparse.Namespace) -> str | None:
    """A session file given as the port, or a screenshot that may not be written: one line, or None."""
    import os

    from .._atomic import OutputRefused, check_outputs
    from ..io import journal_path
    from ..io.session import unfinished_line

    from ._replay import REPLAY_FIXED, is_session_file

    port = args.port
    if port is not None and (os.path.isfile(port) or journal_path(port).is_file()):
        problem = unfinished_line(port)  # a recording not closed: psmat repair finishes it
        if problem:
            return problem
        if not is_session_file(port):
            return (f"{port} is neither a serial port nor a session file (HDF5): psmat view shows a live mat "
                    "(/dev/ttyACM0, COM4, socket://HOST:PORT) or replays a recorded session (S.h5)")
        given = [opt for opt, attr in REPLAY_FIXED if getattr(args, attr, None) is not None]
        if given:
            return (f"{', '.join(given)}: a replay's shape, protocol, ADC bits and rate are the session's "
                    f"({port}); leave {'them' if len(given) > 1 else 'it'} out")
    elif args.speed is not None:
        return "--speed replays a session file given as PORT (psmat view S.h5 --speed 2), not a live mat"
    try:
        check_outputs([args.save], inputs=[port], overwrite=args.overwrite)
    except OutputRefused as exc:
        return str(exc)
    return None


def _open(port: str, prof: Any) -> Any:
    """The mat on ``port`` opened as its profile says: protocol, shape, ADC bits, line speed, wire order."""
    from ..acquire import open_device

    return open_device(port, "psm", prof.protocol, tuple(prof.shape), baudrate=prof.baudrate, bits=prof.bits,
                       row_order=prof.row_order, col_order=prof.col_order)


def run(args: argparse.Namespace) -> int:
    import sys

    import serial

    from ..acquire import AcquireError

    def err(msg: str) -> None:
        print(f"psmat view: {msg}", file=sys.stderr, flush=True)

    if (args.port is None) == (not args.simulate):
        err("give a PORT or --simulate (not both)")
        return 1
    problem = _check_files(args)
    if problem:
        err(problem)
        return 1
    interactive, problem = _pick_backend(args)
    if problem:
        err(problem)
        return 1

    from ._replay import is_session_file, open_replay, replay_label

    twin = None
    dev = None
    port = args.port
    replay = is_session_file(port)
    if replay:
        try:
            dev, prof, note = open_replay(port, args.speed or 1.0, args.profile)
        except (OSError, ValueError) as exc:
            err(str(exc))
            return 1
        print(f"{replay_label(port, dev.speed)}: {dev.n_frames} frames, {dev.duration_s:.1f} s recorded, profile "
              f"{prof.name}{'; ' + note if note else ''}", flush=True)
    else:
        try:
            prof = _profile_args.resolve(args, "psm")
        except ValueError as exc:
            err(str(exc))
            return 1
    if args.simulate:
        from ..twin import PsmSource, SerialTwin

        rate = args.rate or prof.rate_hz
        if problem := _args.twin_shape_problem(prof.shape):
            err(problem)
            return 1
        try:
            source = PsmSource.named(args.scene, rate, profile=prof)
            twin = SerialTwin("psm", rate, prof.protocol, source=source, shape=prof.shape).start()
        except (ValueError, FileNotFoundError) as exc:
            err(str(exc))
            return 1
        port = twin.port
        print(f"simulated mat ({prof.name}, {args.scene}, {prof.protocol}, {twin.rate_hz:g} Hz) on {port}",
              flush=True)
    try:
        if not replay:
            try:
                dev = _open(port, prof)
                d = dev.description or {}
                if (args.shape is None and args.profile is None and "rows" in d and "cols" in d
                        and (int(d["rows"]), int(d["cols"])) != tuple(dev.shape)):
                    dev.close()
                    prof = prof.with_shape((int(d["rows"]), int(d["cols"])))  # what the mat reports
                    dev = _open(port, prof)
                dev.start()
            except (serial.SerialException, OSError, AcquireError) as exc:
                err(f"cannot read a mat on {port}: {exc}")
                return EXIT_DISCONNECTED if isinstance(exc, AcquireError) else 1

        from ..live import LiveView, run_view

        label = replay_label(port, dev.speed) if replay else f"{port}{' (twin)' if twin else ''}"
        view = LiveView(dev, profile=prof, iecm=not args.no_iecm, decimate=args.decimate, g_rest=args.g_rest,
                        rate_hz=twin.rate_hz if twin is not None else None, port=label)

        def stop_device() -> None:
            dev.close()

        result = run_view(view, seconds=args.seconds, interval_s=args.interval, save=args.save,
                          interactive=interactive, on_close=stop_device)
    except KeyboardInterrupt:
        err("interrupted")
        return 0
    finally:
        if dev is not None:
            dev.close()
        if twin is not None:
            twin.stop()
    s = dev.stats
    summary = (f"{result.message}; {view.received} frames received, {view.processed} processed, "
               f"{s.invalid} invalid, {s.dropped_wire + s.dropped_buffer} lost")
    if result.saved:
        summary += f"; screenshot {result.saved}"
    if result.status:
        err(summary)
    else:
        print(f"psmat view: {summary}", flush=True)
    return result.status

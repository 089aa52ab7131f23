"""``psmat record``: record a session file from one device or several (or their digital twins) (docs/spec.md §6).

The first device (PORT, --device) is the session's root; each --also KIND=PORT is one more
device, recorded as the stream KIND of the same file (e.g. the spine IMUs with the mat,
docs/spec.md §8). All devices share one host clock, so every stream's host_time_s is on the same
clock; each device's reader thread appends to its own stream.

The first device is described by its profile (``--profile``, or its kind's shipped one, with
``--protocol``, ``--shape`` and ``--bits`` overriding those fields; ``psmat profiles`` lists them),
which the session stores (``Session.profile``); an ``--also`` device by its kind's shipped
profile, kept under ``"profile"`` in its stream's device dict. A twin (``--simulate``) is the
profile's device.

``--lsl NAME`` records another program's Lab Streaming Layer stream (a force platform, EEG; found
by its name, else its type) as one more stream of the session, of kind ``lsl``: its samples as
float64 ``(T, channels)``, their LSL timestamps mapped to the session's host clock
(``host_time_s = timestamp + LSL time correction + offset``, the offset between LSL's clock and
the host clock measured once when the stream is opened; psmat.acquire.LslInlet). The session's
stream is named ``lsl_NAME`` (characters other than letters, digits and ``_`` made ``_``).

A device's port that vanishes (a cable pulled) is re-opened whenever it is back at the same path,
without a limit on attempts, as the lab does (docs/spec.md §13): the recording keeps its file and goes
on with the frames after the gap, which the chain steps over by the frames' clocks (docs/spec.md §5).
One line on stderr says when the port is lost and one when it is found again; the summary says how
often and for how long, and a port still lost when the recording ends makes the exit status 1.
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass
from typing import Any

from . import _args, _profile_args

NAME = "record"
HELP = "record a session (HDF5) from a mat, IMU or material DAQ, or several at once; Ctrl-C stops cleanly"

KINDS = ("psm", "imu", "daq")


@dataclass(frozen=True)
class Also:
    """One more device: its kind (also the stream's name) and port (None with ``--simulate``)."""

    kind: str
    port: str | None


def also(text: str) -> Also:
    """``KIND=PORT`` (a device) or ``KIND`` (its twin, with ``--simulate``); KIND one of psm, imu, daq."""
    kind, sep, port = text.partition("=")
    if kind not in KINDS:
        raise argparse.ArgumentTypeError(f"a device is KIND=PORT with KIND one of {', '.join(KINDS)} "
                                         f"(e.g. imu=/dev/ttyACM1), got {text!r}")
    if sep and not port:
        raise argparse.ArgumentTypeError(f"no port after {kind}= in {text!r}")
    return Also(kind, port or None)


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("port", nargs="?", help="serial port of the first device, or a pyserial URL such as "
                   "socket://127.0.0.1:5555 (omit with --simulate)")
    p.add_argument("-o", "--out", required=True, help="session file to write (.h5)")
    p.add_argument("--simulate", action="store_true", help="record the digital twin (one per device)")
    _profile_args.add_profile_argument(p)
    p.add_argument("--device", choices=KINDS, default=None,
                   help="kind of the first device: psm (a pressure-sensitive mat), imu (spine IMUs, inertial "
                        "measurement units) or daq (the material data-acquisition box); default: the --profile's "
                        "kind, else psm (a --device that disagrees with --profile is refused)")
    p.add_argument("--also", type=also, action="append", default=[], metavar="KIND=PORT",
                   help="one more device recorded into the same file as stream KIND, on the same host clock "
                        "(e.g. --also imu=/dev/ttyACM1; with --simulate just --also imu); repeatable, each kind once")
    p.add_argument("--lsl", action="append", default=[], metavar="NAME",
                   help="also record the Lab Streaming Layer stream NAME (its name, else its type: a force platform, "
                        "EEG) as the stream lsl_NAME of the session, on the same host clock (waits up to 5 s for it); "
                        "repeatable")
    _profile_args.add_mat_overrides(p, "the devices'")
    p.add_argument("--rate", type=_args.rate_hz, default=None,
                   help="ask the first device for this frame rate, the others keep theirs (Hz; default: the "
                        "device's own; a twin's is its profile's rate_hz)")
    p.add_argument("--seconds", type=_args.seconds, default=None,
                   help="stop after this long (s; default: at Ctrl-C)")
    p.add_argument("--calibration", type=_args.input_file, default=None,
                   help="calibration JSON of the box (psmat calibrate)")
    p.add_argument("--subject", default="", help="subject id (metadata)")
    p.add_argument("--trial", default="", help="trial name (metadata)")
    p.add_argument("--note", default="", help="free text (metadata)")
    p.add_argument("--overwrite", action="store_true",
                   help="replace an existing session file (it stays as it is until the new one is complete)")


def _check(args: argparse.Namespace, profiles: list[Any]) -> str | None:
    """What is wrong with the command line that argparse cannot see, or None (``profiles``: each
    device's profile, the first device's first)."""
    import os

    from .._atomic import OutputRefused, check_outputs
    from ..io import journal_path
    from ..io.session import unfinished_line

    if bool(args.port) == bool(args.simulate):
        return "give a PORT or --simulate"
    prof = profiles[0]
    kind = prof.kind
    kinds = [a.kind for a in args.also]
    if len(set(kinds)) != len(kinds):
        return f"--also names each kind once, got {', '.join(kinds)}"
    lsl = [lsl_stream_name(n) for n in args.lsl]
    if len(set(lsl)) != len(lsl):
        return f"--lsl names each stream once, got {', '.join(args.lsl)}"
    for a in args.also:
        if args.simulate and a.port:
            return f"with --simulate, --also takes a kind only (--also {a.kind}), not a port"
        if not args.simulate and not a.port:
            return f"--also {a.kind} needs the device's port: --also {a.kind}=PORT"
    if prof.protocol == "csv" and (kind != "psm" or args.also):
        return "--protocol csv is a do-it-yourself psm mat's text: record it alone, without --device imu/daq or --also"
    if prof.protocol == "csv" and args.rate and not args.simulate:
        return "a csv mat takes no commands: it keeps its own rate (--rate only with --simulate)"
    for pr in profiles:
        if args.simulate and pr.kind == "psm" and (twin := _args.twin_shape_problem(tuple(pr.shape))):
            return twin
    if args.rate and kind == "imu" and args.rate > _args.IMU_MAX_RATE_HZ:
        return (f"the spine IMUs run at most {_args.IMU_MAX_RATE_HZ} Hz (the BNO055's fusion output), "
                f"got --rate {args.rate:g}")
    unfinished = unfinished_line(args.out)  # its journals are the only copy of that recording: never replaced
    if unfinished:
        return f"{unfinished} ({journal_path(args.out)} is its only copy: not recorded over, even with --overwrite)"
    try:  # an existing file only with --overwrite, an input never (psmat._atomic)
        check_outputs([args.out], inputs=[args.calibration, args.port, *(a.port for a in args.also)],
                      overwrite=args.overwrite)
    except OutputRefused as exc:
        return str(exc)
    journals = [journal_path(args.out), *(journal_path(args.out, k) for k in (*kinds, *lsl))]
    taken = [p for p in journals if os.path.lexists(p)]
    if taken and not args.overwrite:
        return f"{taken[0]} exists; add --overwrite to replace it"
    return None


@dataclass
class _Source:
    """One device being recorded: its stream name (None for the root), device, writer, frames read."""

    name: str | None
    dev: Any
    writer: Any
    frames: int = 0
    ended: str | None = None
    link: tuple[bool, int] = (False, 0)  # the device's port lost now, and its reconnections, when last said

    @property
    def label(self) -> str:
        return self.dev.kind if self.name is None else self.name


def run(args: argparse.Namespace) -> int:
    import sys
    import time

    from ..acquire import invalid_line, link_line, silence_line
    from ..io import SessionNotCompleted, load_session, row_counts
    from ..process import adc_line

    try:  # the devices' profiles: the first's from --profile and the options, the others' their kind's
        kind = _profile_args.device_kind(args)
        prof = _profile_args.resolve(args, kind)
        profiles = [prof, *(_also_profile(args, a.kind) for a in args.also)]
        problem = _check(args, profiles)
    except ValueError as exc:
        problem = str(exc)
    if problem:
        print(f"psmat record: {problem}", file=sys.stderr)
        return 1
    calibration = None
    if args.calibration:
        from ..circuit import Calibration

        try:
            calibration = Calibration.load(args.calibration).to_dict()
        except (OSError, ValueError) as exc:  # unreadable, not JSON, not a calibration: named by the loader
            print(f"psmat record: {' '.join(str(exc).split())}", file=sys.stderr)
            return 1
    try:
        sources, status = _record(args, kind, prof, profiles, calibration)
    except SessionNotCompleted as exc:  # the file could not be written (a full disk): its journals keep the frames
        print(f"psmat record: {' '.join(str(exc).split())}; psmat repair {args.out} finishes it once the disk has "
              "room", file=sys.stderr)
        return 1
    if not sources:  # stopped before the file was begun
        return status
    saved = load_session(args.out)  # the writer closed: count the file's rows, as psmat info does
    for src in sources:
        st = src.dev.stats
        rc = row_counts(saved if src.name is None else saved.streams[src.name])
        where = args.out if src.name is None else f"{args.out} [{src.name}]"
        lost = "losses on the wire unknown" if rc.lost is None else f"{rc.lost} lost on the wire"
        print(f"{where}: {rc.frames} frames recorded, {rc.invalid} invalid, {lost}, "
              f"{st.dropped_buffer} dropped by the host buffer"
              + (f"; ended early: {src.ended}" if src.ended and len(sources) > 1 else ""))
        if rc.invalid and (why := invalid_line(st.invalid_reasons, src.dev, st.frames + st.invalid)):
            print(f"  {why}")
        if st.frames + st.invalid == 0 and (silent := silence_line(st.bytes_in, src.dev)):
            print(f"  {silent}")
        if narrow := adc_line(saved if src.name is None else saved.streams[src.name]):
            print(f"  {narrow}")
        if getattr(st, "lost_at", None) is not None:  # lost when the recording ended
            print(f"  {src.dev.port} was lost at {time.strftime('%H:%M:%S', time.localtime(st.lost_at))} and not found "
                  "again before the recording ended: the recording has no frames after that")
            status = 1
        elif gap := link_line(st, src.dev):
            print(f"  {gap}")
    return status


def _record(args: argparse.Namespace, kind: str, prof: Any, profiles: list[Any], calibration: Any
            ) -> tuple[list[_Source], int]:
    """Open the devices (or twins) and the session writer, record until the loop ends; the sources and
    the exit status. The writer's close (leaving the block) raises SessionNotCompleted."""
    import contextlib

    from ..acquire import HostClock, open_device
    from ..io import SessionWriter

    wanted = [Also(kind, args.port), *args.also]
    clock = HostClock()  # one host clock for every device's frames
    with contextlib.ExitStack() as stack:  # closed in reverse: recording stopped, writer, devices, twins
        lsl_devs = _open_lsl(stack, args.lsl, clock)  # first: a stream that is not there stops before any file
        if lsl_devs is None:
            return [], 1
        ports = [w.port for w in wanted]
        if args.simulate:
            ports = [_twin(stack, pr, args.rate if k == 0 else None, k) for k, pr in enumerate(profiles)]
        devs = []
        for k, (pr, port) in enumerate(zip(profiles, ports)):
            # a cable pulled and put back (the port back at the same path) is re-opened, however long it
            # stayed away (psmat.acquire.link_line says so, _loop prints it)
            dev = open_device(port, pr.kind, clock=clock, reconnect=True, reconnect_attempts=None,
                              **_device_options(pr))
            stack.callback(dev.close)
            if k == 0 and args.rate and not args.simulate and pr.kind != "daq":
                dev.set_rate(int(args.rate))
            devs.append(dev)
        root = devs[0]
        meta = {"subject": args.subject, "trial": args.trial, "note": args.note, "port": ports[0],
                "simulated": bool(args.simulate)}
        if args.also:
            meta["stream_ports"] = {w.kind: p for w, p in zip(args.also, ports[1:])}
        writer = stack.enter_context(SessionWriter(args.out, root.shape, device=dict(root.description or {}),
                                                   calibration=calibration, metadata=meta, kind=root.kind,
                                                   profile=prof.to_dict(), overwrite=args.overwrite))
        sources = [_Source(None, root, writer)]
        for w, dev, pr in zip(args.also, devs[1:], profiles[1:]):  # a stream keeps its profile in its device dict
            sources.append(_Source(w.kind, dev, writer.add_stream(w.kind, kind=dev.kind, shape=dev.shape,
                                                                  device={**(dev.description or {}),
                                                                          "profile": pr.to_dict()})))
        for name, dev in lsl_devs:  # another program's LSL stream, float64 (T, channels)
            sources.append(_Source(name, dev, writer.add_stream(name, kind="lsl", shape=dev.shape,
                                                                device=dev.description)))
        for src in sources:
            src.dev.record_to(src.writer)
            stack.callback(src.dev.stop_recording)  # the final counters, before the writer closes
            stack.callback(src.dev.stop)
        for src in sources:
            src.dev.start()
        status = _loop(sources, args)
    return sources, status


def lsl_stream_name(name: str) -> str:
    """The session stream an LSL stream ``name`` is recorded as: ``lsl_NAME``, characters other than
    ASCII letters, digits and ``_`` made ``_`` (so never a device kind's or a reserved name), at most
    64 characters."""
    import re

    return "lsl_" + re.sub(r"[^A-Za-z0-9_]", "_", name)[:60]


def _open_lsl(stack: Any, names: list[str], clock: Any) -> list[tuple[str, Any]] | None:
    """The ``--lsl`` streams opened on ``clock`` (closed with ``stack``), by session stream name;
    None after printing one line when one cannot be opened."""
    import sys

    from ..acquire import AcquireError, open_lsl

    out = []
    for name in names:
        try:
            dev = open_lsl(name, 5.0, clock=clock)
        except (ImportError, AcquireError, ValueError) as exc:
            print(f"psmat record: --lsl {name}: {' '.join(str(exc).split())}", file=sys.stderr)
            return None
        stack.callback(dev.close)
        out.append((lsl_stream_name(name), dev))
    return out


def _also_profile(args: argparse.Namespace, kind: str) -> Any:
    """The profile of an ``--also`` device: its kind's shipped one, with the command line's
    ``--protocol`` (not the DAQ's), ``--shape`` and ``--bits`` (a mat's: it is never the first device then)."""
    options = argparse.Namespace(profile=None, protocol=None if kind == "daq" else args.protocol,
                                 shape=args.shape, bits=args.bits)
    return _profile_args.resolve(options, kind)


def _device_options(prof: Any) -> dict[str, Any]:
    """:func:`psmat.acquire.open_device`'s keywords for a device of profile ``prof``."""
    options: dict[str, Any] = {"baudrate": prof.baudrate}
    if prof.kind != "daq":  # the DAQ's text lines have one format, whatever the protocol says
        options["protocol"] = prof.protocol
    if prof.kind == "psm":
        options.update(shape=tuple(prof.shape), bits=prof.bits, row_order=prof.row_order, col_order=prof.col_order)
    return options


def _twin(stack: Any, prof: Any, rate_hz: float | None, k: int) -> str:
    """Start the digital twin of the ``k``-th device, of profile ``prof`` at ``rate_hz`` (None: the
    profile's), stopped when ``stack`` closes; its port."""
    import sys

    from ..twin import PsmSource, SerialTwin

    rate, note = _profile_args.twin_rate_hz(rate_hz, prof)
    if note:
        print(f"psmat record: {note}", file=sys.stderr)
    source = PsmSource.named("sway", rate, profile=prof) if prof.kind == "psm" else None
    twin = SerialTwin(prof.kind, rate, "v2" if prof.kind == "daq" else prof.protocol, source=source,
                      shape=tuple(prof.shape) if prof.kind == "psm" else (16, 16), serial=f"TWIN{k + 1:04d}").start()
    stack.callback(twin.stop)
    return twin.port


def _link_news(src: _Source) -> str | None:
    """The line of ``src``'s port lost or found again (:func:`psmat.acquire.link_line`) when that changed
    since it was last said, else None."""
    from ..acquire import link_line

    st = src.dev.stats
    state = (getattr(st, "lost_at", None) is not None, int(getattr(st, "reconnects", 0) or 0))
    if state == src.link:
        return None
    src.link = state
    return link_line(st, src.dev)


def _loop(sources: list[_Source], args: argparse.Namespace) -> int:
    """Read every device until ``--seconds``, Ctrl-C or every device gone; one progress bar. Exit status.

    A device that disconnects ends its stream, reported on stderr (exit status 1); the others go on.
    """
    import sys
    import time

    from psmat._progress import tqdm
    from psmat._signals import stop_requests

    from ..acquire import DeviceDisconnected

    status = 0
    t0 = time.monotonic()
    many = len(sources) > 1
    # Ctrl-C, SIGTERM and SIGHUP end the loop at its next turn (at most 0.25 s), never in the middle of it
    with stop_requests() as stop, tqdm(unit=" frames", desc=f"recording {args.out}") as bar:
        try:
            while (args.seconds is None or time.monotonic() - t0 < args.seconds) and not stop.is_set():
                live = [s for s in sources if s.ended is None]
                if not live:
                    break
                for s in live:
                    try:  # the first device paces the loop; the others give what they buffered meanwhile
                        n = len(s.dev.read(timeout_s=0.25) if s is live[0] else s.dev.read())
                    except DeviceDisconnected as exc:
                        s.ended = str(exc)
                        status = 1
                        rest = "; the other devices go on" if many and len(live) > 1 else ""
                        print(f"\npsmat record: {exc}; the frames received so far are saved{rest}", file=sys.stderr)
                        continue
                    s.frames += n
                    bar.update(n)
                    if news := _link_news(s):  # its port lost, or found again
                        print(f"\npsmat record: {news}", file=sys.stderr)
                    if s.dev.recording_error:  # the file takes no more frames (a full disk): stop, say so
                        print(f"\npsmat record: {args.out} takes no more frames ({s.dev.recording_error}): the "
                              "recording stopped; the frames before it are kept", file=sys.stderr)
                        return 1
                if many:
                    bar.set_postfix_str(", ".join(f"{s.label} {s.frames}" for s in sources), refresh=False)
        except KeyboardInterrupt:
            pass
    return status

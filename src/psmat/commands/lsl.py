"""``psmat lsl``: publish a mat's pressure and centre of pressure on the Lab Streaming Layer (LSL).

The mat (PORT), its digital twin (``--simulate``) or a recorded session played back
(``--replay FILE``) is read, every frame goes through the processing chain (counts → pressure
in kPa → CoP in cm, psmat.process) and is pushed to three LSL streams that any LSL program
(LabRecorder, an EEG or motion-capture suite) sees on the network:

* NAME-pressure: type Pressure, R·C float32 channels in kPa, row-major (labels r00c00, ...),
  the mat's nominal rate, source id the box's serial number; rows, columns and pitch in its
  description;
* NAME-cop: type CoP, two float32 channels ml_cm and ap_cm;
* NAME-markers: type Markers, one string channel ("start" and "stop"; with a terminal, each line
  typed and Enter).

The first lines printed name the streams. Each sample is stamped on LSL's clock from the frame's
host time (the offset between the two clocks is measured once at start; frames that arrived
together are spread by the device's clock). Ctrl-C (or --seconds) stops cleanly.

The mat is described by its profile (--profile, default psm16; with --replay the session's
stored profile): its shape and pitch, its circuit for the counts, its rate.
"""

from __future__ import annotations

import argparse
from typing import Any

from . import _args, _profile_args

NAME = "lsl"
HELP = "publish a mat's pressure and CoP as Lab Streaming Layer streams (PORT, --simulate or --replay FILE)"


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("port", nargs="?", default=None, help="the mat's serial port (/dev/ttyACM0, COM4, a pty) or a "
                   "pyserial URL such as socket://127.0.0.1:5555 (omit with --simulate or --replay)")
    p.add_argument("--simulate", action="store_true", help="publish the digital twin of the profile's mat")
    p.add_argument("--replay", type=_args.input_file, default=None, metavar="FILE",
                   help="publish a recorded session (.h5) played back at its recorded pace")
    _profile_args.add_profile_argument(p)
    p.add_argument("--name", default="psmat", help="prefix of the streams' names: NAME-pressure, NAME-cop, "
                   "NAME-markers")
    p.add_argument("--rate", type=_args.positive_int, default=None,
                   help="with --simulate: the twin's frame rate (Hz; default: the profile's)")
    p.add_argument("--speed", type=_args.speed, default=1.0,
                   help="with --replay: recorded seconds per second (2 = twice as fast)")
    p.add_argument("--seconds", type=_args.seconds, default=None, help="stop after this long (s; default: at Ctrl-C)")
    p.add_argument("--g-rest", type=_args.conductance, default=1e-7,
                   help="conductance of an unloaded cell, subtracted before the sensor model (S)")


def run(args: argparse.Namespace) -> int:
    import contextlib
    import sys

    import serial

    from ..acquire import AcquireError
    from ..io import SessionFormatError

    def err(msg: str) -> int:
        print(f"psmat lsl: {msg}", file=sys.stderr, flush=True)
        return 1

    if sum((args.port is not None, bool(args.simulate), args.replay is not None)) != 1:
        return err("give one of PORT, --simulate or --replay FILE")
    try:
        prof = _profile_args.resolve(args, "psm")
    except ValueError as exc:
        return err(str(exc))
    with contextlib.ExitStack() as stack:
        try:
            dev, prof, rate = _source(stack, args, prof)
            from ..acquire import PressureOutlets

            serial_no = str((dev.description or {}).get("serial", "") or "")
            outlets = stack.enter_context(PressureOutlets.from_profile(prof, serial=serial_no, name=args.name,
                                                                       rate_hz=rate, clock=dev.clock))
        except ImportError as exc:
            return err(str(exc))
        except (serial.SerialException, OSError, AcquireError, SessionFormatError, ValueError) as exc:
            return err(" ".join(str(exc).split()))
        for key, what in (("pressure", f"Pressure, {prof.shape[0] * prof.shape[1]} channels in kPa"),
                          ("cop", "CoP, ml_cm and ap_cm"), ("markers", "Markers")):
            print(f"LSL stream {outlets.names[key]} ({what}, {rate:g} Hz)" if key != "markers"
                  else f"LSL stream {outlets.names[key]} ({what}, irregular)", flush=True)
        status = _publish(dev, prof, rate, outlets, args)
    print(f"psmat lsl: {outlets.pushed} frames published", flush=True)
    return status


def _source(stack: Any, args: argparse.Namespace, prof: Any) -> tuple[Any, Any, float]:
    """The device to read (started), the profile describing it and its frame rate (Hz)."""
    import sys

    from ..acquire import open_device

    if args.replay is not None:
        from ..acquire import open_playback
        from ..profile import Profile

        dev = open_playback(args.replay, speed=args.speed, start=False)
        stack.callback(dev.close)
        if dev.kind != "psm":
            raise ValueError(f"{args.replay} is a {dev.kind} session; psmat lsl publishes a mat's")
        if args.profile is None and dev.profile is not None:
            prof = Profile.from_dict(dev.profile, where=str(args.replay))
        if tuple(prof.shape) != tuple(dev.shape):
            prof = prof.with_shape(tuple(dev.shape))
        rate = float((dev.description or {}).get("rate") or prof.rate_hz)
        dev.start()
        return dev, prof, rate
    port = args.port
    rate = float(prof.rate_hz)
    if args.simulate:
        from ..twin import PsmSource, SerialTwin

        if problem := _args.twin_shape_problem(tuple(prof.shape)):
            raise ValueError(problem)
        rate, note = _profile_args.twin_rate_hz(args.rate, prof)
        if note:
            print(f"psmat lsl: {note}", file=sys.stderr)
        twin = SerialTwin("psm", rate, prof.protocol, source=PsmSource.named("sway", rate, profile=prof),
                          shape=tuple(prof.shape), serial="TWIN0001").start()
        stack.callback(twin.stop)
        port = twin.port
    dev = open_device(port, "psm", prof.protocol, tuple(prof.shape), baudrate=prof.baudrate, bits=prof.bits,
                      row_order=prof.row_order, col_order=prof.col_order)
    stack.callback(dev.close)
    if not args.simulate:
        rate = float((dev.description or {}).get("rate") or rate)
    dev.start()
    return dev, prof, rate


def _publish(dev: Any, prof: Any, rate: float, outlets: Any, args: argparse.Namespace) -> int:
    """Read, process and push until --seconds, Ctrl-C, the end of a replay or a lost device. Exit status."""
    import sys
    import time

    import numpy as np

    from .._signals import stop_requests
    from ..acquire import DeviceDisconnected, frame_times
    from ..process import Processor

    status = 0
    t_prev: float | None = None
    t0 = time.monotonic()
    with stop_requests() as stop, Processor(tuple(prof.shape), circuit=prof.circuit(), geometry=prof.geometry,
                                            g_rest=args.g_rest, threads=1) as chain:
        _markers_from_terminal(outlets, stop)
        outlets.push_marker("start")
        while (args.seconds is None or time.monotonic() - t0 < args.seconds) and not stop.is_set():
            try:
                batch = dev.read(timeout_s=0.25)
            except DeviceDisconnected as exc:
                print(f"psmat lsl: {exc}", file=sys.stderr)
                status = 1
                break
            if len(batch):
                times = frame_times(batch.host_time_s, batch.device_time_us)
                prev = np.concatenate([[np.nan if t_prev is None else t_prev], times[:-1]])
                periods = times - prev
                periods = np.where(np.isfinite(periods) & (periods > 0), periods, 1.0 / rate)
                t_prev = float(times[-1])
                out = chain.push(batch.frames, periods, valid=batch.valid)
                outlets.push(out, batch.host_time_s, batch.device_time_us)
            elif getattr(dev, "finished", False):
                break
        outlets.push_marker("stop")
    return status


def _markers_from_terminal(outlets: Any, stop: Any) -> None:
    """With a terminal on stdin: each line typed is pushed as a marker (a daemon thread)."""
    import sys
    import threading

    if not sys.stdin or not sys.stdin.isatty():
        return
    print("type a marker label and Enter to push it; Ctrl-C stops", flush=True)

    def read() -> None:
        for line in sys.stdin:
            if stop.is_set():
                return
            label = line.strip()
            if label:
                outlets.push_marker(label)

    threading.Thread(target=read, name="psmat-lsl-markers", daemon=True).start()

"""``psmat simulate``: serve the digital twin on a pseudo-terminal (docs/spec.md §5).

The first line of output is the port's path (for a script to read); the twin serves until
Ctrl-C / SIGTERM. Open that path with ``psmat view``, ``psmat record`` or pyserial.
"""

from __future__ import annotations

import argparse

from . import _args

NAME = "simulate"
HELP = "serve the simulated mat (or IMU / material DAQ) on a pseudo-terminal; prints the port first"


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--rate", type=_args.rate_hz, default=None, help="frames per second (PSM default 100, max 1000)")
    p.add_argument("--protocol", choices=("v1", "v2"), default="v2", help="frame format (docs/protocol.md)")
    p.add_argument("--device", choices=("psm", "imu", "daq"), default="psm", help="which device to simulate")
    p.add_argument("--scene", default="sway", help="PSM scene: sway (a BDS force-platform trajectory), quiet, "
                   "single-leg, sitting")
    p.add_argument("--bds-trial", type=int, default=1, help="BDS trial driving the sway scene")
    p.add_argument("--shape", type=_args.shape, default=(16, 16), help="PSM rows x cols, e.g. 16x16")
    p.add_argument("--faults", default="", help="fault injection, e.g. bit_flip=1e-5,drop_byte=1e-6,"
                   "stall_every_s=5,stall_s=0.2,disconnect_after_s=30")
    p.add_argument("--duration", type=_args.seconds, default=None, help="stop after this many seconds (default: never)")
    p.add_argument("--seed", type=int, default=0)


def run(args: argparse.Namespace) -> int:
    import signal
    import sys
    import threading
    import time

    from ..twin import Faults, PsmSource, SerialTwin

    try:
        rows, cols = args.shape
        faults = Faults.parse(args.faults)
        source = None
        if args.device == "psm":
            source = PsmSource.named(args.scene, args.rate or 100.0, (rows, cols), bds_trial=args.bds_trial,
                                     seed=args.seed)
        twin = SerialTwin(args.device, args.rate, args.protocol, source=source, shape=(rows, cols),
                          faults=faults, seed=args.seed)
    except (ValueError, FileNotFoundError) as exc:  # FileNotFoundError: a BDS trial that is not there
        print(f"psmat simulate: {exc}", file=sys.stderr)
        return 1
    print(twin.port, flush=True)
    print(f"serving a simulated {args.device} ({args.protocol}, {twin.rate_hz:g} Hz) on {twin.port}; Ctrl-C stops",
          file=sys.stderr, flush=True)
    done = threading.Event()
    signal.signal(signal.SIGTERM, lambda *_: done.set())
    twin.start()
    t0 = time.monotonic()
    try:
        while not done.wait(0.2):
            if args.duration is not None and time.monotonic() - t0 >= args.duration:
                break
            if twin.disconnected:
                print("psmat simulate: disconnected (fault injection)", file=sys.stderr)
                break
    except KeyboardInterrupt:
        pass
    finally:
        twin.stop()
    s = twin.stats
    print(f"sent {s.frames_sent} frames, {s.frames_unsent} not taken by the host, {s.late_ticks} late ticks",
          file=sys.stderr)
    return 0

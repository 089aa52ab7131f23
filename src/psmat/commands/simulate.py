"""``psmat simulate``: serve the digital twin on a pseudo-terminal or TCP (docs/spec.md §5).

The first line of output is the port (for a script to read): the pty's path, or with
``--tcp PORT`` (and where the system has no pty, as on Windows) ``socket://127.0.0.1:PORT``;
the twin serves until Ctrl-C / SIGTERM. Open it with ``psmat view``, ``psmat record`` or
pyserial's ``serial_for_url``.
"""

from __future__ import annotations

import argparse

from . import _args

NAME = "simulate"
HELP = "serve the simulated mat (or IMU / material DAQ) on a pseudo-terminal or TCP; prints the port first"


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--rate", type=_args.rate_hz, default=None,
                   help="frame rate, at most 1000 (frames/s; default: the device's own, 100 for the mat)")
    p.add_argument("--protocol", choices=("v1", "v2", "csv"), default="v2",
                   help="frame format (docs/protocol.md); csv: a do-it-yourself mat's text lines, one frame per line, "
                        "10-bit counts of an Arduino at 5 V (the mat only)")
    p.add_argument("--device", choices=("psm", "imu", "daq"), default="psm",
                   help="which device to simulate: psm (the pressure-sensitive mat), imu (the spine IMUs, "
                        "inertial measurement units) or daq (the material data-acquisition box)")
    p.add_argument("--scene", default="sway",
                   help="the mat's scene: sway (a force-platform trajectory of the BDS data set), quiet, "
                        "single-leg, sitting")
    p.add_argument("--bds-trial", type=int, default=1,
                   help="trial of the BDS data set (force-platform recordings of human sway shipped with psmat) "
                        "driving the sway scene")
    p.add_argument("--shape", type=_args.shape, default=(16, 16), help="the mat's rows x columns, e.g. 16x16")
    p.add_argument("--faults", default="", help="fault injection (default: none), e.g. bit_flip=1e-5,drop_byte=1e-6,"
                   "stall_every_s=5,stall_s=0.2,disconnect_after_s=30")
    p.add_argument("--duration", type=_args.seconds, default=None, help="stop after this long (s; default: never)")
    p.add_argument("--seed", type=int, default=0, help="seed of the twin's random draws (noise, faults)")
    p.add_argument("--tcp", type=_args.tcp_port, default=None, metavar="PORT",
                   help="serve on this TCP port of 127.0.0.1 instead, 0 for a free one; the first line printed is "
                        "then socket://127.0.0.1:PORT (default: a pseudo-terminal, or a free TCP port where the "
                        "system has none, as on Windows)")


def run(args: argparse.Namespace) -> int:
    import signal
    import sys
    import threading
    import time

    from ..twin import Faults, PsmSource, SerialTwin, diy_circuit

    try:
        rows, cols = args.shape
        faults = Faults.parse(args.faults)
        source = None
        if args.device == "psm":
            physics = {"circuit": diy_circuit()} if args.protocol == "csv" else {}
            source = PsmSource.named(args.scene, args.rate or 100.0, (rows, cols), bds_trial=args.bds_trial,
                                     seed=args.seed, **physics)
        twin = SerialTwin(args.device, args.rate, args.protocol, source=source, shape=(rows, cols),
                          faults=faults, seed=args.seed, tcp_port=args.tcp)
    except (ValueError, FileNotFoundError) as exc:  # FileNotFoundError: a BDS trial that is not there
        print(f"psmat simulate: {exc}", file=sys.stderr)
        return 1
    except OSError as exc:  # the TCP port is taken
        print(f"psmat simulate: cannot listen on 127.0.0.1:{args.tcp}: {exc.strerror or exc}", file=sys.stderr)
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

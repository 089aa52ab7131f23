"""``psmat simulate``: serve the digital twin on a pseudo-terminal or TCP (docs/spec.md §5).

The first line of output is the port (for a script to read): the pty's path, or with
``--tcp PORT`` (and where the system has no pty, as on Windows) ``socket://127.0.0.1:PORT``;
the twin serves until Ctrl-C / SIGTERM. Open it with ``psmat view``, ``psmat record`` or
pyserial's ``serial_for_url``.

With ``--firmware IMAGE.elf`` the twin serves the STM32 PSM firmware image itself, executed in the
emulator (:class:`psmat.twin.EmulatedTwin`), instead of the firmware core compiled for the host:
the image's USART1 bytes on the same link, the scene's counts on its multiplexers.
"""

from __future__ import annotations

import argparse

from . import _args, _profile_args

NAME = "simulate"
HELP = "serve the simulated mat (or IMU / material DAQ) on a pseudo-terminal or TCP; prints the port first"


def add_arguments(p: argparse.ArgumentParser) -> None:
    _profile_args.add_profile_argument(p)
    p.add_argument("--rate", type=_args.rate_hz, default=None,
                   help="frame rate, at most 1000 (frames/s; default: the profile's rate_hz, rounded to a whole "
                        "number for a firmware's timer: 100 for the thesis' mat)")
    p.add_argument("--protocol", choices=("v1", "v2", "csv"), default=None,
                   help="frame format (docs/protocol.md); csv: a do-it-yourself mat's text lines, one frame per line "
                        "(the mat only; without --profile the arduino16 mat's 10-bit counts at 5 V); default: the "
                        "profile's")
    p.add_argument("--device", choices=("psm", "imu", "daq"), default=None,
                   help="which device to simulate: psm (the pressure-sensitive mat), imu (the spine IMUs, "
                        "inertial measurement units) or daq (the material data-acquisition box); default: the "
                        "--profile's kind, else psm (one that disagrees with --profile is refused)")
    p.add_argument("--scene", default="sway",
                   help="the mat's scene: sway (a force-platform trajectory of the BDS data set), quiet, "
                        "single-leg, sitting")
    p.add_argument("--bds-trial", type=int, default=1,
                   help="trial of the BDS data set (force-platform recordings of human sway shipped with psmat) "
                        "driving the sway scene")
    p.add_argument("--shape", type=_args.shape, default=None,
                   help="the mat's rows x columns, e.g. 16x16 (default: the profile's, 16x16 for psm16)")
    p.add_argument("--faults", default="", help="fault injection (default: none), e.g. bit_flip=1e-5,drop_byte=1e-6,"
                   "stall_every_s=5,stall_s=0.2,disconnect_after_s=30")
    p.add_argument("--duration", type=_args.seconds, default=None, help="stop after this long (s; default: never)")
    p.add_argument("--seed", type=int, default=0, help="seed of the twin's random draws (noise, faults)")
    p.add_argument("--tcp", type=_args.tcp_port, default=None, metavar="PORT",
                   help="serve on this TCP port of 127.0.0.1 instead, 0 for a free one; the first line printed is "
                        "then socket://127.0.0.1:PORT (default: a pseudo-terminal, or a free TCP port where the "
                        "system has none, as on Windows)")
    p.add_argument("--firmware", metavar="IMAGE.elf", default=None,
                   help="serve this STM32 PSM firmware image executed in the emulator instead of the firmware core "
                        "compiled for the host (build it with make -C firmware stm32 LINK=uart: "
                        "build/stm32-uart/psm.elf; needs psmat[firmware]); it speaks v2 at its own 100 Hz from "
                        "power-up (a host changes the rate with SET_RATE), scans the scene on a mat of at most "
                        "16x16, and usually runs slower than real time: the rate it reaches, frames per second "
                        "of wall time, goes to stderr once a second (default: the host-compiled core)")


def run(args: argparse.Namespace) -> int:
    import signal
    import sys
    import time

    from ..twin import Faults, PsmSource, SerialTwin

    try:
        kind = _profile_args.device_kind(args)
        prof = _profile_args.resolve(args, kind)
        rate, note = _profile_args.twin_rate_hz(args.rate, prof)
        faults = Faults.parse(args.faults)
        if args.firmware is not None:
            twin = _emulated_twin(args, kind, prof, faults)
            note = None
        else:
            source = None
            if kind == "psm":  # the profile's mat: shape, pitch, circuit and wire order
                source = PsmSource.named(args.scene, rate, profile=prof, bds_trial=args.bds_trial, seed=args.seed)
            twin = SerialTwin(kind, rate, "v2" if kind == "daq" else prof.protocol, source=source,
                              shape=tuple(prof.shape) if kind == "psm" else (16, 16), faults=faults,
                              seed=args.seed, tcp_port=args.tcp)
    except (ValueError, FileNotFoundError) as exc:  # FileNotFoundError: a BDS trial that is not there
        print(f"psmat simulate: {exc}", file=sys.stderr)
        return 1
    except (ImportError, RuntimeError) as exc:  # no unicorn / pyelftools; EmulationError: not an ARM image
        print(f"psmat simulate: --firmware {args.firmware}: {exc}", file=sys.stderr)
        return 1
    except OSError as exc:  # the TCP port is taken
        print(f"psmat simulate: cannot listen on 127.0.0.1:{args.tcp}: {exc.strerror or exc}", file=sys.stderr)
        return 1
    if note:
        print(f"psmat simulate: {note}", file=sys.stderr)
    print(twin.port, flush=True)
    what = f"the firmware image {args.firmware} in the emulator" if args.firmware else f"a simulated {kind}"
    protocol = "v2" if args.firmware else prof.protocol
    print(f"serving {what} (profile {prof.name}, {protocol}, {twin.rate_hz:g} Hz) on {twin.port}; "
          "Ctrl-C stops", file=sys.stderr, flush=True)
    # SIGTERM appends to a plain list: a handler runs in the main thread between two of its Python
    # steps, so one that set a threading.Event while the main thread was inside that event's wait()
    # (which holds the event's lock across a call) would wait for its own lock for ever
    stopping: list[int] = []
    signal.signal(signal.SIGTERM, lambda signum, _frame: stopping.append(signum))
    twin.start()
    t0 = time.monotonic()
    try:
        while not stopping:
            time.sleep(0.2)
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


def _emulated_twin(args: argparse.Namespace, kind: str, prof, faults):  # noqa: ANN001, ANN202
    """The PSM image of ``--firmware`` in the emulator, scanning the profile's mat (ValueError: a
    device, protocol or rate the image does not have)."""
    import sys

    from ..twin import EmulatedTwin, PsmSource
    from ..twin.emulated import IMAGE_RATE_HZ

    if kind != "psm":
        raise ValueError(f"--firmware serves the PSM image, not {'an' if kind[0] in 'aeiou' else 'a'} {kind}")
    if prof.protocol != "v2":
        raise ValueError(f"--firmware: the PSM image speaks v2 from power-up, not {prof.protocol} "
                         "(a host switches it with SET_PROTOCOL)")
    if args.rate is not None and args.rate != IMAGE_RATE_HZ:
        raise ValueError(f"--firmware: the PSM image runs at {IMAGE_RATE_HZ:g} Hz from power-up, not --rate "
                         f"{args.rate:g} (a host changes it with SET_RATE)")
    source = PsmSource.named(args.scene, IMAGE_RATE_HZ, profile=prof, bds_trial=args.bds_trial, seed=args.seed)
    return EmulatedTwin(args.firmware, source=source, faults=faults, tcp_port=args.tcp, progress=sys.stderr)

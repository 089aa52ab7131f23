"""``psmat record``: record a session file from a device (or the digital twin) (SPEC §6)."""

from __future__ import annotations

import argparse

from . import _args

NAME = "record"
HELP = "record a session (HDF5) from a mat, IMU or material DAQ; Ctrl-C stops cleanly"


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("port", nargs="?", help="serial port (omit with --simulate)")
    p.add_argument("-o", "--out", required=True, help="session file to write (.h5)")
    p.add_argument("--simulate", action="store_true", help="record the digital twin")
    p.add_argument("--device", choices=("psm", "imu", "daq"), default="psm")
    p.add_argument("--protocol", choices=("v1", "v2"), default="v2")
    p.add_argument("--shape", type=_args.shape, default=(16, 16), help="PSM rows x cols, e.g. 16x16")
    p.add_argument("--rate", type=_args.rate_hz, default=None, help="ask the device for this frame rate (Hz)")
    p.add_argument("--seconds", type=_args.seconds, default=None, help="stop after this long (default: until Ctrl-C)")
    p.add_argument("--calibration", default=None, help="calibration JSON of the box (psmat calibrate)")
    p.add_argument("--subject", default="", help="subject id (metadata)")
    p.add_argument("--trial", default="", help="trial name (metadata)")
    p.add_argument("--note", default="", help="free text (metadata)")
    p.add_argument("--overwrite", action="store_true", help="replace an existing session file")


def run(args: argparse.Namespace) -> int:
    import os
    import sys
    import time

    from tqdm.auto import tqdm

    from ..acquire import DeviceDisconnected, open_device
    from ..io import SessionWriter, journal_path

    if bool(args.port) == bool(args.simulate):
        print("psmat record: give a PORT or --simulate", file=sys.stderr)
        return 1
    taken = [p for p in (args.out, journal_path(args.out)) if os.path.lexists(p)]
    if taken and not args.overwrite:
        print(f"psmat record: {taken[0]} exists; add --overwrite to replace it", file=sys.stderr)
        return 1
    shape = args.shape if args.device == "psm" else None
    calibration = None
    if args.calibration:
        from ..calibration import Calibration

        calibration = Calibration.load(args.calibration).to_dict()
    twin = None
    port = args.port
    if args.simulate:
        from ..twin import SerialTwin

        twin = SerialTwin(args.device, args.rate, args.protocol, shape=shape or (16, 16)).start()
        port = twin.port
    status = 0
    try:
        with open_device(port, args.device, args.protocol, shape) as dev:
            if args.rate and not args.simulate and args.device != "daq":
                dev.set_rate(int(args.rate))
            desc = dict(dev.description or {})
            meta = {"subject": args.subject, "trial": args.trial, "note": args.note, "port": port,
                    "simulated": bool(args.simulate)}
            with SessionWriter(args.out, dev.shape, device=desc, calibration=calibration, metadata=meta,
                               kind=args.device, overwrite=args.overwrite) as writer:
                dev.record_to(writer)
                dev.start()
                t0 = time.monotonic()
                with tqdm(unit=" frames", desc=f"recording {args.out}") as bar:
                    try:
                        while args.seconds is None or time.monotonic() - t0 < args.seconds:
                            bar.update(len(dev.read(timeout=0.25)))
                    except KeyboardInterrupt:
                        pass
                    except DeviceDisconnected as exc:
                        print(f"\npsmat record: {exc}; the frames received so far are saved", file=sys.stderr)
                        status = 1
                dev.stop()
                dev.stop_recording()
                st = dev.stats
        print(f"{args.out}: {writer.n_frames} frames recorded, {st.invalid} invalid, {st.dropped_wire} lost on the wire, "
              f"{st.dropped_buffer} dropped by the host buffer")
    finally:
        if twin is not None:
            twin.stop()
    return status

"""``psmat info``: what a session file holds (docs/spec.md §6)."""

from __future__ import annotations

import argparse

NAME = "info"
HELP = "summarise a session file: duration, frames, rate, losses, device, calibration, products"


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("session", help="session file (.h5)")
    p.add_argument("--csv", default=None, help="also export the frames to this CSV file (each other device's to "
                   "STEM.NAME.csv beside it)")
    p.add_argument("--overwrite", action="store_true", help="replace existing CSV files")


def run(args: argparse.Namespace) -> int:
    import sys
    from dataclasses import replace
    from pathlib import Path

    from .._atomic import OutputRefused, check_outputs, replacing
    from ..io import SessionFormatError, export_csv, info, load_session, stream_csv_path
    from ..io.session import session_files, unfinished_line
    from ..process import adc_line

    try:
        s = load_session(args.session)  # docs/spec.md §6: every loader error is one SessionFormatError
        csvs = []  # (label, CSV file, the device it gets), checked before anything is printed or written
        if args.csv:
            csvs = [("CSV", Path(args.csv), replace(s, streams={})),
                    *((f"CSV [{name}]", stream_csv_path(args.csv, name), st) for name, st in s.streams.items())]
            check_outputs([out for _, out, _ in csvs], inputs=session_files(args.session), overwrite=args.overwrite)
        print(info(s))
        for label, out, dev in csvs:
            with replacing(out) as tmp:  # whole or not at all
                export_csv(dev, tmp)
            print(f"{label}: {out}")
    except (OutputRefused, SessionFormatError, OSError) as exc:  # FileNotFoundError is an OSError
        print(f"psmat info: {exc}", file=sys.stderr)
        return 1
    line = unfinished_line(args.session, s)
    if line:
        print(f"psmat info: {line}", file=sys.stderr)
    if narrow := adc_line(s):
        print(f"psmat info: {narrow}", file=sys.stderr)
    return 0

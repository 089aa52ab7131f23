"""``psmat info``: what a session file holds (docs/spec.md §6)."""

from __future__ import annotations

import argparse

NAME = "info"
HELP = "summarise a session file: duration, frames, rate, losses, device, calibration, products"


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("session", help="session file (.h5)")
    p.add_argument("--csv", default=None, help="also export the frames to this CSV file")


def run(args: argparse.Namespace) -> int:
    import sys

    from ..io import SessionFormatError, export_csv, info, load_session, stream_csv_path

    try:
        s = load_session(args.session)  # docs/spec.md §6: every loader error is one SessionFormatError
        print(info(s))
        if args.csv:
            print(f"CSV: {export_csv(s, args.csv)}")
            for name in s.streams:
                print(f"CSV [{name}]: {stream_csv_path(args.csv, name)}")
    except (SessionFormatError, OSError) as exc:  # FileNotFoundError is an OSError
        print(f"psmat info: {exc}", file=sys.stderr)
        return 1
    return 0

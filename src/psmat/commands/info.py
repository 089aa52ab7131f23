"""``psmat info``: what a session file holds (SPEC §6)."""

from __future__ import annotations

import argparse

NAME = "info"
HELP = "summarise a session file: duration, frames, rate, losses, device, calibration, products"


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("session", help="session file (.h5)")
    p.add_argument("--csv", default=None, help="also export the frames to this CSV file")


def run(args: argparse.Namespace) -> int:
    import sys

    from ..io import SessionFormatError, export_csv, info, load_session

    try:
        s = load_session(args.session)
    except (FileNotFoundError, SessionFormatError, OSError) as exc:
        print(f"psmat info: {exc}", file=sys.stderr)
        return 1
    print(info(s))
    if args.csv:
        print(f"CSV: {export_csv(s, args.csv)}")
    return 0

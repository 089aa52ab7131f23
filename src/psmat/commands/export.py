"""``psmat export``: a session's counts, pressure, CoP or events as CSV, Parquet or MATLAB (docs/spec.md §6).

``psmat export S.h5 --what pressure --format csv`` writes ``S.pressure.csv`` beside the
session (``-o OUT`` to choose the file): one row per frame, ``time_s`` (host time, s),
``valid`` (1/0) and one column per cell, row-major, each name ending with its unit
(``r00c00_count`` ..., ``r00c00_kpa`` ..., ``ml_cm``, ``ap_cm``; events: ``time_s``, ``label``).
Pressure and CoP are the products ``psmat process`` stored in the file. Parquet files carry
the units in their schema too (needs pyarrow: ``pip install psmat[parquet]``); MATLAB files hold
one variable per column stem (the cells as one T x R x C array) and a struct ``units``
(:func:`psmat.io.export`). The file is written whole or not at all; an existing one is
replaced only with ``--overwrite``.
"""

from __future__ import annotations

import argparse

NAME = "export"
HELP = "write a session's counts, pressure, CoP or events as CSV, Parquet or MATLAB (.mat)"
WHATS = ("counts", "pressure", "cop", "events")
FORMATS = ("csv", "parquet", "mat")


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("session", metavar="S.h5", help="the session file (.h5)")
    p.add_argument("--what", required=True, choices=WHATS,
                   help="the table: raw counts, stored pressure (kPa), stored CoP (cm) or the events")
    p.add_argument("--format", required=True, choices=FORMATS, dest="fmt", help="the file format")
    p.add_argument("-o", "--out", metavar="OUT", default=None,
                   help="the file to write (default: S.WHAT.EXT beside the session)")
    p.add_argument("--overwrite", action="store_true", help="replace an existing OUT")


def default_out(session: str, what: str, fmt: str) -> str:
    """``S.WHAT.EXT`` beside the session ``S.h5`` (e.g. ``s01.pressure.csv``)."""
    from pathlib import Path

    p = Path(session)
    return str(p.with_name(f"{p.stem}.{what}.{fmt}"))


def run(args: argparse.Namespace) -> int:
    import sys

    from .._atomic import OutputRefused, check_outputs
    from ..io import SessionFormatError, export, load_session
    from ..io.session import session_files, unfinished_line

    def fail(msg: object) -> int:
        print(f"psmat export: {' '.join(str(msg).split())}", file=sys.stderr)
        return 1

    out = args.out or default_out(args.session, args.what, args.fmt)
    try:
        check_outputs([out], inputs=session_files(args.session), overwrite=args.overwrite)
        s = load_session(args.session)
        line = unfinished_line(args.session, s)
        if line:
            return fail(line)
        export(s, args.what, args.fmt, out)
    except (OutputRefused, SessionFormatError, ValueError, ImportError, OSError) as exc:
        return fail(exc)
    rows = len(s.events) if args.what == "events" else s.n_frames
    print(f"psmat export: {args.what} of {args.session} ({rows} rows) -> {out}")
    return 0

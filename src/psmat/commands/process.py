"""``psmat process``: a recorded mat session through the chain, the products stored in it (docs/spec.md §6).

``psmat process S.h5`` turns the session's counts into conductances (G), removes the
crosstalk between cells (g, IECM), compensates the sensor (pressure, kPa) and computes the
centre of pressure (CoP, cm), and stores the four in the session file with the parameters that
made them (:func:`psmat.process.process_session`; the file is replaced whole, never modified in
place). It prints the frames processed and usable, the circuit used and the pressure
calibration that made the kPa. A session that already holds products is not processed again
without ``--overwrite``. Then ``psmat export S.h5 --what pressure --format csv`` writes them out.
"""

from __future__ import annotations

import argparse

from ._args import input_file

NAME = "process"
HELP = "run a recorded mat session through the chain: store G, g, pressure (kPa) and CoP (cm) in it"
#: the products :func:`psmat.process.process_session` stores
PRODUCTS = ("G", "g", "pressure", "cop")
#: what a session processed without a pressure calibration says about its kPa
UNCALIBRATED = "uncalibrated: kPa from the nominal sensor model (thesis Table 2.11), not absolute"


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("session", metavar="S.h5", help="the session file (.h5)")
    p.add_argument("--calibration", metavar="FILE", type=input_file, default=None,
                   help="a psmat calibrate file (JSON) of the box the session was recorded with")
    p.add_argument("--overwrite", action="store_true", help="replace products the session already holds")


def run(args: argparse.Namespace) -> int:
    import sys

    from ..io import SessionFormatError, load_session
    from ..io.session import unfinished_line
    from ..process import process_session

    def fail(msg: str) -> int:
        print(f"psmat process: {' '.join(str(msg).split())}", file=sys.stderr)
        return 1

    path = args.session
    try:
        s = load_session(path)
    except (SessionFormatError, OSError) as exc:  # FileNotFoundError is an OSError
        return fail(exc)
    line = unfinished_line(path, s)
    if line:
        return fail(line)
    if s.kind != "psm":
        return fail(f"{path} is a {s.kind} session; psmat process handles mat (psm) sessions")
    held = [name for name in PRODUCTS if name in s.products]
    if held and not args.overwrite:
        return fail(f"{path} already holds {', '.join(held)}; add --overwrite to replace them")
    try:
        out = process_session(path, calibration=args.calibration, progress=None)
    except (ValueError, TypeError, SessionFormatError, OSError) as exc:  # a bad calibration file is a ValueError
        return fail(exc)
    n = int(out.usable.shape[0])
    usable = int(out.usable.sum())
    pct = 100.0 * usable / n if n else 0.0
    print(f"psmat process: {path}: {n} frames processed, {usable} usable ({pct:.1f} %)")
    print(f"  circuit       {out.params.get('circuit_from', 'unknown')}")
    print(f"  pressure      {out.params.get('pressure_calibration', UNCALIBRATED)}")
    print(f"  stored        G (S), g (S), pressure (kPa), cop (cm) in {path}")
    return 0

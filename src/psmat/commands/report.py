"""``psmat report``: one self-contained HTML report of recorded sessions (and a PDF with ``--pdf``).

``psmat report S.h5`` writes ``S.report.html`` beside the session and prints its path: what was
recorded, the mean and peak pressure images (kPa), the centre of pressure (cm), the sway metrics
and the 72 posturography descriptors with their units after one preprocessing (SWARII to 25 Hz,
10 Hz low-pass: ``--preset none`` for the raw trace), the ISPGR flag (at least 25 s at 50 Hz), the
loads of the feet (or of the seat for a seated trial), the conditions the session's markers cut
it into with the Romberg quotients when an eyes-open and an eyes-closed one exist, and with
``--platform`` the force platform aligned with the mat (lag, Eu, the same metrics, an overlay).
Several sessions make one page, in the order given; ``--platform`` and ``--events`` are then
given once per session, in the same order. ``--events FILE`` replaces the session's markers by a
CSV ``time_s,label`` on the session's host clock (``psmat export S.h5 --what events`` writes
one) or read off the wall (``10:32:15``, ``2024-03-01 10:32:15``: on the recording computer's clock,
whose offset from UTC the session stores), or in seconds from the first frame with
``--events-from-start``. The page holds its figures
itself (nothing is fetched from elsewhere); ``--pdf`` prints it with headless Chromium, else
WeasyPrint, and says so when neither is installed. A bad input is one line and exit status 1.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from . import _args

NAME = "report"
HELP = "write one self-contained HTML report (figures, metrics, descriptors, regions, platform) of sessions"


def add_arguments(p: argparse.ArgumentParser) -> None:
    from ..balance import PLATFORM_AXES

    p.add_argument("sessions", metavar="S.h5", nargs="+", help="the session files (.h5), a mat's or imported")
    p.add_argument("--platform", metavar="CSV", action="append", default=None,
                   help="a force-platform CSV of the session (once per session, in their order)")
    p.add_argument("--events", metavar="CSV", action="append", default=None,
                   help="markers (time_s,label) replacing the session's own (once per session, in their order)")
    p.add_argument("--events-from-start", action="store_true",
                   help="--events times are seconds from the session's first frame, not its host clock")
    p.add_argument("-o", "--output", metavar="OUT.html", default=None,
                   help="the report (default: beside the first session, STEM.report.html)")
    p.add_argument("--title", default=None, help="the page's title (default: psmat report and the first session)")
    p.add_argument("--subject", default=None, help="a line under the title: who was measured")
    p.add_argument("--preset", choices=("quijoux2021", "none"), default="quijoux2021",
                   help="preprocessing of every CoP trace before its metrics")
    p.add_argument("--threshold-kpa", type=_args.nonnegative, default=5.0,
                   help="a cell is loaded above this pressure (kPa, a finite number >= 0)")
    p.add_argument("--calibration", metavar="FILE", default=None,
                   help="a psmat calibrate file (JSON) of the box the mat sessions were recorded with")
    p.add_argument("--platform-axes", choices=PLATFORM_AXES, default="x,y", metavar="AXES",
                   help="how the platform's axes lie on the mat's: M-L,A-P in terms of its file's x and y, each "
                        "possibly reversed (-) or swapped (x,y: as the file is; x,-y: its A-P axis points the "
                        "other way; y,x: its x is A-P); write --platform-axes=-x,y for a leading minus")
    p.add_argument("--pdf", action="store_true", help="also print the report to OUT.pdf")
    p.add_argument("--overwrite", action="store_true", help="replace an existing report")


def _default_output(session: str) -> Path:
    p = Path(session)
    stem = p.name[:-3] if p.name.endswith(".h5") else p.stem
    return p.with_name(f"{stem}.report.html")


def run(args: argparse.Namespace) -> int:
    import sys

    from .._atomic import OutputRefused, check_outputs
    from ..balance import load_events_csv
    from ..io import SessionFormatError
    from ..io.session import session_files
    from ..report import ReportItem, write_report
    from ..study import session_events

    def fail(msg: object) -> int:
        print(f"psmat report: {' '.join(str(msg).split())}", file=sys.stderr)
        return 1

    n = len(args.sessions)
    for name, given in (("--platform", args.platform), ("--events", args.events)):
        if given is not None and len(given) != n:
            return fail(f"{name} given {len(given)} time(s) for {n} session(s): give it once per session")
    inputs = [*args.sessions, *(args.platform or []), *(args.events or []), args.calibration]
    for f in (x for x in inputs if x is not None):
        if not Path(f).is_file():
            return fail(f"{f}: no such file")
    out = Path(args.output) if args.output else _default_output(args.sessions[0])
    outs = [out] + ([out.with_suffix(".pdf")] if args.pdf else [])
    try:
        check_outputs(outs, inputs=[*inputs, *(f for s in args.sessions for f in session_files(s))],
                      overwrite=args.overwrite)
    except OutputRefused as exc:
        return fail(exc)
    items = []
    try:
        for k, session in enumerate(args.sessions):
            # on the session's host clock (wall-clock times by its computer's offset), or from its first frame
            events = None if not args.events else load_events_csv(args.events[k]) if args.events_from_start \
                else session_events(Path(args.events[k]), Path(session))
            items.append(ReportItem(session=session, platform=args.platform[k] if args.platform else None,
                                    events=events, events_from_start=args.events_from_start))
        params = {"preset": None if args.preset == "none" else args.preset, "threshold_kpa": args.threshold_kpa,
                  "calibration": args.calibration, "platform_axes": args.platform_axes}
        result = write_report(out, items, title=args.title, subject=args.subject, params=params, pdf=args.pdf)
    except (ValueError, TypeError, KeyError, SessionFormatError, OSError) as exc:
        return fail(exc)
    print(result.html)
    if args.pdf:
        if result.pdf is None:
            print(f"psmat report: {result.pdf_note}", file=sys.stderr)
        else:
            print(result.pdf)
    return 0

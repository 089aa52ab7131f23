"""``psmat posture``: a posture study folder (SPEC §6 layout, §8).

``psmat posture simulate DIR --subjects 12 --days 3 --seed K`` writes a simulated posture study:
the seated twin (:mod:`psmat.twin.seated`) following the thesis' protocol once a day per subject,
one posture trajectory driving both the cushion's mat and the spine IMUs, recorded together into
one session per day (:mod:`psmat.posture.simulate`), the truth apart in ``DIR/truth/``.
"""

from __future__ import annotations

import argparse
import sys

from . import _args

NAME = "posture"
HELP = "simulate a posture study folder (mat and spine IMUs, thesis chapter 4)"


def add_arguments(p: argparse.ArgumentParser) -> None:
    sub = p.add_subparsers(dest="action", required=True, metavar="{simulate}")
    s = sub.add_parser("simulate", help="write a simulated posture study into DIR",
                       description="Write a simulated posture study (SPEC §8): each subject sits on the mat "
                                   "once a day following the thesis' protocol (30 s straight, forward, back, "
                                   "bounces, slow rocking), the mat and the five spine IMUs recorded together; "
                                   "what the simulator knows goes to DIR/truth/.")
    s.add_argument("dir", metavar="DIR", help="the study folder to create")
    s.add_argument("--subjects", type=_args.positive_int, default=12, help="number of subjects (default 12)")
    s.add_argument("--days", type=_args.positive_int, default=3, help="sessions per subject, one a day (default 3)")
    s.add_argument("--seed", type=int, required=True, help="seed of every random draw")
    s.add_argument("--seconds", type=_args.seconds, default=None,
                   help="length of each session: the protocol scaled in time (default: the protocol's own, "
                        "about 175 s)")
    s.add_argument("--rate", type=_args.rate_hz, default=100.0, help="the mat's frame rate (Hz, default 100)")
    s.add_argument("--quiet", action="store_true", help="no progress bar")


def run(args: argparse.Namespace) -> int:
    return _simulate(args)


def _simulate(args: argparse.Namespace) -> int:
    from ..posture.simulate import simulate_posture_study

    try:
        root = simulate_posture_study(args.dir, subjects=args.subjects, days=args.days, seed=args.seed,
                                      rate_hz=args.rate, seconds=args.seconds, progress=not args.quiet)
    except (OSError, ValueError) as exc:
        print(f"psmat posture simulate: {_line(exc)}", file=sys.stderr)
        return 1
    print(f"simulated posture study in {root}: {args.subjects} subject(s) x {args.days} day(s)")
    return 0


def _line(exc: BaseException) -> str:
    """An error as one line."""
    return " ".join(str(exc).split()) or type(exc).__name__

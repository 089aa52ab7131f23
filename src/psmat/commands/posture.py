"""``psmat posture``: a posture study folder (SPEC §6 layout, §8).

``psmat posture simulate DIR --subjects 12 --days 3 --seed K`` writes a simulated posture study:
the seated twin (:mod:`psmat.twin.seated`) following the thesis' protocol once a day per subject,
one posture trajectory driving both the cushion's mat and the spine IMUs, recorded together into
one session per day (:mod:`psmat.posture.simulate`), the truth apart in ``DIR/truth/``.

``psmat posture train DIR --split ksi|ksi-leaky|lso`` builds the inputs of every session
(:mod:`psmat.posture.dataset`: IECM, the mat averaged to the IMU rate; cached in
``DIR/results/posture/inputs/``) and trains the thesis' CNN (§4.3, :mod:`psmat.posture.train`) on
that split, writing ``DIR/results/posture/table44_<split>.csv`` (thesis Table 4.4's shape, the
ridge-on-PCA baseline beside it), figures as Figs. 4.13-4.16 and checkpoints (a killed training
resumes). It needs PyTorch: ``pip install 'psmat[posture]'``.
"""

from __future__ import annotations

import argparse
import sys

from . import _args

NAME = "posture"
HELP = "simulate a posture study folder (mat and spine IMUs, thesis chapter 4) or train the CNN on one"


def add_arguments(p: argparse.ArgumentParser) -> None:
    sub = p.add_subparsers(dest="action", required=True, metavar="{simulate,train}")
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
    t = sub.add_parser("train", help="train the posture CNN on DIR's sessions (Table 4.4, Figs. 4.13-4.16)",
                       description="Build each session's inputs (crosstalk removed, the mat averaged to the IMU "
                                   "rate; cached) and train the thesis' CNN on one split; write "
                                   "DIR/results/posture/table44_<split>.csv, figures and checkpoints.")
    t.add_argument("dir", metavar="DIR", help="the posture study folder (sessions/ with the mat and the IMUs)")
    t.add_argument("--split", choices=("ksi", "ksi-leaky", "lso"), required=True,
                   help="ksi: the same subjects, contiguous 70/10/20 blocks of each session; ksi-leaky: the "
                        "thesis' random 70/10/20 of overlapping windows (leaks); lso: subjects held out")
    t.add_argument("--epochs", type=_args.positive_int, default=30, help="most epochs (default 30)")
    t.add_argument("--patience", type=_args.positive_int, default=5,
                   help="early stopping after this many epochs without a lower validation loss (default 5)")
    t.add_argument("--windows-per-epoch", type=_args.positive_int, default=8192,
                   help="training windows drawn at random each epoch (default 8192)")
    t.add_argument("--seed", type=int, default=0, help="seed of the split and the training (default 0)")
    t.add_argument("--workers", type=_args.positive_int, default=None,
                   help="processes building the inputs (default: every core)")
    t.add_argument("--out", default=None, help="output folder (default DIR/results/posture)")
    t.add_argument("--quiet", action="store_true", help="no progress bars")


def run(args: argparse.Namespace) -> int:
    return _simulate(args) if args.action == "simulate" else _train(args)


def _train(args: argparse.Namespace) -> int:
    from pathlib import Path

    from ..posture.dataset import load_posture_study

    root = Path(args.dir)
    if not (root / "sessions").is_dir():
        print(f"psmat posture train: {root} has no sessions/ folder (a posture study, SPEC §6)", file=sys.stderr)
        return 1
    try:
        from ..posture.train import train_posture
    except ImportError as exc:
        print(f"psmat posture train: {_line(exc)}", file=sys.stderr)
        return 1
    try:
        study = load_posture_study(root, workers=args.workers, progress=not args.quiet)
        for p in study.problems:
            print(f"psmat posture train: left out {p}", file=sys.stderr)
        out = Path(args.out) if args.out else root / "results" / "posture"
        result = train_posture(study.recordings, out, split=args.split, seed=args.seed, epochs=args.epochs,
                               patience=args.patience, windows_per_epoch=args.windows_per_epoch,
                               progress=not args.quiet)
    except (OSError, ValueError) as exc:
        print(f"psmat posture train: {_line(exc)}", file=sys.stderr)
        return 1
    print(f"{len(study.recordings)} sessions, split {args.split}: best epoch {result.best_epoch}; "
          f"{out / f'table44_{args.split}.csv'}")
    for row in [*result.rows, *result.baseline_rows]:
        r2 = ", ".join(f"{k[3:]} {v:.3f}" for k, v in row.items() if k.startswith("R2_"))
        print(f"  {row['model']} {row['subset']}: MSE {row['MSE']:.4g} rad^2; R2 {r2}")
    return 0


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

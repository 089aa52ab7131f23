"""``psmat posture``: a posture study folder (docs/spec.md §6 layout, §8).

``psmat posture simulate DIR --subjects 12 --days 3 --seed K`` writes a simulated posture study:
the seated twin (:mod:`psmat.twin.seated`) following the thesis' protocol once a day per subject,
one posture trajectory driving both the cushion's mat and the spine IMUs, recorded together into
one session per day (:func:`psmat.synth.simulate_posture_study`), the truth apart in ``DIR/truth/``.

``psmat posture train DIR --split ksi|ksi-leaky|lso`` builds the inputs of every session
(:func:`psmat.posture.load_posture_study`: IECM, the mat averaged to the IMU rate; cached in
``DIR/results/posture/inputs/``) and trains the thesis' CNN (§4.3,
:func:`psmat.posture.learn.train_posture`) on that split, writing
``DIR/results/posture/table44_<split>.csv`` (thesis Table 4.4's shape, the ridge-on-PCA baseline
beside it), figures as Figs. 4.13-4.16 and checkpoints (a killed training
resumes). It needs PyTorch: ``pip install 'psmat[posture]'``.

``psmat posture heldout DIR`` evaluates the held-out-subject models (beyond the thesis) on the LSO
test subjects (:func:`psmat.posture.learn.heldout_study`): the thesis' CNN, the CNN on
subject-invariant inputs, both fine-tuned on each test subject's first 30 s, and the ridge-on-PCA baselines (raw,
invariant, calibrated), all on the same windows after each session's calibration phase; it writes
``DIR/results/posture/heldout.csv`` and ``figures/heldout_r2.png`` and reuses the LSO training of
``psmat posture train --split lso`` when its data and settings match.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path
from typing import Any

from . import _args

NAME = "posture"
HELP = ("simulate a posture study folder (mat and spine IMUs, thesis chapter 4), train the CNN on one, or "
        "evaluate models for held-out subjects")


def _learning_rate(text: str) -> float:
    """A learning rate, finite and > 0."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"a learning rate must be a number, got {text!r}") from None
    if not (math.isfinite(value) and value > 0):
        raise argparse.ArgumentTypeError(f"a learning rate must be > 0, got {text!r}")
    return value


def add_arguments(p: argparse.ArgumentParser) -> None:
    sub = p.add_subparsers(dest="action", required=True, metavar="{simulate,train,heldout}")
    s = sub.add_parser("simulate", help="write a simulated posture study into DIR",
                       description="Write a simulated posture study (docs/spec.md §8): each subject sits on the mat "
                                   "once a day following the thesis' protocol (30 s straight, forward, back, "
                                   "bounces, slow rocking), the mat and the five spine IMUs recorded together; "
                                   "what the simulator knows goes to DIR/truth/.")
    s.add_argument("dir", metavar="DIR", help="the study folder to create")
    s.add_argument("--subjects", type=_args.positive_int, default=12, help="number of subjects")
    s.add_argument("--days", type=_args.positive_int, default=3, help="sessions per subject, one a day")
    s.add_argument("--seed", type=int, required=True, help="seed of every random draw")
    s.add_argument("--seconds", type=_args.session_seconds, default=None,
                   help="length of each session, the protocol scaled in time (s; default: the protocol's own, "
                        "about 175 s)")
    s.add_argument("--rate", type=_args.rate_hz, default=100.0, help="the mat's frame rate (Hz)")
    s.add_argument("--quiet", action="store_true", help="no progress bar")
    t = sub.add_parser("train", help="train the posture CNN (convolutional neural network) on DIR's sessions "
                                     "(thesis Table 4.4, Figs. 4.13-4.16)",
                       description="Build each session's inputs (crosstalk removed, the mat averaged to the IMU "
                                   "rate; cached) and train the thesis' CNN on one split; write "
                                   "DIR/results/posture/table44_<split>.csv, figures and checkpoints.")
    t.add_argument("dir", metavar="DIR", help="the posture study folder (sessions/ with the mat and the IMUs)")
    t.add_argument("--split", choices=("ksi", "ksi-leaky", "lso"), required=True,
                   help="how the windows are split into training, validation and test sets (thesis Table 4.3): "
                        "ksi (KSI, Keep Subjects In): the same subjects in every set, contiguous 70/10/20 %% "
                        "blocks of each session; ksi-leaky: KSI as in the thesis, a random 70/10/20 %% of "
                        "overlapping windows (a test window shares frames with training ones); lso (LSO, Leave "
                        "Subjects Out): whole subjects held out of training")
    t.add_argument("--epochs", type=_args.positive_int, default=30, help="most epochs")
    t.add_argument("--patience", type=_args.positive_int, default=5,
                   help="early stopping after this many epochs without a lower validation loss")
    t.add_argument("--windows-per-epoch", type=_args.positive_int, default=8192,
                   help="training windows drawn at random each epoch")
    t.add_argument("--seed", type=int, default=0, help="seed of the split and the training")
    t.add_argument("--workers", type=_args.positive_int, default=None,
                   help="processes building the inputs (default: every core)")
    t.add_argument("--out", default=None, help="output folder (default DIR/results/posture)")
    t.add_argument("--quiet", action="store_true", help="no progress bars")
    h = sub.add_parser("heldout", help="models for held-out subjects (the test subjects of LSO, Leave Subjects "
                                       "Out): invariant inputs, a 30 s calibration, ridge regression on a PCA "
                                       "(principal component analysis), on the same windows",
                       description="Build each session's inputs (cached) and evaluate on the test subjects of the "
                                   "LSO split (Leave Subjects Out: whole subjects held out of training), "
                                   "on the windows after each session's calibration phase: the thesis' CNN, the "
                                   "CNN on subject-invariant inputs, both fine-tuned on each test subject's "
                                   "calibration phase, and ridge on a PCA of the raw and invariant inputs "
                                   "(uncalibrated and offset-calibrated); write DIR/results/posture/heldout.csv "
                                   "and figures/heldout_r2.png.")
    h.add_argument("dir", metavar="DIR", help="the posture study folder (sessions/ with the mat and the IMUs)")
    h.add_argument("--epochs", type=_args.positive_int, default=30,
                   help="most epochs of each CNN (convolutional neural network)")
    h.add_argument("--patience", type=_args.positive_int, default=5,
                   help="early stopping after this many epochs without a lower validation loss")
    h.add_argument("--windows-per-epoch", type=_args.positive_int, default=8192,
                   help="training windows drawn at random each epoch")
    h.add_argument("--calibration-s", type=_args.seconds, default=30.0,
                   help="each session's calibration phase, the protocol's straight back (s)")
    h.add_argument("--finetune-epochs", type=_args.positive_int, default=5,
                   help="epochs of fine-tuning on a test subject's calibration windows")
    h.add_argument("--finetune-lr", type=_learning_rate, default=1e-3, help="the fine-tuning's learning rate")
    h.add_argument("--finetune-layers", choices=("last", "head", "all"), default="head",
                   help="what the fine-tuning trains: last (the output layer), head (the dense layers) or all")
    h.add_argument("--seed", type=int, default=0, help="seed of the trainings and fine-tunings")
    h.add_argument("--workers", type=_args.positive_int, default=None,
                   help="processes building the inputs (default: every core)")
    h.add_argument("--out", default=None, help="output folder (default DIR/results/posture)")
    h.add_argument("--quiet", action="store_true", help="no progress bars")


def run(args: argparse.Namespace) -> int:
    if args.action == "simulate":
        return _simulate(args)
    return _train(args) if args.action == "train" else _heldout(args)


def _study(args: argparse.Namespace, verb: str) -> tuple[Any, Path] | None:
    """The study's recordings and the output folder, or None after a one-line error."""
    from ..posture import load_posture_study

    root = Path(args.dir)
    if not (root / "sessions").is_dir():
        print(f"psmat posture {verb}: {root} has no sessions/ folder (a posture study, docs/spec.md §6)", file=sys.stderr)
        return None
    study = load_posture_study(root, workers=args.workers, progress=not args.quiet)
    if not study.recordings:  # one line, not one per session
        print(f"psmat posture {verb}: {_no_recording(root, study.problems)}", file=sys.stderr)
        return None
    for p in study.problems:
        print(f"psmat posture {verb}: left out {p}", file=sys.stderr)
    for n in study.notes:
        print(f"psmat posture {verb}: {n}", file=sys.stderr)
    return study, Path(args.out) if args.out else root / "results" / "posture"


def _no_recording(root: Path, problems: list[str]) -> str:
    """Why a study gave no recording, as one line."""
    from ..posture import NO_IMU

    line = f"{root}: no session can be used ({len(problems)} left out"
    line += f"; the first, {problems[0]})" if problems else ")"
    if problems and all(NO_IMU in p for p in problems):
        line += ("; posture needs the mat recorded with the spine IMUs: is this a balance study? "
                 "(psmat study run processes those)")
    return " ".join(line.split())


def _print_rows(rows: list[dict[str, Any]]) -> None:
    for row in rows:
        r2 = ", ".join(f"{k[3:]} {v:.3f}" for k, v in row.items() if k.startswith("R2_"))
        print(f"  {row['model']} {row['subset']}: MSE {row['MSE']:.4g} rad^2; R2 {r2}")


def _learning(verb: str) -> Any:
    """:mod:`psmat.posture.learn` (imports PyTorch: seconds), or None after one line without it."""
    try:
        from ..posture import learn
    except ImportError as exc:
        print(f"psmat posture {verb}: {_line(exc)}", file=sys.stderr)
        return None
    return learn


def _torch_missing(verb: str) -> bool:
    """True, after one line, when PyTorch is not installed: found without importing it, so that a
    missing PyTorch is told before the study is read, and a wrong folder before PyTorch is imported."""
    from importlib.util import find_spec

    return find_spec("torch") is None and _learning(verb) is None


def _train(args: argparse.Namespace) -> int:
    if _torch_missing("train"):
        return 1
    try:
        found = _study(args, "train")
        if found is None:
            return 1
        study, out = found
        learn = _learning("train")  # after the folder is checked: PyTorch takes seconds to import
        if learn is None:
            return 1
        result = learn.train_posture(study.recordings, out, split=args.split, seed=args.seed, epochs=args.epochs,
                                     patience=args.patience, windows_per_epoch=args.windows_per_epoch,
                                     progress=not args.quiet)
    except (OSError, ValueError) as exc:
        print(f"psmat posture train: {_line(exc)}", file=sys.stderr)
        return 1
    from ..posture import SPLIT_NAMES

    print(f"{len(study.recordings)} sessions, split {args.split} = {SPLIT_NAMES[args.split]}: "
          f"best epoch {result.best_epoch}; "
          f"{out / f'table44_{args.split}.csv'}")
    _print_rows([*result.rows, *result.baseline_rows])
    return 0


def _heldout(args: argparse.Namespace) -> int:
    if _torch_missing("heldout"):
        return 1
    try:
        found = _study(args, "heldout")
        if found is None:
            return 1
        study, out = found
        learn = _learning("heldout")  # after the folder is checked: PyTorch takes seconds to import
        if learn is None:
            return 1
        ft = learn.FinetuneConfig(epochs=args.finetune_epochs, lr=args.finetune_lr, layers=args.finetune_layers)
        result = learn.heldout_study(study.recordings, out, seed=args.seed, epochs=args.epochs,
                                     patience=args.patience, windows_per_epoch=args.windows_per_epoch,
                                     calibration_s=args.calibration_s, finetune_config=ft, progress=not args.quiet)
    except (OSError, ValueError) as exc:
        print(f"psmat posture heldout: {_line(exc)}", file=sys.stderr)
        return 1
    print(f"{len(study.recordings)} sessions, test subjects of LSO (Leave Subjects Out) "
          f"{', '.join(result.split.subjects['test'])}, "
          f"windows after the first {args.calibration_s:g} s; {result.table_path}")
    _print_rows(result.rows)
    return 0


def _simulate(args: argparse.Namespace) -> int:
    from ..synth import simulate_posture_study

    try:
        root = simulate_posture_study(args.dir, subjects=args.subjects, days=args.days, seed=args.seed,
                                      rate_hz=args.rate, duration_s=args.seconds, progress=not args.quiet)
    except (OSError, ValueError) as exc:
        print(f"psmat posture simulate: {_line(exc)}", file=sys.stderr)
        return 1
    print(f"simulated posture study in {root}: {args.subjects} subject(s) x {args.days} day(s)")
    return 0


def _line(exc: BaseException) -> str:
    """An error as one line."""
    return " ".join(str(exc).split()) or type(exc).__name__

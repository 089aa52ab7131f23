"""``psmat study``: a balance study folder (docs/spec.md §6 layout) in batch.

``psmat study run DIR`` processes every session into ``DIR/results/`` (metrics.csv, summary,
figures, report; ``--reports`` adds one HTML page per subject), resuming where an earlier run
stopped; ``--scheduler tcp://HOST:8786`` (or
``--scheduler-file``, with ``--tls-*`` for TLS) runs the sessions on a Dask distributed cluster
(``pip install 'psmat[cluster]'``; the folder must be on a filesystem the workers share; the
cluster must be trusted, its workers run arbitrary code by design: :mod:`psmat.study` (``_cluster.py``)).
``psmat study simulate DIR`` writes a simulated study (docs/spec.md §7): BDS force-platform
trajectories through mats the processing does not know.
"""

from __future__ import annotations

import argparse
import sys

from . import _args

NAME = "study"
HELP = "run a balance study folder (metrics, summary, figures, report) or simulate one"


def _variant_key() -> str:
    """The variants spelled out, for --variants' help (from :func:`psmat.balance.describe`)."""
    from ..balance import BASE_VARIANTS, EXTRA_VARIANTS, describe

    keys = [f"{v}: {describe(v).key}" for v in (*BASE_VARIANTS, *EXTRA_VARIANTS)]  # type: ignore[union-attr]
    return ("Variants: " + "; ".join(keys) + "; X-8x8: X on an emulated 8x8 mat; IECM: the Inverse of "
            "Equivalent Conductance Method, the crosstalk removal.")


def add_arguments(p: argparse.ArgumentParser) -> None:
    from ..balance import PLATFORM_AXES

    sub = p.add_subparsers(dest="action", required=True, metavar="{run,simulate}")
    r = sub.add_parser("run", help="process every session of DIR into DIR/results/ (resumable)",
                       description="Process every session of a study folder into DIR/results/; finished sessions "
                                   "are reused, so a killed run resumes where it stopped.")
    r.add_argument("dir", metavar="DIR", help="the study folder (subjects.csv, sessions/, forceplate/)")
    r.add_argument("--workers", type=_args.positive_int, default=None,
                   help="processes, one session each (default: every core; 1: in this process)")
    r.add_argument("--scheduler", metavar="ADDRESS", default=None,
                   help="a Dask distributed scheduler, e.g. tcp://host:8786 or tls://host:8786 (DIR on a shared "
                        "filesystem; a cluster you trust: its workers run arbitrary code by design)")
    r.add_argument("--scheduler-file", metavar="FILE", default=None,
                   help="the JSON file a Dask scheduler wrote (dask scheduler --scheduler-file), instead of "
                        "--scheduler")
    r.add_argument("--tls-ca-file", metavar="FILE", default=None,
                   help="TLS to the cluster: the PEM file of the CA that signed its certificates")
    r.add_argument("--tls-cert", metavar="FILE", default=None,
                   help="TLS to the cluster: this client's PEM certificate (Dask's TLS is mutual)")
    r.add_argument("--tls-key", metavar="FILE", default=None,
                   help="TLS to the cluster: this client's PEM private key (if not in --tls-cert's file)")
    r.add_argument("--require-encryption", action="store_true",
                   help="refuse any connection to the cluster that is not TLS")
    r.add_argument("--variants", metavar="NAMES", default=None,
                   help="comma-separated processing variants to compute (default: the thesis' PROP, PROP-C, "
                        "CHC, SCHC and their 8x8; 'default' stands for those, e.g. default,SCHC-EQ adds the "
                        "per-cell equilibration). " + _variant_key())
    r.add_argument("--preprocess", choices=("quijoux2021", "none"), default="quijoux2021",
                   help="the preprocessing of every trace (platform and mat alike) before its sway metrics: "
                        "quijoux2021 = SWARII resampling to 25 Hz, 4th-order Butterworth low-pass at "
                        "10 Hz forward and backward; none = the raw traces. Eu is always on the unfiltered "
                        "aligned traces at the mat's frame times (thesis eq. 3.1)")
    r.add_argument("--descriptors", choices=("quijoux2021",), default=None,
                   help="add the 72 posturography descriptors of Quijoux et al. (2021) (preset quijoux2021) to "
                        "every row of metrics.csv, on the same aligned window")
    r.add_argument("--platform-axes", choices=PLATFORM_AXES, default="x,y", metavar="AXES",
                   help="how the force platform's axes lie on the mat's: M-L,A-P in terms of the platform file's "
                        "x and y, each possibly reversed (-) or swapped: x,y (as the files are), x,-y "
                        "(its A-P axis points the other way), y,x (its x is A-P), ... A trial whose platform "
                        "aligns poorly says which axes would align it; write --platform-axes=-x,y for a leading minus")
    r.add_argument("--reports", action="store_true",
                   help="also write one self-contained HTML report per subject, DIR/results/reports/<subject>.html "
                        "(psmat report of its sessions with their platform and events files), linked from "
                        "report.md; off by default because it processes every session a second time; a report "
                        "whose inputs are unchanged is not written again")
    r.add_argument("--quiet", action="store_true", help="no progress bar")
    s = sub.add_parser("simulate", help="write a simulated balance study into DIR",
                       description="Write a simulated balance study (docs/spec.md §7): three trials per volunteer "
                                   "(right-leg, left-leg, rotation; a fourth, romberg, with --romberg) driven by BDS "
                                   "force-platform trajectories.")
    s.add_argument("dir", metavar="DIR", help="the study folder to create")
    s.add_argument("--volunteers", type=_args.positive_int, required=True, help="number of volunteers")
    s.add_argument("--seconds", type=_args.session_seconds, required=True,
                   help="length of each trial, at most an hour (s)")
    s.add_argument("--seed", type=int, required=True, help="seed of every random draw")
    s.add_argument("--rate", type=_args.rate_hz, default=100.0, help="the mats' frame rate (Hz)")
    s.add_argument("--bds", nargs="+", metavar="FILE", default=None,
                   help="trial files of the BDS data set (force-platform recordings of human sway) to draw "
                        "trajectories from (default: those shipped with psmat)")
    s.add_argument("--romberg", action="store_true",
                   help="add a fourth trial per volunteer, 'romberg': eyes open then eyes closed (each --seconds "
                        "long, BDS trials of one subject on a firm surface) in one session with the markers "
                        "'eyes open' and 'eyes closed' (docs/spec.md §7)")


def run(args: argparse.Namespace) -> int:
    return _run(args) if args.action == "run" else _simulate(args)


def _run(args: argparse.Namespace) -> int:
    from ..study import run_study

    if args.workers is not None and (args.scheduler is not None or args.scheduler_file is not None):
        print("psmat study run: give --workers or --scheduler/--scheduler-file, not both", file=sys.stderr)
        return 1
    params: dict[str, object] = {"preprocess": None if args.preprocess == "none" else args.preprocess,
                                 "descriptors": args.descriptors, "platform_axes": args.platform_axes}
    if args.variants is not None:
        from ..balance import VARIANTS

        names = [n.strip() for n in args.variants.split(",") if n.strip()]
        params["variants"] = [v for n in names for v in (VARIANTS if n == "default" else (n,))]
    try:
        from ..study import security

        tls = security(args.tls_ca_file, args.tls_cert, args.tls_key, args.require_encryption)
        report = run_study(args.dir, workers=args.workers, scheduler=args.scheduler, params=params,
                           progress=not args.quiet, scheduler_file=args.scheduler_file, security=tls,
                           reports=args.reports)
    except (OSError, ValueError, ImportError, RuntimeError) as exc:
        print(f"psmat study run: {_line(exc)}", file=sys.stderr)
        return 1
    print(report)
    return 0


def _simulate(args: argparse.Namespace) -> int:
    from ..io import SessionNotCompleted
    from ..synth import simulate_study

    try:
        root = simulate_study(args.dir, volunteers=args.volunteers, duration_s=args.seconds, seed=args.seed,
                              rate_hz=args.rate, bds_paths=args.bds, progress=True, romberg=args.romberg)
    except (OSError, ValueError, SessionNotCompleted) as exc:
        print(f"psmat study simulate: {_line(exc, f'make room, remove {args.dir} and run it again')}",
              file=sys.stderr)
        return 1
    print(f"simulated study in {root}")
    return 0


def _line(exc: BaseException, again: str = "make room and run it again: what was finished is kept, and a run "
                                            "resumes where it stopped") -> str:
    """An error as one line (a full disk said in words, with ``again``: what to do)."""
    from .._atomic import no_space

    text = " ".join(str(exc).split()) or type(exc).__name__
    full = no_space(exc)
    if full and full not in text:
        where = getattr(exc, "filename", None)
        text = f"{f'{where}: ' if where else ''}{full} ({text})"
    return f"{text}; {again}" if full else text

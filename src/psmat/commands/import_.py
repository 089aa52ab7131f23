"""``psmat import``: another mat's pressure file as a psmat session (docs/spec.md §6).

``psmat import FILE -o OUT.h5`` reads a Tekscan ASCII export, an XSENSOR CSV export or a
generic CSV of one frame a line (``--format auto`` tells them apart from the first lines) and
writes a session of kind ``pressure``: the frames in kPa as the maker's software computed them,
their times, the sensel pitch as the session's geometry, and where they came from in its
metadata. A generic CSV needs ``--shape RxC --pitch-cm P`` and ``--rate-hz F`` (or a first
column of times in s). ``--unit`` gives the pressure unit when the file names none (kPa, mmHg,
PSI, N/cm2). A bad file is one line naming it and the line, exit status 1.
"""

from __future__ import annotations

import argparse

from ._args import shape as _shape

NAME = "import"
HELP = "import another mat's pressure file (Tekscan ASCII, XSENSOR CSV, generic CSV) as a session"
FORMATS = ("auto", "tekscan", "xsensor", "csv")


def _positive(text: str) -> float:
    import math

    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a number, got {text!r}") from None
    if not (math.isfinite(v) and v > 0):
        raise argparse.ArgumentTypeError(f"must be > 0, got {text!r}")
    return v


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("file", metavar="FILE", help="the file to import")
    p.add_argument("-o", "--out", metavar="OUT.h5", default=None,
                   help="the session to write (default: FILE's stem + .h5 beside it)")
    p.add_argument("--format", choices=FORMATS, default="auto", dest="fmt",
                   help="the file's format; auto reads it from the file's first lines")
    p.add_argument("--shape", type=_shape, default=None, metavar="RxC", help="generic CSV: rows x columns")
    p.add_argument("--pitch-cm", type=_positive, default=None, metavar="P", help="generic CSV: sensel pitch (cm)")
    p.add_argument("--rate-hz", type=_positive, default=None, metavar="F",
                   help="generic CSV: frame rate (Hz), when the file has no time column")
    p.add_argument("--unit", default=None, metavar="UNIT",
                   help="the pressure unit when the file names none: kPa, mmHg, PSI, N/cm2")
    p.add_argument("--overwrite", action="store_true", help="replace an existing OUT.h5")


def run(args: argparse.Namespace) -> int:
    import sys

    from ..io import ImportFormatError, import_pressure, load_session

    def fail(msg: object) -> int:
        print(f"psmat import: {' '.join(str(msg).split())}", file=sys.stderr)
        return 1

    opts = {"unit": args.unit}
    if args.fmt in ("auto", "csv"):
        opts.update(shape=args.shape, pitch_cm=args.pitch_cm, rate_hz=args.rate_hz)
    elif any(v is not None for v in (args.shape, args.pitch_cm, args.rate_hz)):
        return fail(f"--shape, --pitch-cm and --rate-hz apply to --format csv only, not {args.fmt}")
    try:
        out = import_pressure(args.file, args.out, args.fmt, overwrite=args.overwrite,
                              **{k: v for k, v in opts.items() if v is not None})
        s = load_session(out)
    except (ImportFormatError, ValueError, OSError) as exc:
        return fail(exc)
    print(f"psmat import: {s.metadata.get('source_format')} {args.file} ({s.n_frames} frames of "
          f"{s.frame_shape[0]}x{s.frame_shape[1]}, {s.duration_s:.3f} s, kPa) -> {out}")
    return 0

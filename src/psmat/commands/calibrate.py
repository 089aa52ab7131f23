"""``psmat calibrate``: open-circuit and short-circuit steps → calibration file (docs/spec.md §2).

Asks the person to unplug the mat, then to wire a few row–column pairs, records each step
and writes the JSON that :class:`psmat.Calibration` / :class:`psmat.Circuit` load.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from . import _args

NAME = "calibrate"
HELP = "calibrate the box: R_adc from an open circuit, R_mux from shorted pairs; writes a JSON file"


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("port", nargs="?", help="the box's serial port, or a pyserial URL such as "
                   "socket://127.0.0.1:5555 (omit with --simulate)")
    p.add_argument("--simulate", action="store_true", help="calibrate the digital twin (no person needed)")
    p.add_argument("--protocol", choices=("v1", "v2"), default="v2",
                   help="the box's frame format (docs/protocol.md)")
    p.add_argument("--shape", type=_args.shape, default=(16, 16), help="the mat's rows x columns, e.g. 16x16")
    p.add_argument("--pairs", default="corners",
                   help="row,column pairs to short: 'corners', 'all', or a list like 0,0;15,15")
    p.add_argument("--seconds", type=_args.seconds, default=1.0, help="recording length of each step (s)")
    p.add_argument("--per-pair", action="store_true", help="keep R_mux per pair (needs --pairs all)")
    p.add_argument("--out", default=None, help="file to write (default psmat_calibration_<serial>.json)")
    p.add_argument("--overwrite", action="store_true", help="replace an existing calibration file")
    p.add_argument("--yes", action="store_true", help="do not wait for Enter between steps")


def _pairs(text: str, R: int, C: int) -> list[tuple[int, int]]:
    if text == "corners":
        return sorted({(0, 0), (0, C - 1), (R - 1, 0), (R - 1, C - 1)})
    if text == "all":
        return [(i, p) for i in range(R) for p in range(C)]
    return [tuple(int(v) for v in item.split(",")) for item in text.split(";") if item.strip()]  # type: ignore[misc]


def run(args: argparse.Namespace) -> int:
    import sys

    from .._atomic import OutputRefused, check_outputs
    from ..acquire import open_device
    from ..workflows.calibrate_steps import run_calibration

    if bool(args.port) == bool(args.simulate):
        print("psmat calibrate: give a PORT or --simulate", file=sys.stderr)
        return 1
    R, C = args.shape
    if args.simulate and (twin_problem := _args.twin_shape_problem(args.shape)):
        print(f"psmat calibrate: {twin_problem}", file=sys.stderr)
        return 1
    try:
        pairs = _pairs(args.pairs, R, C)
    except ValueError:
        print(f"psmat calibrate: --pairs must be 'corners', 'all' or 'i,p;i,p', got {args.pairs!r}", file=sys.stderr)
        return 1
    twin = fixture = None
    port = args.port
    if args.simulate:
        from ..twin import CalibrationFixture, PsmSource, SerialTwin

        fixture = CalibrationFixture(PsmSource.named("quiet", 100, (R, C), duration_s=10))
        twin = SerialTwin("psm", 100, args.protocol, source=fixture, shape=(R, C)).start()
        port = twin.port
    prompt = (lambda text: print(text)) if args.yes or args.simulate else input
    try:
        with open_device(port, "psm", args.protocol, (R, C)) as dev:
            # the file name is known once the box has said its serial: refuse before any step
            out = Path(args.out or f"psmat_calibration_{(dev.description or {}).get('serial') or 'unknown'}.json")
            try:
                check_outputs([out], inputs=[port], overwrite=args.overwrite)
            except OutputRefused as exc:
                print(f"psmat calibrate: {exc}", file=sys.stderr)
                return 1
            dev.start()
            cal = run_calibration(dev, pairs, seconds=args.seconds, prompt=prompt,
                                  set_fixture=(lambda m: setattr(fixture, "mode", m)) if fixture else None,
                                  per_pair=args.per_pair)
    except (ValueError, RuntimeError) as exc:
        print(f"psmat calibrate: {exc}", file=sys.stderr)
        return 1
    finally:
        if twin is not None:
            twin.stop()
    try:
        cal.save(out, overwrite=args.overwrite)  # whole or not at all
    except OutputRefused as exc:
        print(f"psmat calibrate: {exc}", file=sys.stderr)
        return 1
    r_mux = cal.r_mux if isinstance(cal.r_mux, float) else f"per pair, median {float(__import__('numpy').median(cal.r_mux)):.1f}"
    print(f"R_adc = {cal.r_adc / 1e6:.3g} MOhm, R_mux = {r_mux if isinstance(r_mux, str) else f'{r_mux:.1f}'} Ohm "
          f"(box {cal.serial or 'without serial'})")
    print(f"written {out}; apply it with psmat.Circuit().calibrated(psmat.Calibration.load(path)), or pass it to "
          "psmat.process.process_session(..., calibration=path)")
    return 0

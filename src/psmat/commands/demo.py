"""``psmat demo``: the main job on the simulated mat (or a real one with ``--port``).

Records a person swaying from the digital twin through the serial link, removes crosstalk,
compensates the sensor, computes the CoP and compares it with the force platform's; writes
a figure and the session file. ``--crosstalk`` runs the single-frame crosstalk demo instead.

The mat is the one of ``--profile NAME|FILE`` (default ``psm16``, the thesis' mat; docs/spec.md §5
"Device profiles"): the twin is a mat of its shape, pitch and circuit, the port is read with its
protocol, and the session stores it, so the processing places the CoP on its geometry.
"""

from __future__ import annotations

import argparse
import sys

from typing import Any

from . import _args, _profile_args

NAME = "demo"
HELP = "record, process and plot a swaying person on the simulated mat (or --port PORT)"


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--out", type=_args.figure_file, default="psmat_demo.png",
                   help="figure path (its suffix names the format: .png, .pdf, .svg, ...)")
    p.add_argument("--port", default=None, help="a real mat's serial port or pyserial URL (default: a psmat box "
                   "found on USB, else the digital twin)")
    p.add_argument("--twin", action="store_true", help="use the digital twin even if a mat is plugged in")
    p.add_argument("--seconds", type=_args.session_seconds, default=8.0, help="recording length, at most an hour (s)")
    _profile_args.add_profile_argument(p)
    p.add_argument("--rate", type=_args.positive_int, default=None,
                   help="frame rate of the recording (frames/s; default: the profile's)")
    p.add_argument("--session", default="psmat_demo.h5", help="session file to write (HDF5)")
    p.add_argument("--bds-trial", type=int, default=1,
                   help="trial of the BDS data set (force-platform recordings of human sway shipped with psmat) "
                        "driving the twin")
    p.add_argument("--crosstalk", action="store_true", help="run the single-frame crosstalk demo instead")
    p.add_argument("--shape", type=_args.shape, default=None,
                   help="rows x cols of the mat, e.g. 16x16 (default: the profile's; with --crosstalk 16x16)")
    p.add_argument("--noise-mv", type=_args.nonnegative, default=1.0,
                   help="with --crosstalk: standard deviation of the voltage noise on the ADC node (mV)")
    p.add_argument("--seed", type=int, default=0, help="seed of the simulation's random draws")
    p.add_argument("--show", action="store_true", help="also open a window")
    p.add_argument("--overwrite", action="store_true",
                   help="replace an existing figure or session file (each only once its new one is complete)")


def _rate(args: argparse.Namespace, prof: Any) -> float:
    """The recording's frame rate (frames/s): ``--rate``, else the profile's."""
    return float(args.rate) if args.rate is not None else float(prof.rate_hz)


def _check(args: argparse.Namespace, prof: Any) -> str | None:
    """Why the outputs may not be written (one line), or None; nothing is touched."""
    from .. import _checks
    from .._atomic import OutputRefused, check_outputs
    from ..io import journal_path
    from ..io.session import unfinished_line

    rate = _rate(args, prof)
    shape = (args.shape or (16, 16)) if args.crosstalk else tuple(prof.shape)
    if rate > _checks.MAX_RATE_HZ:
        return (f"--rate is at most {_checks.MAX_RATE_HZ} frames/s (the PSM firmware's fastest, docs/spec.md §5), "
                f"got {rate:g}")
    if args.port is None and (twin := _args.twin_shape_problem(shape)):
        return twin
    if args.port is None and not args.crosstalk:  # the twin's scene, as workflows.sway_demo sizes it
        from ..twin.sources import check_scene

        if prof.protocol != "csv" and rate != int(rate):
            return f"the simulated mat's timer takes a whole number of frames per second, got {rate:g} (give --rate)"
        try:
            check_scene(max(60.0, args.seconds + 1), rate, shape)
        except ValueError as exc:
            return f"--seconds {args.seconds:g} at --rate {rate:g} on --shape {shape[0]}x{shape[1]}: {exc}"
    outputs = [args.out] if args.crosstalk else [args.out, args.session]
    if not args.crosstalk:
        unfinished = unfinished_line(args.session)  # its journal is the only copy of that recording
        if unfinished:
            return (f"{unfinished} ({journal_path(args.session)} is its only copy: not recorded over, even with "
                    "--overwrite)")
        if journal_path(args.session).exists() and not args.overwrite:
            return f"{journal_path(args.session)} exists; add --overwrite to replace it"
    try:
        check_outputs(outputs, inputs=[args.port], overwrite=args.overwrite)
    except OutputRefused as exc:
        return str(exc)
    return None


def run(args: argparse.Namespace) -> int:
    try:
        prof = _profile_args.resolve(args, "psm")
    except ValueError as exc:
        print(f"psmat demo: {exc}", file=sys.stderr)
        return 1
    rows, cols = (args.shape or (16, 16)) if args.crosstalk else tuple(prof.shape)
    rate = _rate(args, prof)
    problem = _check(args, prof)  # before a port is opened or anything is recorded
    if problem:
        print(f"psmat demo: {problem}", file=sys.stderr)
        return 1
    if not args.crosstalk:
        from ..acquire import find_devices
        from ..workflows.sway_demo import run_sway_demo

        if args.port is None and not args.twin:
            found = find_devices()
            if found:
                args.port = found[0].port
                print(f"psmat demo: using the mat on {args.port} ({found[0].description}); --twin for the simulation")

        print(f"psmat demo: {args.seconds:g} s of a person swaying, {rows}x{cols} at {rate:g} Hz "
              f"(profile {prof.name}, {prof.pitch_cm:g} cm pitch)")
        try:
            run_sway_demo(args.out, seconds=args.seconds, rate_hz=rate, session=args.session,
                          bds_trial=args.bds_trial, port=args.port, seed=args.seed, overwrite=args.overwrite,
                          profile=prof)
        except FileNotFoundError as exc:  # the force-platform trial the twin follows is not there
            print(f"psmat demo: {exc}", file=sys.stderr)
            return 1
        return 0
    from ..workflows.crosstalk_demo import run_crosstalk_demo

    res = run_crosstalk_demo(args.out, rows=rows, cols=cols, noise_v=args.noise_mv * 1e-3,
                             seed=args.seed, show=args.show)
    print(f"psmat demo: simulated {rows}x{cols} mat, two feet, {args.noise_mv:g} mV noise, 12-bit ADC")
    print(f"  ghost (conductance outside the feet): {100 * res['ghost_fraction_raw']:.1f} % raw -> "
          f"{100 * res['ghost_fraction_iecm']:.2f} % after IECM")
    print(f"  centre-of-pressure error: {res['cop_error_raw_cm']:.3f} cm raw -> {res['cop_error_iecm_cm']:.4f} cm after IECM")
    print(f"  loaded cells: median relative error {res['loaded_cells_median_rel_error']:.2e}, "
          f"median propagated uncertainty {res['loaded_cells_median_rel_uncertainty']:.2e}")
    print(f"  IECM: {res['iterations']} iterations, status {res['status']}")
    print(f"  figure: {res['figure']}")
    return 0

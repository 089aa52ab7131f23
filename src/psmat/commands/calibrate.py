"""``psmat calibrate``: the box's electronics and the mat's pressure → calibration file (docs/spec.md §2, §4).

``psmat calibrate PORT`` (or ``--simulate``) calibrates the electronics: it asks the person to
unplug the mat, then to wire a few row–column pairs, records each step and writes the JSON
that :class:`psmat.Calibration` / :class:`psmat.Circuit` load. The box is the ``--profile``'s
(default psm16, the thesis' 12-bit 3.3 V box): its shape, protocol and circuit; the file records
that circuit's R_o, V_ref and ADC bits, for which the estimates hold. A box whose open circuit
reads full scale (R_adc beyond the ADC's resolution, as an Arduino's) keeps the nominal R_adc.

The pressure steps add their part, dated, to a calibration file (``--calibration``, created if
missing, replaced whole or not at all), from session files recorded with ``psmat record``:

* ``psmat calibrate equilibrate S1.h5 S2.h5 --level-kpa 20 40 --calibration CAL.json`` — uniform
  loads of known level over the whole mat (a bladder, masses on a plate) → per-cell gains;
* ``psmat calibrate known-load S.h5 --load-kg 70 --calibration CAL.json`` — a known load (masses,
  or a person of known weight standing still; or ``--load-n``) → one global scale (thesis eq. 3.3);
* ``psmat calibrate pneumatic LOG --schedule CSV --calibration CAL.json`` — a material-DAQ log
  of pneumatic-platform samples and its pressure schedule (CSV time_s,pressure_psi) → a
  fitted sensor model.

Each recording starts with the mat unloaded; the average starts --settle-s after the load appears.
``psmat.process`` then turns counts into kPa with the file's pressure part.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from . import _args, _profile_args

NAME = "calibrate"
HELP = ("calibrate the box (R_adc from an open circuit, R_mux from shorted pairs) or the mat's pressure "
        "(equilibrate, known-load, pneumatic); writes a JSON file")

#: the pressure steps, named where the electronics' PORT goes
STEPS = ("equilibrate", "known-load", "pneumatic")


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("port", nargs="?", metavar="PORT|STEP",
                   help="the box's serial port, or a pyserial URL such as socket://127.0.0.1:5555 (omit with "
                        "--simulate); or a pressure step: equilibrate, known-load, pneumatic")
    p.add_argument("files", nargs="*", metavar="FILE",
                   help="the pressure step's recordings: session files (equilibrate: one per level; known-load: "
                        "one), or the material DAQ's log (pneumatic)")
    p.add_argument("--simulate", action="store_true", help="calibrate the digital twin (no person needed)")
    _profile_args.add_profile_argument(p)
    p.add_argument("--protocol", choices=("v1", "v2"), default=None,
                   help="the box's frame format (docs/protocol.md; default: the profile's)")
    p.add_argument("--shape", type=_args.shape, default=None,
                   help="the mat's rows x columns, e.g. 16x16 (default: the profile's, 16x16 for psm16)")
    p.add_argument("--pairs", default="corners",
                   help="row,column pairs to short: 'corners', 'all', or a list like 0,0;15,15")
    p.add_argument("--seconds", type=_args.seconds, default=1.0, help="recording length of each step (s)")
    p.add_argument("--per-pair", action="store_true", help="keep R_mux per pair (needs --pairs all)")
    p.add_argument("--out", default=None, help="file to write (default psmat_calibration_<serial>.json)")
    p.add_argument("--overwrite", action="store_true", help="replace an existing calibration file")
    p.add_argument("--yes", action="store_true", help="do not wait for Enter between steps")
    g = p.add_argument_group("pressure steps")
    g.add_argument("--calibration", metavar="CAL.json", default=None,
                   help="the calibration file the step adds its part to (created if missing)")
    g.add_argument("--level-kpa", type=_positive, nargs="+", default=None,
                   help="equilibrate: the uniform load of each recording, in order (kPa)")
    g.add_argument("--load-kg", type=_positive, default=None,
                   help="known-load: the known mass on the mat, a person's weight included (kg)")
    g.add_argument("--load-n", type=_positive, default=None,
                   help="known-load: the known load instead of --load-kg (N)")
    g.add_argument("--settle-s", type=_args.nonnegative, default=3.0,
                   help="time after the load appears before frames enter the average (s)")
    g.add_argument("--schedule", metavar="CSV", default=None,
                   help="pneumatic: the applied-pressure schedule, CSV rows time_s,pressure_psi")


def _positive(text: str) -> float:
    """A load or level: a finite number > 0."""
    return _args._positive(text, "a load")


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

    if args.port in STEPS:
        return _pressure_step(args)
    if bool(args.port) == bool(args.simulate):
        print("psmat calibrate: give a PORT or --simulate", file=sys.stderr)
        return 1
    stray = [f"--{k.replace('_', '-')}" for k in ("calibration", "level_kpa", "load_kg", "load_n", "schedule")
             if getattr(args, k) is not None] + (args.files[:1] or [])
    if stray:
        print(f"psmat calibrate: {stray[0]} belongs to a pressure step ({', '.join(STEPS)}), not to the "
              "electronics (PORT or --simulate)", file=sys.stderr)
        return 1
    try:  # the box: its shape, protocol and measurement chain
        prof = _profile_args.resolve(args, "psm")
    except ValueError as exc:
        print(f"psmat calibrate: {exc}", file=sys.stderr)
        return 1
    R, C = prof.shape
    if args.simulate and (twin_problem := _args.twin_shape_problem((R, C))):
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

        rate, note = _profile_args.twin_rate_hz(None, prof)
        if note:
            print(f"psmat calibrate: {note}", file=sys.stderr)
        # the profile's box and mat: shape, circuit (what the open and shorted set-ups read through), wire order
        fixture = CalibrationFixture(PsmSource.named("quiet", rate, profile=prof, duration_s=10))
        twin = SerialTwin("psm", rate, prof.protocol, source=fixture, shape=(R, C)).start()
        port = twin.port
    prompt = (lambda text: print(text)) if args.yes or args.simulate else input
    try:
        with open_device(port, "psm", prof.protocol, (R, C), prof.baudrate, bits=prof.bits, row_order=prof.row_order,
                         col_order=prof.col_order) as dev:
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
                                  per_pair=args.per_pair, circuit=prof.circuit(), rate_hz=prof.rate_hz)
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
    print(f"written {out} (R_o {cal.r_o:g} Ohm, V_ref {cal.v_ref:g} V, {cal.bits}-bit: profile {prof.name}); apply "
          f"it with psmat.Circuit(r_o={cal.r_o:g}, v_ref={cal.v_ref:g}, bits={cal.bits}).calibrated("
          "psmat.Calibration.load(path)), or pass it to psmat.process.process_session(..., calibration=path)")
    return 0


def _pressure_step(args: argparse.Namespace) -> int:
    """One pressure step (module docstring): its part added to --calibration, or one line on stderr."""
    import sys

    from ..workflows import calibrate_pressure as steps

    step = args.port
    say = f"psmat calibrate {step}"
    problem = None
    if args.simulate:
        problem = "--simulate is for the electronics (psmat calibrate --simulate)"
    elif args.calibration is None:
        problem = "give --calibration CAL.json: the file the step adds its part to"
    elif not args.files:
        problem = "give the recording(s) to calibrate from"
    elif step == "equilibrate" and args.level_kpa is None:
        problem = "give --level-kpa: the uniform load of each recording (kPa)"
    elif step == "known-load" and (args.load_kg is None) == (args.load_n is None):
        problem = "give the known load: --load-kg or --load-n (one of them)"
    elif step == "known-load" and len(args.files) != 1:
        problem = f"one recording of the known load, got {len(args.files)}"
    elif step == "pneumatic" and (args.schedule is None or len(args.files) != 1):
        problem = "give one DAQ log and --schedule CSV (time_s,pressure_psi)"
    else:
        missing = [f for f in [*args.files, args.schedule] if f is not None and not Path(f).is_file()]
        if missing:
            problem = f"no such file: {missing[0]}"
    if problem:
        print(f"{say}: {problem}", file=sys.stderr)
        return 1
    try:
        if step == "equilibrate":
            result, part = steps.run_equilibrate(args.files, args.level_kpa, args.calibration, settle_s=args.settle_s)
            n = int(result.flagged.sum())
            import numpy as np

            print(f"gains of {result.gains.size - n} cells: median {float(np.median(result.gains)):.3g}, "
                  f"range {float(result.gains.min()):.3g} ... {float(result.gains.max()):.3g}; "
                  f"{n} cell(s) without a gain (given the median)")
            if len(args.files) > 1:
                print(f"spread between recordings: median {float(np.nanmedian(result.spread)) * 100:.2g} %, "
                      f"largest {float(np.nanmax(result.spread)) * 100:.2g} %")
        elif step == "known-load":
            load_n = args.load_n if args.load_n is not None else args.load_kg * steps.STANDARD_GRAVITY
            part = steps.run_known_load(args.files[0], load_n, args.calibration, settle_s=args.settle_s)
            print(f"scale {part.scale:.4g} for a known load of {load_n:.1f} N")
        else:
            part = steps.run_pneumatic(args.files[0], args.schedule, args.calibration)
            print(f"sensor model fitted on {args.files[0]}: {part.sensor!r}")
    except (ValueError, OSError) as exc:
        print(f"{say}: {' '.join(str(exc).split())}", file=sys.stderr)
        return 1
    print(f"written {args.calibration}: {part.describe()}")
    return 0

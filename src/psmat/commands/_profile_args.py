"""``--profile NAME|FILE`` and the device options it supplies defaults for (docs/spec.md §5 "Device profiles").

One rule for every command that opens or simulates a device (``record``, ``view``, ``lab``,
``simulate``, ``demo``, ``calibrate``): the device is described by a profile; an option given on the command
line overrides that one field of it.

* no ``--profile``: the shipped profile of the device kind (``psm16`` for a mat, ``imu``,
  ``daq``), or ``arduino16`` for a mat whose ``--protocol`` is ``csv`` (a do-it-yourself mat);
* ``--protocol`` replaces the profile's protocol; ``--shape`` gives the profile for that shape
  (pitch, axes and circuit kept, the wire order dropped: :meth:`psmat.Profile.with_shape`);
  ``--bits`` replaces the ADC resolution.

The profile that results is what the command uses and what a recorded session stores.
"""

from __future__ import annotations

import argparse
from dataclasses import replace
from typing import Any

__all__ = ["add_profile_argument", "add_mat_overrides", "profile", "resolve", "device_kind", "twin_rate_hz",
           "DEFAULT_FOR_KIND", "CSV_PROFILE"]

#: the profile of each device kind when none is named
DEFAULT_FOR_KIND = {"psm": "psm16", "imu": "imu", "daq": "daq"}
#: the profile of a mat streaming csv when none is named: a do-it-yourself Arduino mat
CSV_PROFILE = "arduino16"


def profile(text: str) -> Any:
    """argparse type: a shipped profile's name or a profile file (.toml) → :class:`psmat.Profile`."""
    from ..profile import ProfileError, load_profile

    try:
        return load_profile(text)
    except ProfileError as exc:
        hint = "" if text.endswith(".toml") else "; psmat profiles describes each"
        raise argparse.ArgumentTypeError(f"{exc}{hint}") from None


def add_profile_argument(p: argparse.ArgumentParser) -> None:
    """Add ``--profile NAME|FILE`` to a command's parser."""
    p.add_argument("--profile", type=profile, default=None, metavar="NAME|FILE",
                   help="the device's profile: a shipped name (psmat profiles lists them) or a TOML file; it gives "
                        "the shape, pitch, circuit, protocol and rate, and any option given here overrides its value "
                        "(default: psm16, the thesis' mat, or arduino16 with --protocol csv)")


def add_mat_overrides(p: argparse.ArgumentParser, what: str = "the mat's") -> None:
    """Add ``--protocol``, ``--bits`` and ``--shape``, the fields of a mat's profile a command line
    overrides (``psmat record``, ``psmat lab``); ``what`` names whose frame format ``--protocol`` is."""
    from . import _args

    p.add_argument("--protocol", choices=("v1", "v2", "csv"), default=None,
                   help=f"{what} frame format (docs/protocol.md): v1, v2, or csv (the text lines of a "
                        "do-it-yourself mat, e.g. an Arduino: no commands); default: the profile's (without "
                        "--profile, csv means the arduino16 mat)")
    p.add_argument("--bits", type=_args.bits, default=None,
                   help="ADC resolution of a csv mat: a count above 2**bits - 1 is an invalid frame (default: the "
                        "profile's, 10 for arduino16; v1/v2 devices carry 12-bit counts)")
    p.add_argument("--shape", type=_args.shape, default=None,
                   help="the mat's rows x columns, e.g. 16x16 (default: the profile's, 16x16 for psm16)")


def resolve(args: argparse.Namespace, kind: str = "psm") -> Any:
    """The profile a command uses: ``args.profile`` (or the kind's default) with the command line's
    ``protocol``, ``shape`` and ``bits`` (attributes that are absent or None are not given).

    Raises
    ------
    ValueError
        A profile of another device kind, or an override the profile refuses (one line).
    """
    from ..profile import ProfileError, load_profile

    protocol = getattr(args, "protocol", None)
    shape = getattr(args, "shape", None)
    bits = getattr(args, "bits", None)
    prof = getattr(args, "profile", None)
    if prof is None:
        prof = load_profile(CSV_PROFILE if kind == "psm" and protocol == "csv" else DEFAULT_FOR_KIND[kind])
    elif prof.kind != kind:
        raise ValueError(f"--profile {prof.name} describes a {prof.kind} device, not a {kind} device")
    try:
        if protocol is not None and protocol != prof.protocol:
            prof = replace(prof, protocol=protocol, source=f"{prof.source or prof.name}, protocol {protocol}")
        if shape is not None and kind == "psm" and tuple(shape) != tuple(prof.shape):
            prof = prof.with_shape(tuple(shape))
        if bits is not None and bits != prof.bits:
            prof = replace(prof, bits=int(bits), source=f"{prof.source or prof.name}, {bits}-bit")
    except ProfileError as exc:
        raise ValueError(str(exc)) from None
    return prof


def device_kind(args: argparse.Namespace) -> str:
    """The device kind a command works on: ``--device`` when given, else the ``--profile``'s kind,
    else ``psm``.

    Raises
    ------
    ValueError
        ``--device`` and ``--profile`` name different kinds (one line).
    """
    device = getattr(args, "device", None)
    prof = getattr(args, "profile", None)
    if prof is not None and device is not None and prof.kind != device:
        a = "an" if prof.kind[0] in "aeiou" else "a"
        raise ValueError(f"--profile {prof.name} describes {a} {prof.kind} device, not --device {device}: "
                         f"drop --device or give a profile of kind {device}")
    return device or (prof.kind if prof is not None else "psm")


def twin_rate_hz(rate_hz: float | None, prof: Any) -> tuple[float, str | None]:
    """The frame rate of a simulated device (Hz) and, when the profile's had to change, a note saying so.

    ``rate_hz`` (``--rate``) when given, else the profile's ``rate_hz``. A device whose firmware
    runs on a timer (a mat speaking v1/v2, the IMU box) takes a whole number of frames per second,
    1 ... 1000: a fractional profile rate is rounded to the nearest one.
    """
    if rate_hz is not None:
        return float(rate_hz), None
    rate = float(prof.rate_hz)
    if prof.kind == "daq" or prof.protocol == "csv":  # no firmware timer: any rate the profile gives
        return rate, None
    whole = float(min(1000, max(1, round(rate))))
    if whole == rate:
        return rate, None
    return whole, (f"profile {prof.name}: rate_hz {rate:g} rounded to {whole:g} Hz (the firmware's timer counts "
                   "whole frames per second)")

"""``psmat profiles``: the device profiles (docs/spec.md §5 "Device profiles").

A device is described by a small TOML file: its kind and protocol, nominal rate and line speed,
for a mat its geometry (shape, pitch, origin, axis directions) and the order of its rows and
columns on the wire, and its measurement circuit. Without an argument, ``psmat profiles`` lists
the profiles shipped with psmat (name, kind, shape, pitch, protocol, rate, description);
``psmat profiles NAME`` prints one of them as TOML text, its source on the first line, and
``psmat profiles FILE.toml`` checks a profile file of your own and prints it the same way (a
bad key or value is one line naming the file and the key). To describe a new mat, start from
the printed text of the closest shipped profile and change what differs.
"""

from __future__ import annotations

import argparse

NAME = "profiles"
HELP = "list the device profiles (mats, IMU box, DAQ), or print one as TOML"


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("profile", nargs="?", default=None, metavar="NAME|FILE",
                   help="a shipped profile's name, or a profile file (.toml) to check and print")


def _table() -> str:
    """The shipped profiles, one line each, under a header with the units."""
    from ..profile import list_profiles

    header = ("name", "kind", "shape", "pitch (cm)", "protocol", "rate (Hz)", "description")
    rows = [header]
    for prof in list_profiles():
        rows.append((prof.name, prof.kind, "x".join(map(str, prof.shape)),
                     "-" if prof.pitch_cm is None else f"{prof.pitch_cm:g}", prof.protocol, f"{prof.rate_hz:g}",
                     prof.description))
    widths = [max(len(r[k]) for r in rows) for k in range(len(header) - 1)]
    return "\n".join("  ".join([c.ljust(w) for c, w in zip(r, widths)] + [r[-1]]) for r in rows)


def run(args: argparse.Namespace) -> int:
    import sys

    from ..profile import ProfileError, load_profile

    if args.profile is None:
        print(_table())
        return 0
    try:
        prof = load_profile(args.profile)
    except ProfileError as exc:
        print(f"psmat profiles: {exc}", file=sys.stderr)
        return 1
    print(prof.to_toml(), end="")
    return 0

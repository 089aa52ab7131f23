"""Command line: ``psmat <command>`` (also ``python -m psmat``).

Commands live one per module in :mod:`psmat.commands` and are discovered here, so adding a
command is adding a file. A command-line error (a bad or missing argument) is one line on
stderr and exit status 1, like every other error a person can fix.
"""

from __future__ import annotations

import argparse
import importlib
import pkgutil
import sys
from typing import NoReturn

from . import commands as _commands


def _command_modules() -> list:
    mods = []
    for info in sorted(pkgutil.iter_modules(_commands.__path__), key=lambda m: m.name):
        if info.name.startswith("_"):
            continue
        mod = importlib.import_module(f"{_commands.__name__}.{info.name}")
        if hasattr(mod, "NAME") and hasattr(mod, "run"):
            mods.append(mod)
    return mods


class UsageError(Exception):
    """A bad command line, already worded for the person who typed it."""


class _Parser(argparse.ArgumentParser):
    """argparse without the usage block and exit status 2: errors become :class:`UsageError`."""

    def error(self, message: str) -> NoReturn:
        raise UsageError(f"{self.prog}: {message} (see {self.prog} --help)")


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="psmat", description="Low-cost pressure-sensitive mats")
    sub = parser.add_subparsers(dest="command", required=True)
    for mod in _command_modules():
        p = sub.add_parser(mod.NAME, help=mod.HELP, description=mod.__doc__,
                           add_help=getattr(mod, "ADD_HELP", True))
        mod.add_arguments(p)
        p.set_defaults(func=mod.run, parser=p)
    return parser


def parse(argv: list[str] | None = None) -> argparse.Namespace:
    """The command line as a namespace; raises :class:`UsageError` for a bad one."""
    args, unknown = build_parser().parse_known_args(argv)
    if unknown:  # named by the subcommand's parser, so that the hint is its --help
        args.parser.error(f"unrecognized arguments: {' '.join(unknown)}")
    return args


def main(argv: list[str] | None = None) -> int:
    try:
        args = parse(argv)
    except UsageError as exc:
        print(exc, file=sys.stderr)
        return 1
    try:
        return int(args.func(args))
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130
    except Exception as exc:
        # a device that cannot be opened or vanishes is the person's problem to fix, not a
        # bug: one clear line instead of a traceback (anything else still raises)
        if not _is_device_error(exc):
            raise
        print(f"psmat {args.command}: {exc}", file=sys.stderr)
        return 1


def _is_device_error(exc: BaseException) -> bool:
    from .acquire import AcquireError

    try:
        from serial import SerialException
    except ImportError:  # pragma: no cover - pyserial is a dependency
        return isinstance(exc, AcquireError)
    return isinstance(exc, (AcquireError, SerialException))


if __name__ == "__main__":
    sys.exit(main())

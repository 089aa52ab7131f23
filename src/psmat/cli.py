"""Command line: ``psmat <command>`` (also ``python -m psmat``).

Commands live one per module in :mod:`psmat.commands` and are discovered here, so adding a
command is adding a file.
"""

from __future__ import annotations

import argparse
import importlib
import pkgutil
import sys

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


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="psmat", description="Low-cost pressure-sensitive mats")
    sub = parser.add_subparsers(dest="command", required=True)
    for mod in _command_modules():
        p = sub.add_parser(mod.NAME, help=mod.HELP, description=mod.__doc__,
                           add_help=getattr(mod, "ADD_HELP", True))
        mod.add_arguments(p)
        p.set_defaults(func=mod.run)
    return parser


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
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

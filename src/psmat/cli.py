"""Command line: ``psmat <command>`` (also ``python -m psmat``).

Commands live one per module in :mod:`psmat.commands` and are discovered here, so adding a
command is adding a file. A command-line error (a bad or missing argument) is one line on
stderr and exit status 1, like every other error a person can fix. SIGTERM and SIGHUP stop a
command as Ctrl-C does (:mod:`psmat._signals`): a recording is closed into its file.

Help is for people (:mod:`psmat._help`): each command's description is its module docstring
as plain text, and every option shows its default and unit. ``psmat --version`` prints the
package version.
"""

from __future__ import annotations

import argparse
import importlib
import pkgutil
import sys
from collections.abc import Collection
from typing import NoReturn

from . import commands as _commands
from ._help import HelpFormatter, plain


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


DESCRIPTION = """psmat: software for low-cost pressure-sensitive mats (PSM), resistive sensor arrays
read row by row: record and view a mat or its simulation (the digital twin), remove the
crosstalk between cells (IECM, the inverse of equivalent conductance method), compensate the
sensor's hysteresis and creep, and run balance and posture studies as in the thesis."""
EPILOG = "Run psmat COMMAND --help for a command's options."


def _version() -> str:
    from . import __version__

    return f"psmat {__version__}"


class _Version(argparse.Action):
    """``--version``: print ``psmat X.Y.Z`` and exit 0 (the version read when asked for)."""

    def __init__(self, option_strings: list[str], dest: str = argparse.SUPPRESS, **kwargs: object) -> None:
        super().__init__(option_strings, dest, nargs=0, default=argparse.SUPPRESS,
                         help="print the package version (psmat X.Y.Z) and exit")

    def __call__(self, parser: argparse.ArgumentParser, namespace: argparse.Namespace, values: object,
                 option_string: str | None = None) -> None:
        print(_version())
        parser.exit(0)


def subparsers(parser: argparse.ArgumentParser) -> dict[str, argparse.ArgumentParser]:
    """The subcommands of ``parser`` by name (``run`` and ``simulate`` of ``psmat study``, ...)."""
    found: dict[str, argparse.ArgumentParser] = {}
    for action in parser._actions:  # argparse keeps the actions only there
        if isinstance(action, argparse._SubParsersAction):
            found.update(action.choices)
    return found


def _for_people(parser: argparse.ArgumentParser) -> None:
    """The help of ``parser`` and of every subcommand below it as plain, filled text with defaults."""
    parser.formatter_class = HelpFormatter
    parser.description = plain(parser.description)
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for choice in action._choices_actions:
                choice.help = plain(choice.help)
    for sub in subparsers(parser).values():
        _for_people(sub)


def build_parser(commands: Collection[str] | None = None) -> argparse.ArgumentParser:
    """The ``psmat`` parser: every command, with the options of those named in ``commands``.

    ``None`` (the default) adds every command's options (the whole help tree); :func:`parse`
    names only the command on its command line, so that ``psmat --help`` and ``psmat info F``
    do not run the other commands' ``add_arguments`` (which may import what their defaults
    come from).
    """
    parser = _Parser(prog="psmat", description=DESCRIPTION, epilog=EPILOG)
    parser.add_argument("--version", action=_Version)
    sub = parser.add_subparsers(dest="command", required=True, metavar="command", title="commands")
    for mod in _command_modules():
        p = sub.add_parser(mod.NAME, help=mod.HELP, description=getattr(mod, "DESCRIPTION", None) or mod.__doc__)
        if commands is None or mod.NAME in commands:
            mod.add_arguments(p)
        p.set_defaults(func=mod.run, parser=p)
    _for_people(parser)
    return parser


def _command_word(argv: list[str]) -> str | None:
    """The command named on a command line: its first word that is not an option (``psmat`` itself
    has only ``--help`` and ``--version``, which take no value)."""
    return next((a for a in argv if not a.startswith("-")), None)


def parse(argv: list[str] | None = None) -> argparse.Namespace:
    """The command line as a namespace; raises :class:`UsageError` for a bad one."""
    argv = sys.argv[1:] if argv is None else list(argv)
    word = _command_word(argv)
    args, unknown = build_parser(() if word is None else (word,)).parse_known_args(argv)
    if unknown:  # named by the subcommand's parser, so that the hint is its --help
        args.parser.error(f"unrecognized arguments: {' '.join(unknown)}")
    return args


def main(argv: list[str] | None = None) -> int:
    try:
        args = parse(argv)
    except UsageError as exc:
        print(exc, file=sys.stderr)
        return 1
    from ._signals import Terminated, stop_on_termination

    try:
        with stop_on_termination():  # SIGTERM and SIGHUP stop a command as Ctrl-C does
            return int(args.func(args))
    except Terminated as exc:
        print(f"psmat {args.command}: {exc}", file=sys.stderr)
        return exc.exit_status
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130
    except Exception as exc:
        # a device that cannot be opened or vanishes, or a full disk, is the person's problem to fix,
        # not a bug: one clear line instead of a traceback (anything else still raises)
        from ._atomic import causes, no_space

        full = no_space(exc)
        if full:  # psmat's own message says where (SessionNotCompleted), else the file the system names
            where = next((e.filename for e in causes(exc) if getattr(e, "filename", None)), None)
            said = str(exc) if full in str(exc) else f"{where or 'a file it writes'}: {full}"
            print(f"psmat {args.command}: {' '.join(said.split())}; make room and run it again (a file it "
                  "replaces is left as it was)", file=sys.stderr)
            return 1
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

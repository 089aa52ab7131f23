"""One command line for a family of runnable modules (``python -m psmat.bench NAME``,
``python -m psmat.experiments NAME``): a name picks a module of the package, which has
``build_parser(prog)`` and ``main(argv, prog)``, imported only when asked for."""

from __future__ import annotations

import argparse
import importlib
import sys
from collections.abc import Mapping
from dataclasses import dataclass, field
from types import ModuleType

from ._help import HelpFormatter


@dataclass(frozen=True)
class Runners:
    """The runnable modules of ``package``: ``entries`` maps each name to its one-line summary;
    ``modules`` the module of a name that is not a module name (``import``, a keyword)."""

    package: str
    prog: str
    kind: str  # "benchmark", "experiment": the word the help and the errors use
    entries: Mapping[str, str]
    description: str
    modules: Mapping[str, str] = field(default_factory=dict)

    def module(self, name: str) -> ModuleType:
        if name not in self.entries:
            raise ValueError(f"unknown {self.kind} {name!r}; choose from {', '.join(self.entries)}")
        return importlib.import_module(f"{self.package}.{self.modules.get(name, name)}")

    def parser(self, name: str, prog: str | None = None) -> argparse.ArgumentParser:
        """The option parser of ``name``, its usage line starting ``prog name``."""
        return self.module(name).build_parser(f"{prog or self.prog} {name}")

    def run(self, name: str, options: list[str], prog: str | None = None) -> int:
        """Run ``name`` with its command-line ``options``; its exit status."""
        return int(self.module(name).main(options, prog=f"{prog or self.prog} {name}") or 0)

    def add_arguments(self, p: argparse.ArgumentParser) -> None:
        """NAME and the options passed on to it."""
        word = self.kind.upper()
        p.add_argument(self.kind, nargs="?", choices=tuple(self.entries), metavar=word,
                       help=f"the {self.kind} to run: {', '.join(self.entries)}")
        p.add_argument("options", nargs=argparse.REMAINDER, metavar="...",
                       help=f"the {self.kind}'s options ({word} --help lists them)")

    def main(self, argv: list[str] | None = None) -> int:
        p = argparse.ArgumentParser(prog=self.prog, description=self.description, formatter_class=HelpFormatter)
        self.add_arguments(p)
        args = p.parse_args(sys.argv[1:] if argv is None else argv)
        name = getattr(args, self.kind)
        if name is None:
            p.error(f"name a{'n' if self.kind[0] in 'aeiou' else ''} {self.kind}: {', '.join(self.entries)}")
        return self.run(name, args.options)

"""Subcommands of ``psmat``: one module per command, discovered by :mod:`psmat.cli`.

Each module defines ``NAME`` (the word typed after ``psmat``), ``HELP`` (one line),
``add_arguments(parser)`` and ``run(args) -> int`` (the exit status); ``psmat NAME --help``
shows ``DESCRIPTION`` if the module has one, else its docstring, as plain text (markup
stripped by :func:`psmat._help.plain`). Every option has a help string ending with its unit in
parentheses where it has one, e.g. ``(s)``; the default is added by the formatter. Modules
import their heavy dependencies inside ``run`` so that ``psmat --help`` stays fast.
"""

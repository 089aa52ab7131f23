"""Subcommands of ``psmat``: one module per command, discovered by :mod:`psmat.cli`.

Each module defines ``NAME`` (the word typed after ``psmat``), ``HELP`` (one line),
``add_arguments(parser)`` and ``run(args) -> int`` (the exit status). Modules import their
heavy dependencies inside ``run`` so that ``psmat --help`` stays fast.
"""

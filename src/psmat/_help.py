"""Command-line help for people: docstrings without reStructuredText markup, paragraphs and
lists kept, and every option's default shown with its unit.

Used by :mod:`psmat.cli` (every ``psmat`` command), the benchmarks (:mod:`psmat.bench`) and
the experiments that have a command line. Imports nothing but the standard library.

Conventions for a help string (``add_argument(..., help=...)``):

* the unit goes last, in parentheses: ``"recording per step (s)"``; with a default the
  formatter writes ``"recording per step (default: 1 s)"``;
* the default is not written by hand: the formatter adds ``(default: X)`` for every option whose
  default is not None, False or empty (a help string that words its default itself, e.g.
  "default: every core" for a None default, is left alone).
"""

from __future__ import annotations

import argparse
import inspect
import re
import textwrap
from typing import Any

__all__ = ["UNITS", "plain", "default_text", "HelpFormatter"]

#: Units recognised at the end of a help string, in parentheses.
UNITS = frozenset({"s", "ms", "Hz", "cm", "mm", "m", "cm²", "kPa", "Pa", "N", "kg", "V", "mV", "S", "mS", "Ω",
                   "MΩ", "°", "rad", "frames/s", "rad²"})

_ROLE = re.compile(r":(?:[a-z]+:)?[a-z]+:`~?([^`<]+?)(?:\s*<[^`>]+>)?`")  # :class:`x`, :py:func:`~a.b`, :ref:`t <x>`
_LITERAL = re.compile(r"``(.+?)``", re.S)
_LINK = re.compile(r"`([^`<]+?)\s*<[^`>]+>`__?")  # `text <url>`_
_DEFAULT_ROLE = re.compile(r"(?<![\w`])`([^`\n]+?)`(?![\w`])")  # `x` (the default role)
_STRONG = re.compile(r"\*\*(\S(?:.*?\S)?)\*\*")
_UNDERLINE = re.compile(r"^\s*([-=~^\"'`#*+])\1{2,}\s*$")  # a section title's underline
_ITEM = re.compile(r"^(\s*)([*\-•]|\d+[.)])\s+")
_COMMAND_LINE = re.compile(r"^(``[^`]+``(?::.*)?)$", re.M)
_VERBATIM = "    "  # a line indented this much (not a list item's continuation) is kept as it is
_UNIT_AT_END = re.compile(r"\s*\(([^()]{1,12})\)\s*$")


def plain(text: str | None) -> str:
    """A docstring as plain text: ``x``, :role:`x`, `x`, **x** and links become x; indentation
    removed (:func:`inspect.cleandoc`); section-title underlines kept as lines of dashes."""
    if not text:
        return ""
    # a line that is a command and nothing else (or a command and a colon-led gloss) stays a line
    # of its own: indented, so that the formatter keeps it as it is
    text = _COMMAND_LINE.sub(r"    \1", inspect.cleandoc(text))

    def role(m: re.Match[str]) -> str:
        target = m.group(1).strip()
        # Sphinx shows only the last component of a ~-prefixed target
        return target.rsplit(".", 1)[-1] if m.group(0).split("`", 1)[1].startswith("~") else target

    text = _ROLE.sub(role, text)
    text = _LINK.sub(r"\1", text)
    text = _LITERAL.sub(r"\1", text)
    text = _DEFAULT_ROLE.sub(r"\1", text)
    text = _STRONG.sub(r"\1", text)
    return text.replace("\\ ", "")


def _wrap(text: str, width: int, **kwargs: str) -> list[str]:
    """Lines of ``text`` at most ``width`` wide, never broken inside a word or at its hyphens
    (held-out, A-P and 16x16 stay whole)."""
    return textwrap.wrap(text, width, break_on_hyphens=False, break_long_words=False, **kwargs)


def _paragraphs(text: str) -> list[list[str]]:
    blocks: list[list[str]] = [[]]
    for line in text.splitlines():
        if line.strip():
            blocks[-1].append(line.rstrip())
        elif blocks[-1]:
            blocks.append([])
    return [b for b in blocks if b]


def _fill(lines: list[str], width: int, indent: str) -> list[str]:
    """One paragraph refilled to ``width``: list items (``*``, ``-``, ``1.``) each with a hanging
    indent, a section title and its underline, verbatim lines (:data:`_VERBATIM`) and a table (a
    line of ``===``) kept as they are."""
    if any(re.match(r"^\s*=+(\s+=+)+\s*$", line) for line in lines):
        return [indent + line for line in lines]
    out: list[str] = []
    chunk: list[str] = []  # the lines of the running text or of the current list item

    def flush() -> None:
        if chunk:
            item = _ITEM.match(chunk[0])
            lead = indent + (item.group(1) + item.group(2) + " " if item else "")
            words = " ".join([chunk[0][item.end():] if item else chunk[0], *chunk[1:]]).split()
            out.extend(_wrap(" ".join(words), width, initial_indent=lead,
                             subsequent_indent=" " * len(lead) if item else indent))
            chunk.clear()

    for i, line in enumerate(lines):
        if _UNDERLINE.match(line):
            continue
        if i + 1 < len(lines) and _UNDERLINE.match(lines[i + 1]):  # a section title
            flush()
            out += [indent + line.strip(), indent + "-" * len(line.strip())]
        elif line.startswith(_VERBATIM) and not (chunk and _ITEM.match(chunk[0])):
            flush()
            out.append(indent + line[len(_VERBATIM):])
        else:
            if _ITEM.match(line):
                flush()
            chunk.append(line)
    flush()
    return out


class HelpFormatter(argparse.HelpFormatter):
    """argparse's formatter with readable paragraphs and each option's default (and unit).

    Descriptions and epilogs are filled paragraph by paragraph (blank lines kept), lists item
    by item; help strings get ``(default: X)`` or, when they end with a unit in parentheses
    (:data:`UNITS`), ``(default: X unit)``.
    """

    def _fill_text(self, text: str, width: int, indent: str) -> str:
        width = max(width, 20)
        return "\n\n".join("\n".join(_fill(p, width, indent)) for p in _paragraphs(text))

    def _split_lines(self, text: str, width: int) -> list[str]:
        return _wrap(" ".join(text.split()), width)

    def _format_action(self, action: argparse.Action) -> str:
        text = super()._format_action(action)
        if isinstance(action, argparse._SubParsersAction):  # not its metavar line: the commands
            text = text.split("\n", 1)[1] if "\n" in text else ""
        return text

    def _get_help_string(self, action: argparse.Action) -> str:
        text = action.help or ""
        if "%(default)" in text:
            return text
        shown = default_text(action)
        if shown is None:
            return text
        shown = shown.replace("%", "%%")
        m = _UNIT_AT_END.search(text)
        if m and m.group(1) in UNITS:
            return f"{text[:m.start()]} (default: {shown} {m.group(1)})"
        return f"{text} (default: {shown})" if text else f"default: {shown}"


def default_text(action: argparse.Action) -> str | None:
    """How ``action``'s default reads on the command line, or None when there is nothing to show
    (no default, None, a flag, an empty list or string, a positional that must be given).

    A tuple is a shape (``16x16``); a list reads as typed: space-separated for an option that
    takes several values, else comma-separated; a float in its shortest form (``1e-07``, ``30``).
    """
    value: Any = action.default
    if value is None or value is argparse.SUPPRESS or action.nargs == 0:
        return None
    if not action.option_strings and action.nargs not in (argparse.OPTIONAL, argparse.ZERO_OR_MORE):
        return None
    if isinstance(value, (str, list, tuple)) and len(value) == 0:
        return None
    if isinstance(value, tuple):
        return "x".join(_scalar(v) for v in value)
    if isinstance(value, list):
        several = action.nargs not in (None, argparse.OPTIONAL)
        return (" " if several else ",").join(_scalar(v) for v in value)
    return _scalar(value)


def _scalar(value: Any) -> str:
    if isinstance(value, float):
        return format(value, "g")
    return str(value)

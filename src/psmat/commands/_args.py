"""Argument types shared by the subcommands: every value is parsed and checked once, by argparse.

A bad value is reported by :mod:`psmat.cli` as one line with exit status 1, before a device
is opened or a file is created.
"""

from __future__ import annotations

import argparse
import math

__all__ = ["shape", "seconds", "rate_hz", "positive_int", "tcp_port"]

#: rows and columns a mat may have: IECM needs at least 2 (docs/spec.md §3), the protocol's
#: shape fields are one byte (docs/spec.md §5)
MIN_LINES, MAX_LINES = 2, 255


def shape(text: str) -> tuple[int, int]:
    """``RxC`` (e.g. ``16x16``) → (rows, columns), each 2 ... 255."""
    parts = text.lower().split("x")
    try:
        rows, cols = (int(v) for v in parts)
    except ValueError:
        raise argparse.ArgumentTypeError(f"a shape is ROWSxCOLS, e.g. 16x16, got {text!r}") from None
    if not (MIN_LINES <= rows <= MAX_LINES and MIN_LINES <= cols <= MAX_LINES):
        raise argparse.ArgumentTypeError(f"rows and columns must be {MIN_LINES} ... {MAX_LINES}, got {text!r}")
    return rows, cols


def _positive(text: str, what: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{what} must be a number, got {text!r}") from None
    if not (math.isfinite(value) and value > 0):
        raise argparse.ArgumentTypeError(f"{what} must be > 0, got {text!r}")
    return value


def seconds(text: str) -> float:
    """A duration in s, finite and > 0."""
    return _positive(text, "a duration in seconds")


def rate_hz(text: str) -> float:
    """A frame rate in Hz, finite and > 0."""
    return _positive(text, "a rate in Hz")


def positive_int(text: str) -> int:
    """An integer >= 1."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be an integer, got {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be >= 1, got {text!r}")
    return value


def tcp_port(text: str) -> int:
    """A TCP port number 0 ... 65535 (0: a free one the system picks)."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"a TCP port is an integer 0 ... 65535, got {text!r}") from None
    if not 0 <= value <= 65535:
        raise argparse.ArgumentTypeError(f"a TCP port is 0 ... 65535, got {text!r}")
    return value

"""Argument types shared by the subcommands: every value is parsed and checked once, by argparse.

A bad value is reported by :mod:`psmat.cli` as one line with exit status 1, before a device
is opened or a file is created.
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

__all__ = ["shape", "seconds", "speed", "session_seconds", "rate_hz", "positive_int", "tcp_port", "nonnegative",
           "conductance", "input_file", "figure_file", "twin_shape_problem", "bits", "TWIN_MAX_LINES",
           "IMU_MAX_RATE_HZ"]

#: rows and columns a mat may have: IECM needs at least 2 (docs/spec.md §3), the protocol's
#: shape fields are one byte (docs/spec.md §5)
MIN_LINES, MAX_LINES = 2, 255
#: rows and columns of the digital twin: it runs the PSM firmware's core, whose frame buffer
#: holds at most 64 x 64 cells (firmware/core/psm_core.h, ``PSM_MAX_ROWS``, ``PSM_MAX_COLS``)
TWIN_MAX_LINES = 64
#: the spine IMUs' fastest rate (Hz): the BNO055's fusion output (firmware/core/imu_core.h, ``IMU_RATE_MAX``)
IMU_MAX_RATE_HZ = 100


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


def speed(text: str) -> float:
    """A replay speed: recorded seconds per second, finite and > 0 (2 = twice as fast)."""
    return _positive(text, "a replay speed")


def rate_hz(text: str) -> float:
    """A frame rate in Hz: a whole number of frames per second, 1 ... 1000 (the PSM firmware's
    SET_RATE range, :data:`psmat._checks.MAX_RATE_HZ`)."""
    from .. import _checks  # here: numpy, which it needs, is not loaded for psmat --help

    return _checked(_checks.rate_hz, "a rate", _number(text, "a rate in Hz"), whole=True)


def session_seconds(text: str) -> float:
    """The length of a simulated session in s: finite, > 0 and at most an hour
    (:data:`psmat._checks.MAX_SESSION_S`)."""
    from .. import _checks

    return _checked(_checks.duration_s, "a duration", _number(text, "a duration in seconds"))


def nonnegative(text: str) -> float:
    """A finite number >= 0 (a noise level, ...)."""
    value = _number(text, "the value")
    if not (math.isfinite(value) and value >= 0):
        raise argparse.ArgumentTypeError(f"must be a finite number >= 0, got {text!r}")
    return value


def conductance(text: str) -> float:
    """A conductance in S, finite and >= 0."""
    value = _number(text, "a conductance in S")
    if not (math.isfinite(value) and value >= 0):
        raise argparse.ArgumentTypeError(f"a conductance must be a finite number >= 0 S, got {text!r}")
    return value


def input_file(text: str) -> str:
    """A file that exists and is a file (not a folder); the path as given."""
    path = Path(text)
    if path.is_dir():
        raise argparse.ArgumentTypeError(f"{text} is a folder, not a file")
    if not path.is_file():
        raise argparse.ArgumentTypeError(f"no such file: {text}")
    return text


def figure_file(text: str) -> str:
    """A figure's file name whose suffix is a format matplotlib writes (.png, .pdf, .svg, ...)."""
    from matplotlib.backend_bases import FigureCanvasBase

    formats = sorted(FigureCanvasBase.get_supported_filetypes())
    suffix = Path(text).suffix.lower().lstrip(".")
    if suffix not in formats:
        got = f"'.{suffix}'" if suffix else "no suffix"
        raise argparse.ArgumentTypeError(f"a figure file's suffix names its format, one of "
                                         f"{', '.join('.' + f for f in formats)}; {text!r} has {got}")
    return text


def twin_shape_problem(shape: tuple[int, int]) -> str | None:
    """Why the digital twin cannot be ``shape`` (rows, columns), as one line, or None."""
    rows, cols = shape
    if rows > TWIN_MAX_LINES or cols > TWIN_MAX_LINES:
        return (f"the simulated mat has at most {TWIN_MAX_LINES}x{TWIN_MAX_LINES} cells (the PSM firmware's frame "
                f"buffer), got --shape {rows}x{cols}")
    return None


def _number(text: str, what: str) -> float:
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{what} must be a number, got {text!r}") from None


def _checked(check: Callable[..., float], name: str, value: float, **kwargs: Any) -> float:
    """``check(name, value, **kwargs)`` (:mod:`psmat._checks`) with its ValueError as argparse's error."""
    try:
        return check(name, value, **kwargs)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def bits(text: str) -> int:
    """ADC resolution (bits), an integer 1 ... 16."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be an integer 1 ... 16, got {text!r}") from None
    if not 1 <= value <= 16:
        raise argparse.ArgumentTypeError(f"must be 1 ... 16, got {text!r}")
    return value


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

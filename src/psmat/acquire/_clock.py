"""Host wall clock that cannot jump: ``time.time()`` anchored once, advanced by ``time.monotonic()``."""

from __future__ import annotations

import time
from typing import Callable

__all__ = ["HostClock"]


class HostClock:
    """Wall-clock seconds (Unix epoch) that advance monotonically.

    Parameters
    ----------
    wall, mono : callable, optional
        Clock sources (injectable for tests); default :func:`time.time` and
        :func:`time.monotonic`.

    Notes
    -----
    ``now() = wall0 + (mono() - mono0)``: reads like ``time.time()`` but NTP steps or a
    user changing the clock during a recording do not make frame times go backwards.
    """

    def __init__(self, wall: Callable[[], float] = time.time, mono: Callable[[], float] = time.monotonic) -> None:
        self._mono = mono
        self._mono0 = mono()
        self._wall0 = wall()

    def now(self) -> float:
        """Current host time (s since the Unix epoch, monotonic)."""
        return self._wall0 + (self._mono() - self._mono0)

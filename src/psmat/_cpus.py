"""The CPUs this process may run on, on every system."""

from __future__ import annotations

import os

__all__ = ["usable_cpus"]


def usable_cpus() -> int:
    """CPUs this process may use: its affinity mask where the system has one (Linux), else
    every logical CPU (``os.cpu_count``; Windows, macOS); at least 1."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except (AttributeError, OSError):
        return os.cpu_count() or 1

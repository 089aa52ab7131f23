"""The machine a benchmark ran on, printed and stored with its figures (every ``python -m psmat.bench`` benchmark)."""

from __future__ import annotations

import datetime
import os
import platform

import numpy as np

__all__ = ["machine_info"]


def machine_info() -> dict:
    """CPU model, cores, versions and date of this run."""
    model = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.lower().startswith("model name"):
                    model = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    try:
        usable = len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        usable = os.cpu_count() or 1
    try:
        import scipy

        scipy_version = scipy.__version__
    except ImportError:  # pragma: no cover - scipy is a bench/test requirement
        scipy_version = "not installed"
    try:
        from importlib.metadata import version

        psmat_version = version("psmat")
    except Exception:  # pragma: no cover
        psmat_version = "unknown"
    try:
        from .. import _core

        simd = _core.iecm.simd_kernels()
    except Exception:  # pragma: no cover - an extension without it
        simd = "unknown"
    return {
        "cpu": model,
        "logical_cpus": os.cpu_count(),
        "usable_cpus": usable,
        "platform": platform.platform(),
        "python": platform.python_version(),
        "numpy": np.__version__,
        "scipy": scipy_version,
        "psmat": psmat_version,
        "psmat_simd": simd,
        "date": datetime.datetime.now().astimezone().isoformat(timespec="seconds"),
    }

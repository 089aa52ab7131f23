"""Freed memory kept by a pool's worker process for its next task (glibc's allocator).

A study's session allocates and frees arrays of megabytes many times (one copy of a 60 s trial
of a 16×16 mat at 100 Hz is 12 MB). glibc's malloc maps a block above its mmap threshold
afresh and gives the top of its heap back to the system once more than its trim threshold is
free there; both thresholds adapt to the blocks freed so far, but a session's peaks still leave
the heap and come back: every page that comes back is a page fault on first touch, zeroed by the
kernel. Measured on this project's 2-core machine (a simulated thesis-size study, four sessions a
process after one to warm up, four processes each way, alternating): 24 000 page faults and
0.12-0.16 s of system time a session, 2.79-2.90 s of CPU, against 320-480 faults, 0.004-0.007 s and
2.63-2.66 s with these settings (given as the environment variables below; the function itself,
once: 367 faults and 0.006 s a session); the processes' peak resident memory did not change (276
MB against 271 MB).

:func:`keep_freed_memory` raises the mmap threshold to the largest glibc accepts on 64-bit
systems (32 MiB) and the trim threshold to 1 GiB: a worker keeps the memory of its largest task
and reuses it. It is what ``MALLOC_MMAP_THRESHOLD_=33554432 MALLOC_TRIM_THRESHOLD_=1073741824``
in a process's environment does (:data:`ENVIRONMENT`, for workers psmat does not start: a Dask
cluster's). Other C libraries have no ``mallopt``: nothing is changed there. Imports nothing but
the standard library.
"""

from __future__ import annotations

import ctypes
import sys

__all__ = ["MMAP_THRESHOLD", "TRIM_THRESHOLD", "ENVIRONMENT", "keep_freed_memory"]

#: blocks below this (bytes) come from the heap: glibc's largest mmap threshold on 64-bit systems
MMAP_THRESHOLD = 32 << 20
#: free memory at the top of the heap kept up to this (bytes)
TRIM_THRESHOLD = 1 << 30
#: the same settings as environment variables of a process that is to start with them
ENVIRONMENT = {"MALLOC_MMAP_THRESHOLD_": str(MMAP_THRESHOLD), "MALLOC_TRIM_THRESHOLD_": str(TRIM_THRESHOLD)}

# mallopt's parameters (glibc's malloc.h)
_M_TRIM_THRESHOLD = -1
_M_MMAP_THRESHOLD = -3


def keep_freed_memory() -> bool:
    """Set this process's allocator to keep freed memory (module docstring); True where it did
    (glibc on Linux), False elsewhere, where nothing changes."""
    if not sys.platform.startswith("linux"):
        return False
    try:
        mallopt = ctypes.CDLL(None).mallopt
    except (OSError, AttributeError):  # no C library symbols in this process, or a C library without mallopt
        return False
    mallopt.argtypes = (ctypes.c_int, ctypes.c_int)
    mallopt.restype = ctypes.c_int
    return bool(mallopt(_M_MMAP_THRESHOLD, MMAP_THRESHOLD)) and bool(mallopt(_M_TRIM_THRESHOLD, TRIM_THRESHOLD))

"""A simulated mat on a real pseudo-terminal, for the tests that read it: ``psmat simulate`` in a child
process, its port yielded, stopped by SIGTERM. :func:`csv_twin`: a do-it-yourself mat speaking the csv
protocol; :func:`box_twin`: the thesis' box (v1/v2, takes commands)."""

from __future__ import annotations

import contextlib
import signal
import subprocess
import sys
from collections.abc import Iterator

from conftest import child_preexec


@contextlib.contextmanager
def box_twin(*options: str, protocol: str = "v2", rate_hz: float = 100.0) -> Iterator[str]:
    """The port of ``psmat simulate --protocol PROTOCOL --rate RATE_HZ OPTIONS``."""
    proc = subprocess.Popen([sys.executable, "-m", "psmat", "simulate", "--protocol", protocol, "--rate",
                             f"{rate_hz:g}", *options], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            preexec_fn=child_preexec())
    try:
        port = proc.stdout.readline().strip()
        assert port, proc.communicate()
        yield port
    finally:
        proc.send_signal(signal.SIGTERM)
        proc.communicate(timeout=60)


def csv_twin(*options: str, rate_hz: float = 100.0) -> contextlib.AbstractContextManager[str]:
    """The port of ``psmat simulate --protocol csv --rate RATE_HZ OPTIONS`` (``--profile psm16``: a 12-bit board;
    none: the 10-bit arduino16)."""
    return box_twin(*options, protocol="csv", rate_hz=rate_hz)

"""Headless Chromium for the browser tests: the driver :mod:`psmat.bench.chromium` (one home for
the code; the lab benchmark uses it too) and a fixture helper that skips, with its reason, where
there is no Chromium (``.ci/run`` installs Debian's ``chromium`` when it runs as root).
"""

from __future__ import annotations

import pytest

from psmat.bench.chromium import Chromium, ChromiumError, find_chromium

__all__ = ["Chromium", "ChromiumError", "find_chromium", "chromium_or_skip"]


def chromium_or_skip() -> str:
    """The Chromium executable, or skip the test saying why (none on PATH, no ``websockets``)."""
    pytest.importorskip("websockets", reason="the DevTools driver needs the websockets package (the test extra)")
    exe = find_chromium()
    if exe is None:
        pytest.skip("no Chromium on PATH (Debian: apt-get install chromium; or set PSMAT_CHROMIUM)")
    return exe

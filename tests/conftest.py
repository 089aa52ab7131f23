"""Shared test helpers: the independent reference vectors in ``tests/data/reference`` and fixtures.

Everything the tests read lives in the repository: the reference vectors under
``tests/data/reference`` (see its README) and the BDS force-platform trials shipped with the
package (``psmat.io.bds_dir()``).
"""

from __future__ import annotations

import json
import os
import signal
from collections.abc import Callable
from pathlib import Path

# One BLAS thread, here and in every process a test starts (they inherit it), unless the caller
# chose: OpenBLAS's threads spin while they wait, and on a 2-core machine with other work
# running (the suite's own subprocesses, or anyone else's) an SVD of a 1100 x 256 matrix took
# 1-4 s with two threads against 0.03 s with one. Set before numpy is first imported.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402 (after the BLAS setting above)
import pytest  # noqa: E402

from psmat._orphans import parent_death_preexec  # noqa: E402

#: ``tests/data`` in the repository (this file is ``<root>/tests/conftest.py``).
DATA_DIR = Path(__file__).resolve().parent / "data"


def child_preexec() -> Callable[[], None]:
    """The ``preexec_fn`` for a child a test starts (``psmat lab``, ``psmat simulate``, ``psmat record``...):
    ``Popen(..., preexec_fn=child_preexec())``, made in the process that starts the child.

    * The default handling of SIGINT, SIGHUP and SIGTERM: a process started in the background by a
      non-interactive shell ignores SIGINT, and one under ``nohup`` ignores SIGHUP; a child inherits
      that, and Python keeps an ignored signal ignored, so without this the child never sees the
      signal the test sends.
    * On Linux, SIGTERM when the test process dies (``PR_SET_PDEATHSIG``,
      :func:`psmat._orphans.parent_death_preexec`): a pytest killed outright never reaches the
      ``finally`` clauses that stop its children, and a ``psmat lab --simulate`` would otherwise serve
      its twin for hours. The signal follows the thread that started the child, so the tests start
      them from their main thread.
    """
    arm = parent_death_preexec()

    def preexec() -> None:
        for name in ("SIGINT", "SIGHUP", "SIGTERM"):
            if hasattr(signal, name):
                signal.signal(getattr(signal, name), signal.SIG_DFL)
        if arm is not None:
            arm()
    return preexec


def load_reference(name: str) -> dict:
    """The reference vectors ``tests/data/reference/<name>`` (JSON)."""
    return json.loads((DATA_DIR / "reference" / name).read_text(encoding="utf-8"))


@pytest.fixture(scope="session")
def iecm_reference() -> dict:
    return load_reference("iecm_forward.json")["cases"]


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(12345)

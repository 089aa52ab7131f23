"""Shared test helpers: the independent reference vectors in ``tests/data/reference`` and fixtures.

Everything the tests read lives in the repository: the reference vectors under
``tests/data/reference`` (see its README) and the BDS force-platform trials shipped with the
package (``psmat.io.bds_dir()``).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

#: ``tests/data`` in the repository (this file is ``<root>/tests/conftest.py``).
DATA_DIR = Path(__file__).resolve().parent / "data"


def load_reference(name: str) -> dict:
    """The reference vectors ``tests/data/reference/<name>`` (JSON)."""
    return json.loads((DATA_DIR / "reference" / name).read_text(encoding="utf-8"))


@pytest.fixture(scope="session")
def iecm_reference() -> dict:
    return load_reference("iecm_forward.json")["cases"]


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(12345)

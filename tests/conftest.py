"""Shared test helpers: the ``shared/`` folder beside the repository (reference vectors of an
independent implementation, the BDS data), and fixtures.

Every test that reads ``shared/`` goes through :func:`shared_path`, which skips the test, with
the path it looked for, when the folder or the file is not there (a clone on its own).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

#: ``shared/`` beside the repository root (this file is ``<root>/tests/conftest.py``).
SHARED_DIR = Path(__file__).resolve().parents[2] / "shared"


def shared_path(*parts: str) -> Path:
    """``shared/<parts...>`` beside the repository; skips the calling test when it is absent."""
    path = SHARED_DIR.joinpath(*parts)
    if not path.exists():
        pytest.skip(f"{path} not found: the reference vectors and data live in shared/ beside the repository")
    return path


def load_reference(name: str) -> dict:
    """The reference vectors ``shared/reference/<name>`` (JSON)."""
    return json.loads(shared_path("reference", name).read_text())


@pytest.fixture(scope="session")
def iecm_reference() -> dict:
    return load_reference("iecm_forward.json")["cases"]


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(12345)

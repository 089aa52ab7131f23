"""Shared fixtures: the reference vectors of ../shared/reference (independent implementation)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

REFERENCE_DIR = Path(__file__).resolve().parents[2] / "shared" / "reference"


def load_reference(name: str) -> dict:
    path = REFERENCE_DIR / name
    if not path.is_file():
        pytest.fail(f"reference vectors missing: {path} (the repository expects ../shared beside it)")
    return json.loads(path.read_text())


@pytest.fixture(scope="session")
def iecm_reference() -> dict:
    return load_reference("iecm_forward.json")["cases"]


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(12345)

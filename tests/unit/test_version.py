"""The version is written in one place, ``src/psmat/_version.py``: the build reads it from there
(pyproject.toml's ``[tool.scikit-build.metadata.version]``, scikit-build-core's regex provider)
and :data:`psmat.__version__` imports it; pyproject.toml does not write it."""

from __future__ import annotations

import re
import sys
from pathlib import Path
from typing import Any

import pytest

import psmat

ROOT = Path(__file__).resolve().parents[2]
if sys.version_info >= (3, 11):
    import tomllib
else:  # Python 3.10
    tomllib = pytest.importorskip("tomli")


def _pyproject() -> dict[str, Any]:
    return tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))


def _strings(node: Any) -> list[str]:
    if isinstance(node, dict):
        return [s for v in node.values() for s in _strings(v)]
    if isinstance(node, list):
        return [s for v in node for s in _strings(v)]
    return [node] if isinstance(node, str) else []


def test_pyproject_does_not_write_the_version() -> None:
    doc = _pyproject()
    assert "version" not in doc["project"] and "version" in doc["project"]["dynamic"]
    assert psmat.__version__ not in _strings(doc), "a string of pyproject.toml is the version itself"
    settings = doc["tool"]["scikit-build"]["metadata"]["version"]
    assert settings["provider"] == "scikit_build_core.metadata.regex"
    assert (ROOT / settings["input"]).resolve() == (ROOT / "src" / "psmat" / "_version.py").resolve()


def test_the_build_reads_the_version_psmat_reports(monkeypatch: pytest.MonkeyPatch) -> None:
    """The build backend's own provider, run on the repository, finds ``psmat.__version__``."""
    from scikit_build_core.metadata import regex  # a test requirement (pyproject.toml, extra "test")
    monkeypatch.chdir(ROOT)  # the provider's input is relative to the project
    settings = {k: v for k, v in _pyproject()["tool"]["scikit-build"]["metadata"]["version"].items()
                if k != "provider"}
    assert regex.dynamic_metadata("version", settings) == psmat.__version__


def test_the_version_is_written_once_in_the_package() -> None:
    assignments = [p for p in (ROOT / "src" / "psmat").rglob("*.py")
                   if re.search(r"^__version__\s*=", p.read_text(encoding="utf-8"), re.M)]
    assert assignments == [ROOT / "src" / "psmat" / "_version.py"]
    assert re.fullmatch(r"\d+\.\d+\.\d+\S*", psmat.__version__)

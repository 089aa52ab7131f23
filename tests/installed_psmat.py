"""Helpers of tests/e2e/test_wheel.py: the installation of psmat those tests run, and the test extras
hidden from its commands.

* :func:`regular_installation`: the psmat that runs the tests, when it is a regular (not
  editable) install of a wheel, as ``pip install ".[test]"`` (the README's test command) makes.
* :func:`hidden_modules` / :func:`write_hider`: the top-level modules of the distributions that
  only the ``test`` extra brings (pytest, torch, dask, psutil, ...), and a ``sitecustomize.py``
  that makes them unimportable, so that a command run with it fails on an import of one of them
  as it would for a user who installed psmat alone.
"""

from __future__ import annotations

import base64
import hashlib
import importlib.metadata as md
import json
from pathlib import Path

from packaging.requirements import Requirement
from packaging.utils import canonicalize_name

__all__ = ["regular_installation", "requirement_closure", "hidden_modules", "write_hider", "record_hash"]


def regular_installation(root: Path) -> md.Distribution | None:
    """The distribution of the psmat running the tests when it is a regular install, else None.

    Regular: its ``direct_url.json`` (PEP 610) does not mark it editable, and the package is
    imported from outside ``root`` (the repository).
    """
    import psmat

    dist = md.distribution("psmat")
    direct = dist.read_text("direct_url.json")
    if direct and json.loads(direct).get("dir_info", {}).get("editable", False):
        return None
    if Path(psmat.__file__).resolve().is_relative_to(root.resolve()):
        return None
    return dist


def requirement_closure(name: str, extra: str = "") -> set[str]:
    """Canonical names of ``name`` and of every installed distribution it requires, recursively.

    ``extra`` selects the requirements of ``name[extra]``; the requirements of a dependency are
    those of its plain install plus the extras the requirement names.
    """
    seen: set[tuple[str, str]] = set()
    todo = [(canonicalize_name(name), extra)]
    found: set[str] = set()
    while todo:
        dist_name, dist_extra = todo.pop()
        if (dist_name, dist_extra) in seen:
            continue
        seen.add((dist_name, dist_extra))
        try:
            requires = md.distribution(dist_name).requires or []
        except md.PackageNotFoundError:  # a requirement for another platform or Python
            continue
        found.add(dist_name)
        for text in requires:
            req = Requirement(text)
            if req.marker is not None and not req.marker.evaluate({"extra": dist_extra}):
                continue
            todo.append((canonicalize_name(req.name), ""))
            todo.extend((canonicalize_name(req.name), canonicalize_name(e)) for e in req.extras)
    return found


def hidden_modules(name: str = "psmat", extra: str = "test") -> set[str]:
    """Top-level modules that belong only to distributions ``name[extra]`` needs and ``name`` does not."""
    test_only = requirement_closure(name, extra) - requirement_closure(name)
    return {top for top, dists in md.packages_distributions().items()
            if dists and all(canonicalize_name(d) in test_only for d in dists)}


_HIDER = '''"""Written by tests/installed_psmat.py: the modules of the test extras are not importable."""
import sys
from importlib.abc import MetaPathFinder

HIDDEN = frozenset({names!r})


class _Hidden(MetaPathFinder):
    def find_spec(self, fullname, path=None, target=None):
        if fullname.partition(".")[0] in HIDDEN:
            raise ModuleNotFoundError(f"No module named {{fullname!r}} (test extra hidden)", name=fullname)
        return None


sys.meta_path.insert(0, _Hidden())
'''


def write_hider(folder: Path, names: set[str]) -> Path:
    """Write ``folder/sitecustomize.py`` hiding ``names``; put ``folder`` on PYTHONPATH to use it."""
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / "sitecustomize.py"
    path.write_text(_HIDER.format(names=sorted(names)), encoding="utf-8")
    return path


def record_hash(path: Path) -> str:
    """``sha256=<urlsafe base64, no padding>`` of a file, as a wheel's RECORD writes it (PEP 376/427)."""
    digest = hashlib.sha256(path.read_bytes()).digest()
    return "sha256=" + base64.urlsafe_b64encode(digest).rstrip(b"=").decode("ascii")

"""What ``import psmat`` and ``psmat --help`` load: only what they use (docs/architecture.md, "Import cost").

Each check runs a fresh Python process with ``-X importtime``, which lists every module the
process imports, and compares it with a process that imports nothing (``python -c pass``), so
that whatever the interpreter's own start loads (a ``.pth`` file, a sitecustomize) is not
counted against psmat. Nothing here is timed: ``python -m psmat.bench import`` gives the times.
"""

from __future__ import annotations

import subprocess
import sys

import pytest

import psmat

#: heavy libraries that neither ``import psmat`` nor the command line's help may load
HEAVY = ("scipy.signal", "matplotlib", "h5py", "torch", "dask", "distributed", "sklearn", "serial")


def _imported(*args: str) -> tuple[set[str], str]:
    """The modules a fresh ``python -X importtime ARGS`` imports, and what it printed."""
    p = subprocess.run([sys.executable, "-X", "importtime", *args], capture_output=True, text=True, timeout=120)
    assert p.returncode == 0, p.stderr[-2000:]
    names = {line.split("|")[2].strip() for line in p.stderr.splitlines() if line.startswith("import time:")}
    names.discard("imported package")  # the header line: "import time: self [us] | cumulative | imported package"
    return names, p.stdout


@pytest.fixture(scope="module")
def startup() -> set[str]:
    """What the interpreter imports by itself, before any psmat code runs."""
    return _imported("-c", "pass")[0]


def _heavy(names: set[str]) -> list[str]:
    return sorted(n for n in names if any(n == h or n.startswith(h + ".") for h in HEAVY))


def test_importtime_lists_what_a_process_imports(startup: set[str]) -> None:
    """The check can fail: a process that does import h5py is seen to."""
    names, _ = _imported("-c", "import h5py")
    assert "h5py" in names - startup and _heavy(names - startup)


def test_import_psmat_loads_nothing_but_its_version(startup: set[str]) -> None:
    names, _ = _imported("-c", "import psmat")
    added = names - startup
    assert _heavy(added) == []
    assert sorted(n for n in added if n.startswith("psmat")) == ["psmat", "psmat._version"]
    assert "numpy" not in added


@pytest.mark.parametrize("argv", [["--help"], ["--version"], ["info", "--help"], ["record", "--help"],
                                  ["view", "--help"], ["bench", "--help"]], ids=" ".join)
def test_the_command_line_help_loads_no_heavy_library(startup: set[str], argv: list[str]) -> None:
    names, out = _imported("-m", "psmat", *argv)
    assert out.startswith("usage: psmat") or out.startswith("psmat ")
    assert _heavy(names - startup) == []
    assert "numpy" not in names - startup  # listing the commands needs none of psmat's numerics


def test_a_subpackage_is_imported_when_first_used() -> None:
    # thesis framing: FF FF, the cells little-endian, their sum (1+2+3+4 = 10) mod 4096
    code = ("import sys, psmat\n"
            "assert 'psmat.protocol' not in sys.modules\n"
            "assert psmat.protocol.encode_v1([[1, 2], [3, 4]]) == bytes.fromhex('ffff 0100 0200 0300 0400 0a00')\n"
            "assert 'psmat.protocol' in sys.modules and 'psmat.circuit' not in sys.modules\n"
            "assert psmat.Circuit.__name__ == 'Circuit' and 'psmat.circuit' in sys.modules\n"
            "from psmat import io\n"
            "assert io is sys.modules['psmat.io']\n")
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert p.returncode == 0, p.stderr[-2000:]


def test_every_public_name_resolves_and_is_listed() -> None:
    for name in psmat.__all__:
        assert getattr(psmat, name) is not None, name
    assert set(psmat.__all__) <= set(dir(psmat))
    assert psmat.Calibration.__module__ == "psmat.circuit._calibration" and psmat.Circuit.__module__ == "psmat.circuit._circuit"
    with pytest.raises(AttributeError, match="no attribute 'no_such_thing'"):
        psmat.no_such_thing  # noqa: B018

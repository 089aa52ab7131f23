"""The wheel as a user gets it: built from this tree, installed with its dependencies into a
fresh virtual environment, run with nothing else reachable.

The commands run with PATH reduced to the environment's ``bin`` (no compiler, no other
Python) from an empty directory outside the repository, so the package, its compiled core and
the force-platform data the demo follows can only come from the installed wheel.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
import venv
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"      # PNG specification, §5.2
HDF5_SIGNATURE = b"\x89HDF\r\n\x1a\n"     # HDF5 file format specification, superblock at offset 0
DEMO_SECONDS, DEMO_RATE_HZ = 2.0, 100


def _run(cmd: list[str], *, timeout: float, **kw) -> subprocess.CompletedProcess:
    """Run ``cmd``; fail the test with its output when it exits non-zero."""
    out = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, **kw)
    if out.returncode != 0:
        pytest.fail(f"{' '.join(map(str, cmd))} exited {out.returncode}\n--- stdout\n{out.stdout[-4000:]}"
                    f"\n--- stderr\n{out.stderr[-4000:]}")
    return out


def _checkout_version() -> str:
    """The version written in src/psmat/_version.py, read as text (not imported)."""
    text = (ROOT / "src" / "psmat" / "_version.py").read_text()
    return re.search(r'^__version__ = "([^"]+)"', text, re.MULTILINE).group(1)


@pytest.fixture(scope="module")
def installed(tmp_path_factory) -> dict:
    """A wheel built from the tree and installed, with its dependencies, into a fresh venv."""
    tmp = tmp_path_factory.mktemp("wheel")
    # A build folder of its own: the tree's build/ belongs to the developers' editable install.
    _run([sys.executable, "-m", "pip", "wheel", str(ROOT), "--no-deps", "-w", str(tmp / "dist"),
          "-C", f"build-dir={tmp / 'build'}"], timeout=1800)
    wheels = sorted((tmp / "dist").glob("psmat-*.whl"))
    assert len(wheels) == 1, wheels
    env_dir = tmp / "venv"
    venv.create(env_dir, with_pip=True, clear=True)
    bin_dir = env_dir / ("Scripts" if os.name == "nt" else "bin")
    python = bin_dir / ("python.exe" if os.name == "nt" else "python")
    _run([str(python), "-m", "pip", "install", "--disable-pip-version-check", str(wheels[0])], timeout=1800)
    home = tmp / "home"
    home.mkdir()
    user_env = {"PATH": str(bin_dir), "HOME": str(home), "MPLBACKEND": "Agg", "LC_ALL": "C.UTF-8"}
    if os.name == "nt":  # pragma: no cover - Windows needs its system root to start Python
        user_env["SYSTEMROOT"] = os.environ.get("SYSTEMROOT", r"C:\Windows")
    return dict(wheel=wheels[0], prefix=env_dir.resolve(), python=python, env=user_env, tmp=tmp)


def _in_venv(installed: dict, args: list[str], cwd: Path, timeout: float = 600) -> str:
    cwd.mkdir(exist_ok=True)
    return _run(args, cwd=cwd, env=installed["env"], timeout=timeout).stdout


@pytest.mark.slow
def test_the_installed_package_is_the_wheels(installed):
    out = _in_venv(installed, ["python", "-c",
                               "import importlib.metadata as m, psmat, psmat._core; "
                               "print(psmat.__file__); print(psmat._core.__file__); "
                               "print(psmat.__version__); print(m.version('psmat'))"], installed["tmp"] / "run0")
    pkg, core, version, metadata_version = out.splitlines()[-4:]
    for path in (pkg, core):
        assert Path(path).resolve().is_relative_to(installed["prefix"]), path
        assert not Path(path).resolve().is_relative_to(ROOT), path
    # one version: the metadata the wheel was built with, psmat.__version__ and the checkout's file
    assert version == metadata_version == _checkout_version()


@pytest.mark.slow
def test_psmat_version_prints_the_version(installed):
    out = _in_venv(installed, ["psmat", "--version"], installed["tmp"] / "run1")
    assert _checkout_version() in out


@pytest.mark.slow
def test_psmat_demo_records_processes_and_plots(installed):
    cwd = installed["tmp"] / "run2"
    out = _in_venv(installed, ["psmat", "demo", "--twin", "--seconds", str(DEMO_SECONDS), "--rate",
                               str(DEMO_RATE_HZ), "--out", "demo.png", "--session", "demo.h5"], cwd)
    m = re.search(r"recorded demo\.h5: (\d+) frames, (\d+) invalid, (\d+) lost on the wire", out)
    assert m, out
    frames, invalid, lost = map(int, m.groups())
    # the twin streams at the requested rate over a clean pty: about seconds x rate frames, none bad
    assert 0.5 * DEMO_SECONDS * DEMO_RATE_HZ <= frames <= 1.5 * DEMO_SECONDS * DEMO_RATE_HZ + 20, out
    assert invalid == 0 and lost == 0, out
    # crosstalk removal + the sensor model bring the CoP closer to the force platform than raw G
    cop = re.search(r"raw G ([\d.]+) -> IECM \+ sensor model ([\d.]+)", out)
    assert cop, out
    assert float(cop.group(2)) < float(cop.group(1)), out
    assert (cwd / "demo.png").read_bytes()[:8] == PNG_SIGNATURE
    assert (cwd / "demo.h5").read_bytes()[:8] == HDF5_SIGNATURE


@pytest.mark.slow
def test_compare_native_measures_each_build_in_its_own_environment(installed, tmp_path):
    # Two environments with their own psmat._core: the wheel's venv and the one running the tests.
    import psmat._core

    cmd = [sys.executable, "-m", "psmat.bench", "iecm", "--compare-native", str(installed["python"]),
           sys.executable, "--sizes", "8", "--frames", "8", "--repeats", "1", "--quick"]
    out = _run(cmd, cwd=tmp_path, timeout=600).stdout
    lines = out.splitlines()
    portable = next(line for line in lines if line.startswith("portable: "))
    native = next(line for line in lines if line.startswith("native: "))
    assert str(installed["prefix"]) in portable
    assert str(Path(psmat._core.__file__).parent) in native
    rows = [line for line in lines if line.startswith("| 8x8 |")]
    assert len(rows) == 2 and "noisy G" in rows[1], out
    # the same interpreter twice is one build, not two: refused with one line
    same = subprocess.run(cmd[:6] + [str(installed["python"])] + cmd[7:], cwd=tmp_path, capture_output=True,
                          text=True, timeout=600)
    assert same.returncode == 1
    assert "the builds import the same psmat._core" in same.stderr.strip().splitlines()[-1]

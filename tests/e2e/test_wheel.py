"""The package as a user gets it: psmat installed from a wheel of this tree, run with nothing
else reachable.

Which installation the tests run:

* the psmat that runs the tests, when it is a regular install of a wheel (the README's test
  command, ``pip install ".[test]"``, builds a wheel from this tree and installs it): the tests
  check that its files are this tree's, byte for byte, and run it;
* otherwise (an editable install, a developer's tree): a wheel built from the tree and
  installed, with its dependencies, into a fresh virtual environment.

The commands run with PATH reduced to the folder of the installed ``psmat`` script (no compiler,
no other Python) from an empty directory outside the repository, so the package, its compiled
core and the force-platform data the demo follows can only come from the installation. Every
module of a distribution that only the ``test`` extra brings (pytest, torch, dask, psutil, ...)
is made unimportable in the commands (tests/installed_psmat.py), so a command that needs one
fails as it would for a user who installed psmat alone.

What the first case does not show: that pip installs the wheel into an empty environment; the
README's test command has just done that, with the versions of the dependencies that the test
extras allow.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
import sysconfig
import venv
from pathlib import Path

import pytest
from installed_psmat import hidden_modules, record_hash, regular_installation, write_hider

ROOT = Path(__file__).resolve().parents[2]
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


def _fresh_venv(tmp: Path) -> tuple[Path, Path, Path]:
    """A wheel built from the tree, installed with its dependencies into a fresh venv: (python, bin, prefix)."""
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
    return python, bin_dir, env_dir.resolve()


@pytest.fixture(scope="module")
def installed(tmp_path_factory) -> dict:
    """The installation the tests run (module docstring) and the environment of its commands."""
    tmp = tmp_path_factory.mktemp("wheel")
    dist = regular_installation(ROOT)
    if dist is None:
        python, bin_dir, prefix = _fresh_venv(tmp)
    else:
        script = next(f for f in dist.files if f.stem == "psmat" and f.parent.name in ("bin", "Scripts"))
        python, bin_dir = Path(sys.executable), Path(dist.locate_file(script)).resolve().parent
        prefix = Path(dist.locate_file("")).resolve()  # the site-packages folder holding psmat
    home = tmp / "home"
    home.mkdir()
    hider = write_hider(tmp / "hide_test_extras", hidden_modules())
    user_env = {"PATH": str(bin_dir), "HOME": str(home), "MPLBACKEND": "Agg", "LC_ALL": "C.UTF-8",
                "PYTHONPATH": str(hider.parent)}
    if os.name == "nt":  # pragma: no cover - Windows needs its system root to start Python
        user_env["SYSTEMROOT"] = os.environ.get("SYSTEMROOT", r"C:\Windows")
    return dict(reused=dist is not None, prefix=prefix, python=python, env=user_env, tmp=tmp)


def _in_venv(installed: dict, args: list[str], cwd: Path, timeout: float = 600) -> str:
    cwd.mkdir(exist_ok=True)
    return _run(args, cwd=cwd, env=installed["env"], timeout=timeout).stdout


@pytest.mark.slow
def test_the_installed_package_is_the_wheels(installed):
    out = _in_venv(installed, [str(installed["python"]), "-c",
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
def test_the_installed_files_are_the_trees_and_the_compiled_core(installed):
    # the installed file list (the wheel's RECORD) with each file's hash
    out = _in_venv(installed, [str(installed["python"]), "-c",
                               "import importlib.metadata as m, json; "
                               "print(json.dumps({str(f): f.hash and f'{f.hash.mode}={f.hash.value}' "
                               "for f in m.distribution('psmat').files}))"], installed["tmp"] / "run_files")
    record = json.loads(out.splitlines()[-1])
    tree = ROOT / "src" / "psmat"
    files = [p for p in tree.rglob("*") if p.is_file() and "__pycache__" not in p.parts
             and p.suffix not in (".pyc", ".so", ".pyd")]
    data = [p for p in files if p.relative_to(tree).parts[0] == "data"]
    assert data and any(p.suffix == ".py" for p in files)  # the BDS trials and the modules of the tree
    for p in files:
        name = "psmat/" + p.relative_to(tree).as_posix()
        assert name in record, f"{name} is not installed"
        assert record[name] == record_hash(p), f"the installed {name} is not the tree's"
    assert [n for n in record if re.fullmatch(r"psmat/_core\.[^/]+\.(so|pyd)", n)], "no compiled psmat._core"


@pytest.mark.slow
def test_the_commands_cannot_import_the_test_extras(installed):
    # the check of the other tests that nothing of the test extras is needed can fail
    for module in ("pytest", "hypothesis", "torch"):
        out = subprocess.run([str(installed["python"]), "-c", f"import {module}"], cwd=installed["tmp"],
                             env=installed["env"], capture_output=True, text=True, timeout=120)
        assert out.returncode == 1 and f"No module named '{module}'" in out.stderr, out.stderr


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


def _copy_environment(tmp: Path) -> tuple[Path, Path]:
    """A venv holding a copy of the installed psmat (its own psmat._core), the rest from the test env.

    Returns (python, prefix). Its site-packages comes first on its path, so psmat is the copy's;
    a ``.pth`` file adds the running environment's site-packages for psmat's dependencies.
    """
    import psmat

    env_dir = tmp / "copy_env"
    venv.create(env_dir, with_pip=False, symlinks=os.name != "nt")
    python = env_dir / ("Scripts/python.exe" if os.name == "nt" else "bin/python")
    site = Path(_run([str(python), "-c", "import sysconfig; print(sysconfig.get_path('purelib'))"],
                     timeout=120).stdout.strip())
    shutil.copytree(Path(psmat.__file__).parent, site / "psmat", ignore=shutil.ignore_patterns("__pycache__"))
    paths = dict.fromkeys([sysconfig.get_path("purelib"), sysconfig.get_path("platlib")])
    (site / "test_environment.pth").write_text("".join(f"{p}\n" for p in paths))
    return python, env_dir.resolve()


@pytest.mark.slow
def test_compare_native_measures_each_build_in_its_own_environment(installed, tmp_path):
    # Two environments with their own psmat._core: the wheel's venv (a copy of the installation
    # when it is the test environment's) and the one running the tests.
    import psmat._core

    python, prefix = ((installed["python"], installed["prefix"]) if not installed["reused"]
                      else _copy_environment(tmp_path))
    cmd = [sys.executable, "-m", "psmat.bench", "iecm", "--compare-native", str(python),
           sys.executable, "--sizes", "8", "--frames", "8", "--repeats", "1", "--quick"]
    out = _run(cmd, cwd=tmp_path, timeout=600).stdout
    lines = out.splitlines()
    portable = next(line for line in lines if line.startswith("portable: "))
    native = next(line for line in lines if line.startswith("native: "))
    assert str(prefix) in portable
    assert str(Path(psmat._core.__file__).parent) in native
    rows = [line for line in lines if line.startswith("| 8x8 |")]
    assert len(rows) == 2 and "noisy G" in rows[1], out
    # the same interpreter twice is one build, not two: refused with one line
    same = subprocess.run(cmd[:6] + [str(python)] + cmd[7:], cwd=tmp_path, capture_output=True,
                          text=True, timeout=600)
    assert same.returncode == 1
    assert "the builds import the same psmat._core" in same.stderr.strip().splitlines()[-1]

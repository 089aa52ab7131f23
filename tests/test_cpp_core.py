"""The C++ unit tests of the core (src/cpp/tests, doctest), configured, built and run by CTest.

The build directory is ``build/cpp-tests`` under the repository (ignored by git); CMake, Ninja
and CTest come from the Python environment (the ``cmake`` and ``ninja`` packages of the
``test`` extra), Eigen from ``cmeel-eigen``.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
BUILD_DIR = REPO / "build" / "cpp-tests"
INSTALL_HINT = 'install the test requirements: pip install ".[test]"'


def _python_tool(name: str) -> str | None:
    """A tool from the Python environment (its scripts dir or the PyPI package), else PATH."""
    exe = name + (".exe" if os.name == "nt" else "")
    candidates: list[Path] = [Path(sys.executable).parent / exe]
    if name in ("cmake", "ctest"):
        try:
            import cmake  # type: ignore[import-not-found]

            candidates.insert(0, Path(cmake.CMAKE_BIN_DIR) / exe)
        except ImportError:
            pass
    if name == "ninja":
        try:
            import ninja  # type: ignore[import-not-found]

            candidates.insert(0, Path(ninja.BIN_DIR) / exe)
        except ImportError:
            pass
    for c in candidates:
        if c.is_file() and os.access(c, os.X_OK):
            return str(c)
    return shutil.which(name)


def _run(cmd: list[str], timeout: float) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        cmd, cwd=REPO, capture_output=True, text=True, timeout=timeout, check=False
    )


def _require_ok(proc: subprocess.CompletedProcess[str], what: str) -> None:
    if proc.returncode != 0:
        pytest.fail(
            f"{what} failed (exit {proc.returncode}): {' '.join(proc.args)}\n"
            f"--- stdout ---\n{proc.stdout}\n--- stderr ---\n{proc.stderr}",
            pytrace=False,
        )


def test_cpp_unit_tests_pass_under_ctest() -> None:
    cmake_exe = _python_tool("cmake")
    ctest_exe = _python_tool("ctest")
    ninja_exe = _python_tool("ninja")
    missing = [n for n, p in (("cmake", cmake_exe), ("ctest", ctest_exe), ("ninja", ninja_exe)) if p is None]
    if missing:
        pytest.fail(f"{', '.join(missing)} not found: {INSTALL_HINT}", pytrace=False)
    assert cmake_exe and ctest_exe and ninja_exe

    BUILD_DIR.parent.mkdir(parents=True, exist_ok=True)
    configure = [
        cmake_exe,
        "-S", str(REPO),
        "-B", str(BUILD_DIR),
        "-G", "Ninja",
        f"-DCMAKE_MAKE_PROGRAM={ninja_exe}",
        f"-DPython_EXECUTABLE={sys.executable}",  # the environment that holds cmeel-eigen
        "-DPSMAT_BUILD_TESTS=ON",
        "-DPSMAT_BUILD_PYTHON=OFF",
        "-DCMAKE_BUILD_TYPE=Release",
    ]  # fmt: skip
    _require_ok(_run(configure, timeout=600), "CMake configure")
    _require_ok(_run([cmake_exe, "--build", str(BUILD_DIR), "-j", "2"], timeout=1800), "C++ build")

    proc = _run([ctest_exe, "--test-dir", str(BUILD_DIR), "--output-on-failure"], timeout=1800)
    output = f"--- ctest stdout ---\n{proc.stdout}\n--- ctest stderr ---\n{proc.stderr}"
    # "100% tests passed, 0 tests failed out of 5" (CMake < 4) or "100% tests passed out of 5"
    m = re.search(r"(\d+)% tests passed(?:, (\d+) tests? failed)? out of (\d+)", proc.stdout)
    if proc.returncode != 0 or m is None:
        pytest.fail(f"ctest failed (exit {proc.returncode})\n{output}", pytrace=False)
    failed, total = int(m.group(2) or 0), int(m.group(3))
    assert total > 0, f"ctest ran no tests\n{output}"
    assert failed == 0, output

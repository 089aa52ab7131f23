"""The C++ unit tests of the core (src/cpp/tests, doctest), built once and run by CTest.

The CMake build tree ``build/cpp-tests`` under the repository (ignored by git) is kept between
runs: the first run compiles the core library and the one test executable (about a minute of
two cores), later runs let Ninja rebuild what changed since (nothing: seconds). Each test file
``src/cpp/tests/test_*.cpp`` is one CTest test and one pytest test here, which fails with the
file's doctest output. CMake, Ninja and CTest come from the Python environment (the ``cmake``
and ``ninja`` packages of the ``test`` extra), Eigen from ``cmeel-eigen``.
"""

from __future__ import annotations

import os
import platform
import re
import shutil
import subprocess
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
BUILD_DIR = REPO / "build" / "cpp-tests"
LOCK_FILE = REPO / "build" / "cpp-tests.lock"
CPP_TESTS = sorted(p.stem for p in (REPO / "src" / "cpp" / "tests").glob("test_*.cpp"))
INSTALL_HINT = 'install the test requirements: pip install ".[test]"'
BUILD_TIMEOUT_S = 1800.0


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
    """Runs ``cmd`` in the repository; one that runs past ``timeout`` s exits 124 with a note."""
    try:
        return subprocess.run(cmd, cwd=REPO, capture_output=True, text=True, timeout=timeout, check=False)
    except subprocess.TimeoutExpired as e:
        out = e.stdout.decode(errors="replace") if isinstance(e.stdout, bytes) else (e.stdout or "")
        err = e.stderr.decode(errors="replace") if isinstance(e.stderr, bytes) else (e.stderr or "")
        return subprocess.CompletedProcess(cmd, 124, out, f"{err}\ntimed out after {timeout:.0f} s")


def _report(proc: subprocess.CompletedProcess[str]) -> str:
    return f"$ {' '.join(proc.args)}\n--- stdout ---\n{proc.stdout}\n--- stderr ---\n{proc.stderr}"


def _cpus() -> int:
    """CPUs this process may run on (its affinity where the OS has one), for ``cmake --build -j``."""
    if hasattr(os, "sched_getaffinity"):
        return max(1, len(os.sched_getaffinity(0)))
    return max(1, os.cpu_count() or 1)


@contextmanager
def _build_lock(timeout_s: float) -> Iterator[None]:
    """Wait for, then hold, an exclusive lock on ``build/cpp-tests.lock``: two test runs in one
    checkout take turns on the build tree instead of running two Ninjas in it. The OS releases
    the lock when its holder dies."""
    LOCK_FILE.parent.mkdir(parents=True, exist_ok=True)
    fd = os.open(LOCK_FILE, os.O_RDWR | os.O_CREAT, 0o644)
    deadline = time.monotonic() + timeout_s
    try:
        while True:
            try:
                if os.name == "nt":  # pragma: no cover - Windows
                    import msvcrt

                    msvcrt.locking(fd, msvcrt.LK_NBLCK, 1)
                else:
                    import fcntl

                    fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
                break
            except OSError:
                if time.monotonic() > deadline:
                    pytest.fail(f"another test run held {LOCK_FILE} for {timeout_s:.0f} s", pytrace=False)
                time.sleep(1.0)
        yield
    finally:
        os.close(fd)  # closing the file releases the lock


def _cache_value(cache: Path, key: str) -> str | None:
    m = re.search(rf"^{re.escape(key)}:[A-Z]+=(.*)$", cache.read_text(encoding="utf-8", errors="replace"), re.M)
    return m.group(1).strip() if m else None


def _remove_foreign_tree() -> None:
    """A tree configured for another source directory (the checkout was moved or copied with its
    build/) or by another generator cannot be reconfigured: start it afresh."""
    cache = BUILD_DIR / "CMakeCache.txt"
    if not cache.is_file():
        return
    home = _cache_value(cache, "CMAKE_HOME_DIRECTORY")
    same_source = home is not None and Path(home).resolve() == REPO.resolve()
    if not same_source or _cache_value(cache, "CMAKE_GENERATOR") != "Ninja":
        shutil.rmtree(BUILD_DIR)


@dataclass
class CppBuild:
    """Where the C++ tests were built, and how: ``ok`` False with the failing step's output."""

    ctest: str
    ok: bool
    log: str
    reported_by: str = ""  # the first test that failed with ``log``; the others refer to it

    def fail_if_broken(self, test: str) -> None:
        """Fails ``test`` when the build failed: with the build's output the first time, later
        with a reference to the test that showed it."""
        if self.ok:
            return
        if self.reported_by:
            pytest.fail(f"the C++ tests did not build (the output is under {self.reported_by})", pytrace=False)
        self.reported_by = test
        pytest.fail(self.log, pytrace=False)


@pytest.fixture(scope="module")
def cpp_build() -> CppBuild:
    """Configures (cheap when nothing changed) and builds ``build/cpp-tests`` once per test run."""
    tools = {name: _python_tool(name) for name in ("cmake", "ctest", "ninja")}
    missing = [name for name, path in tools.items() if path is None]
    if missing:
        pytest.fail(f"{', '.join(missing)} not found: {INSTALL_HINT}", pytrace=False)
    cmake_exe, ctest_exe, ninja_exe = (str(tools[n]) for n in ("cmake", "ctest", "ninja"))
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
    build = [cmake_exe, "--build", str(BUILD_DIR), "-j", str(_cpus())]
    with _build_lock(BUILD_TIMEOUT_S):
        _remove_foreign_tree()
        for step, cmd in (("CMake configure", configure), ("C++ build", build)):
            proc = _run(cmd, timeout=BUILD_TIMEOUT_S)
            if proc.returncode != 0:
                return CppBuild(ctest_exe, False, f"{step} failed (exit {proc.returncode})\n{_report(proc)}")
    return CppBuild(ctest_exe, True, "")


def test_cpp_tests_build(cpp_build: CppBuild) -> None:
    """CMake configures ``build/cpp-tests`` and Ninja builds the core and the test executable."""
    cpp_build.fail_if_broken("test_cpp_tests_build")


@pytest.mark.parametrize("name", CPP_TESTS)
def test_cpp_unit_tests(cpp_build: CppBuild, name: str) -> None:
    """The test cases of ``src/cpp/tests/<name>.cpp``, run by CTest (output shown on failure)."""
    cpp_build.fail_if_broken(f"test_cpp_unit_tests[{name}]")
    with _build_lock(BUILD_TIMEOUT_S):
        proc = _run(
            [cpp_build.ctest, "--test-dir", str(BUILD_DIR), "--output-on-failure", "-R", f"^{name}$"],
            timeout=BUILD_TIMEOUT_S,
        )
    output = _report(proc)
    if "No tests were found" in proc.stdout + proc.stderr:
        pytest.fail(
            f"src/cpp/tests/{name}.cpp is not a CTest test: add it to PSMAT_CPP_TEST_SOURCES in "
            f"src/cpp/tests/CMakeLists.txt\n{output}",
            pytrace=False,
        )
    # "100% tests passed, 0 tests failed out of 1" (CMake < 4) or "100% tests passed out of 1"
    m = re.search(r"(\d+)% tests passed(?:, (\d+) tests? failed)? out of (\d+)", proc.stdout)
    if proc.returncode != 0 or m is None:
        pytest.fail(f"C++ test {name} failed (exit {proc.returncode})\n{output}", pytrace=False)
    assert int(m.group(3)) == 1, output
    assert int(m.group(2) or 0) == 0, output


def test_every_cpp_test_file_is_collected() -> None:
    """The files this module parametrizes over exist; a glob that finds none would pass vacuously."""
    assert CPP_TESTS, "no src/cpp/tests/test_*.cpp found"
    assert "test_forward" in CPP_TESTS


def test_vector_units_keep_to_themselves(cpp_build: CppBuild) -> None:
    """The x86-64 vector units of ``src/cpp/psmat/iecm/simd.hpp`` (one object each, AVX2 and
    AVX-512) define no global symbol but their kernel table and their own renamed Eigen, and have
    no static initialiser: the linker cannot take one of their template copies for the baseline
    code, and nothing of a unit runs before the CPU is known to have its instructions."""
    cpp_build.fail_if_broken("test_vector_units_keep_to_themselves")
    if platform.machine().lower() not in ("x86_64", "amd64") or sys.platform != "linux":
        pytest.skip("the vector units are x86-64 objects, read here as ELF (Linux)")
    from elftools.elf.elffile import ELFFile

    objects = sorted(BUILD_DIR.rglob("simd_avx*.cpp.o"))
    assert {o.name for o in objects} >= {"simd_avx2.cpp.o"}, objects  # GCC or Clang on x86-64 builds them
    for obj in objects:
        with open(obj, "rb") as f:
            elf = ELFFile(f)
            sections = {sec.name for sec in elf.iter_sections()}
            assert not sections & {".init_array", ".ctors", ".preinit_array"}, (obj.name, sections)
            tier = obj.name.removeprefix("simd_").removesuffix(".cpp.o")
            exported = [sym.name for sym in elf.get_section_by_name(".symtab").iter_symbols()
                        if sym["st_shndx"] != "SHN_UNDEF" and sym["st_info"]["bind"] != "STB_LOCAL"]
            assert any(f"simd_table_{tier}" in name for name in exported), (obj.name, exported)
            foreign = [name for name in exported
                       if f"psmat_eigen_{tier}" not in name and f"simd_table_{tier}" not in name
                       and name != "DW.ref.__gxx_personality_v0"]
            assert not foreign, (obj.name, foreign)

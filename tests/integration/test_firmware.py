"""Firmware (docs/spec.md §5): the host unit tests of firmware/core, the core as the CMake library
the main project links, and the cross builds for the BluePill and the Nano Every when their
toolchains are installed. Everything is built in a temporary directory."""

from __future__ import annotations

import re
import shutil
import subprocess
from pathlib import Path

import pytest

FIRMWARE = Path(__file__).resolve().parents[2] / "firmware"
CORE_SOURCES = sorted(str(p) for p in (FIRMWARE / "core").glob("*.c"))
HOST_TESTS = ["crc16", "frame", "command", "psm_core", "daq_core", "imu_core"]
# register-free parts of the BluePill USB CDC-ACM device and the rings (stm32/common)
STM32_COMMON = FIRMWARE / "stm32" / "common"
STM32_HOST_TESTS = {"usb": ["usb_ctrl.c", "usb_desc.c"], "ring": ["ring.c"]}
CC = next((c for c in ("cc", "gcc", "clang") if shutil.which(c)), None)
# `size` (Berkeley format): text data bss dec hex filename
SIZE_ROW = re.compile(r"^\s*(\d+)\s+(\d+)\s+(\d+)\s+\d+\s+[0-9a-f]+\s+(\S+)$", re.M)


def run(cmd: list[str], **kw) -> subprocess.CompletedProcess:
    return subprocess.run(cmd, capture_output=True, text=True, timeout=120, **kw)


@pytest.mark.parametrize("name", HOST_TESTS)
def test_core_unit(name: str, tmp_path: Path) -> None:
    if CC is None:
        pytest.skip("no C compiler (cc, gcc or clang) on PATH")
    exe = tmp_path / f"test_{name}"
    build = run([CC, "-std=c99", "-Wall", "-Wextra", "-Werror", "-O2", f"-I{FIRMWARE / 'core'}",
                 "-o", str(exe), str(FIRMWARE / "tests" / f"test_{name}.c"), *CORE_SOURCES])
    assert build.returncode == 0, build.stderr
    result = run([str(exe)])
    assert result.returncode == 0, result.stdout + result.stderr
    assert f"test_{name}: ok" in result.stdout


@pytest.mark.parametrize("name", sorted(STM32_HOST_TESTS))
def test_stm32_host_unit(name: str, tmp_path: Path) -> None:
    """Descriptors, EP0 dispatcher, packetisers and rings, without the registers."""
    if CC is None:
        pytest.skip("no C compiler (cc, gcc or clang) on PATH")
    exe = tmp_path / f"test_{name}"
    sources = [str(STM32_COMMON / f) for f in STM32_HOST_TESTS[name]]
    build = run([CC, "-std=c99", "-Wall", "-Wextra", "-Werror", "-O2", f"-I{STM32_COMMON}",
                 "-o", str(exe), str(FIRMWARE / "tests" / f"test_{name}.c"), *sources])
    assert build.returncode == 0, build.stderr
    result = run([str(exe)])
    assert result.returncode == 0, result.stdout + result.stderr
    assert f"test_{name}: ok" in result.stdout


def test_core_cmake_library(tmp_path: Path) -> None:
    """The static PIC library the main project add_subdirectory()s, warning-free."""
    if CC is None or shutil.which("cmake") is None:
        pytest.skip("needs a C compiler and cmake")
    configure = run(["cmake", "-S", str(FIRMWARE / "core"), "-B", str(tmp_path),
                     "-DCMAKE_C_FLAGS=-Werror", f"-DCMAKE_C_COMPILER={CC}"])
    assert configure.returncode == 0, configure.stdout + configure.stderr
    build = run(["cmake", "--build", str(tmp_path), "-j2"])
    assert build.returncode == 0, build.stdout + build.stderr
    assert list(tmp_path.glob("*psmat_firmware_core.a"))


def make_target(target: str, build: Path, *args: str) -> dict[str, tuple[int, int]]:
    """Builds one cross target; returns {elf name: (flash bytes, RAM bytes)} from `size`."""
    result = run(["make", "-C", str(FIRMWARE), "-j2", f"BUILD={build}", *args, target])
    assert result.returncode == 0, result.stdout + result.stderr
    assert "SKIP" not in result.stdout, result.stdout
    return {Path(f).stem: (int(t) + int(d), int(d) + int(b))
            for t, d, b, f in SIZE_ROW.findall(result.stdout)}


@pytest.mark.parametrize("link", ["usb", "uart"])
def test_stm32_targets(link: str, tmp_path: Path) -> None:
    """USB CDC-ACM is the default link (build/stm32/); LINK=uart keeps USART1
    (build/stm32-uart/). Each image holds only its own link's interrupt handler."""
    if shutil.which("arm-none-eabi-gcc") is None or shutil.which("make") is None:
        pytest.skip("arm-none-eabi-gcc (Debian gcc-arm-none-eabi) or make not on PATH")
    sizes = make_target("stm32", tmp_path, f"LINK={link}")
    out = tmp_path / ("stm32" if link == "usb" else "stm32-uart")
    assert set(sizes) == {"psm", "imu"}
    for name, (flash, ram) in sizes.items():
        assert (out / f"{name}.elf").is_file()
        assert (out / f"{name}.bin").stat().st_size > 0
        symbols = (out / f"{name}.map").read_text()
        # a handler's own section is linked only from its driver (else the weak alias)
        assert (".text.USB_LP_CAN1_RX0_IRQHandler" in symbols) == (link == "usb")
        assert (".text.USART1_IRQHandler" in symbols) == (link == "uart")
        assert 0 < flash <= 64 * 1024, (name, flash)
        assert 0 < ram <= 20 * 1024, (name, ram)


def test_avr_target(tmp_path: Path) -> None:
    avr = shutil.which("avr-gcc")
    if avr is None or shutil.which("make") is None:
        pytest.skip("avr-gcc (Debian gcc-avr) or make not on PATH")
    probe = run([avr, "-mmcu=avrxmega3", "-E", "-x", "c", "/dev/null", "-o", "/dev/null"])
    if probe.returncode != 0:
        pytest.skip("avr-gcc lacks the avrxmega3 architecture of the ATmega4809")
    sizes = make_target("avr", tmp_path)
    flash, ram = sizes["daq"]
    assert (tmp_path / "avr" / "daq.hex").is_file()
    assert 0 < flash <= 48 * 1024
    assert 0 < ram <= 6 * 1024

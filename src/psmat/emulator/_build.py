"""Building the STM32 images the emulator runs: ``make -C firmware stm32 LINK=uart`` in a source checkout.

The firmware's sources are in the repository (``firmware/``), not in the wheel; :func:`build_images`
runs its Makefile with Debian's ``arm-none-eabi-gcc`` and returns where the ELF files are. Without
the sources or the toolchain it raises :class:`BuildUnavailable` with the reason in one line.
"""

from __future__ import annotations

import os
import shutil
import subprocess
from pathlib import Path

__all__ = ["BuildUnavailable", "firmware_dir", "build_images", "ARM_GCC"]

#: the cross compiler the Makefile calls (``ARM ?= arm-none-eabi-``)
ARM_GCC = "arm-none-eabi-gcc"


class BuildUnavailable(RuntimeError):
    """The images cannot be built here (no firmware sources, no toolchain, no make); the reason in one line."""


def firmware_dir() -> Path:
    """The repository's ``firmware/`` folder (the sources of the images): beside the package when
    psmat runs from its checkout (an editable install), else ``./firmware`` of a clone psmat is run
    from (an installed psmat run in its repository, as CI does).

    Raises
    ------
    BuildUnavailable
        Neither holds the firmware's Makefile (an installed wheel carries no firmware sources).
    """
    for found in (Path(__file__).resolve().parents[3] / "firmware", Path.cwd() / "firmware"):
        if (found / "Makefile").is_file() and (found / "stm32").is_dir():
            return found
    raise BuildUnavailable("the firmware sources (firmware/ of the psmat repository) are not here: run from a "
                           "clone of the repository, or build the images there with make -C firmware stm32 "
                           "LINK=uart")


def build_images(build_dir: str | os.PathLike[str], *, link: str = "uart", extra_cflags: str = "",
                 source: str | os.PathLike[str] | None = None) -> dict[str, Path]:
    """Build the PSM and IMU images; their ELF files by name (``"psm"``, ``"imu"``).

    Parameters
    ----------
    build_dir : path
        Where the Makefile writes (``BUILD=``); the images land in ``build_dir/stm32-uart/``
        (``link="uart"``) or ``build_dir/stm32/`` (``"usb"``).
    link : {"uart", "usb"}
        The link the images talk over; the emulator models USART1 only.
    extra_cflags : str
        Further compiler flags (``EXTRA_CFLAGS``), e.g. ``-DPM_CRC16_BITWISE`` for the bitwise CRC.
    source : path, optional
        The firmware folder; default :func:`firmware_dir`.

    Raises
    ------
    BuildUnavailable
        No sources, no ``make``, no ``arm-none-eabi-gcc``.
    subprocess.CalledProcessError
        The build failed (its output in the exception).
    """
    if link not in ("uart", "usb"):
        raise ValueError(f"link must be 'uart' or 'usb', got {link!r}")
    src = Path(source) if source is not None else firmware_dir()
    if not (src / "Makefile").is_file():
        raise BuildUnavailable(f"{src} is not the firmware folder of a psmat clone (no Makefile)")
    for tool in ("make", ARM_GCC):
        if shutil.which(tool) is None:
            raise BuildUnavailable(f"{tool} is not on PATH (Debian: apt-get install make gcc-arm-none-eabi)")
    out = Path(build_dir)
    subprocess.run(["make", "-C", str(src), "-s", f"BUILD={out.resolve()}", f"LINK={link}",
                    f"EXTRA_CFLAGS={extra_cflags}", "stm32"], check=True, capture_output=True, text=True)
    folder = out / ("stm32-uart" if link == "uart" else "stm32")
    return {name: folder / f"{name}.elf" for name in ("psm", "imu")}

"""The unmodified IMU image (``make -C firmware stm32 LINK=uart``) on the emulated STM32F103 with
BNO055 models on its three bit-banged I²C buses (docs/spec.md §5 "Firmware executed").

Expectations: the BNO055 keeps Euler angles as int16 of 1/16 degree (datasheet §3.6.5.4), so an
angle comes out as round(16 x angle) / 16; sensor k is row k with columns heading, roll, pitch
(firmware/core/imu_core.h, firmware/stm32/imu/hal.c: bus 0 0x28, 0x29, bus 1 0x28, 0x29, bus 2
0x28); the default rate is 10 Hz, so device timestamps are 100 000 µs apart (to the 1 µs of the
counter); a sensor that does not acknowledge gives NaN (hal.c). The run has no Misuse, so the
image also kept the BNO055 mode-switching times (datasheet Table 3-6).

The emulation runs at 8 cycles per instruction with 10 µs slices: the image's waits read the
TIM3/TIM4 microsecond counter, and the frame period comes from TIM2, so neither depends on the
instruction rate, while the 0.8 s of busy-waiting at boot costs an eighth of the CPU time.
"""

from __future__ import annotations

import math
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("unicorn")
pytest.importorskip("elftools")

from psmat.emulator import IMU_SENSOR_SLOTS, Bno055, ImuBoard  # noqa: E402

FIRMWARE = Path(__file__).resolve().parents[2] / "firmware"
pytestmark = pytest.mark.skipif(shutil.which("arm-none-eabi-gcc") is None or shutil.which("make") is None,
                                reason="arm-none-eabi-gcc (Debian gcc-arm-none-eabi) or make not on PATH")

ABSENT = (1, 0x29)                          # sensor 3


@pytest.fixture(scope="module")
def imu_elf(tmp_path_factory: pytest.TempPathFactory) -> Path:
    build = tmp_path_factory.mktemp("fw")
    result = subprocess.run(["make", "-C", str(FIRMWARE), "-j2", f"BUILD={build}", "LINK=uart", "stm32"],
                            capture_output=True, text=True, timeout=600)
    assert result.returncode == 0, result.stdout + result.stderr
    return build / "stm32-uart" / "imu.elf"


def angles(k: int) -> tuple[float, float, float]:
    """Distinct per sensor, some off the 1/16-degree grid (heading, roll, pitch; degrees)."""
    return (12.0625 + 50.0 * k + 0.03, -3.5 - 7.0 * k, 1.25 + 11.0 * k - 0.02)


def quantized(values: tuple[float, ...]) -> list[float]:
    return [round(16.0 * v) / 16.0 for v in values]


def test_imu_image_reports_the_sensors_angles_at_10_hz(imu_elf: Path) -> None:
    sensors: dict[tuple[int, int], Bno055 | None] = {}
    for k, slot in enumerate(IMU_SENSOR_SLOTS):
        sensor = Bno055(slot[1])
        sensor.set_euler(*angles(k))
        sensors[slot] = sensor
    sensors[ABSENT] = None
    board = ImuBoard(imu_elf, sensors, cycles_per_instruction=8.0, max_slice_s=1e-5)

    board.run(1.25)                         # 650 ms sensor boot wait, set-up, then frames
    first = board.frames()
    n = len(first["seq"])
    assert n >= 3
    moved = (200.0, 45.0, -60.0)
    sensors[IMU_SENSOR_SLOTS[0]].set_euler(*moved)
    board.run(board.machine.now_s + 0.1)    # one more frame period
    result = board.frames()

    assert result["valid"].all() and result["dropped"] == 0
    seq, t_us, frames = result["seq"], result["t_us"], result["frames"]
    assert len(seq) == n + 1
    assert list(seq) == list(range(seq[0], seq[0] + n + 1))
    assert frames.shape == (n + 1, 5, 3) and frames.dtype == np.float32
    assert np.all(np.abs(np.diff(t_us) - 100_000) <= 1)
    for row in range(n + 1):
        for k in range(5):
            got = frames[row, k].tolist()
            if IMU_SENSOR_SLOTS[k] == ABSENT:
                assert all(math.isnan(v) for v in got), (row, k, got)
            elif k == 0 and row == n:
                assert got == quantized(moved)
            else:
                assert got == quantized(angles(k)), (row, k, got)

    # the absent sensor was asked for and did not answer, on bus 1
    nacked = [e for e in board.buses[1].log if e.kind == "address" and not e.ack]
    assert nacked and all(e.value >> 1 == 0x29 for e in nacked)

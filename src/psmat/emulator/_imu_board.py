"""The spine IMU board: the IMU image on an emulated STM32F103 with five BNO055 on three buses.

Wiring (firmware/README.md "Pins and links", firmware/stm32/imu/hal.c): bus 0 on PB6 (SCL) /
PB7 (SDA) with sensors 0x28 and 0x29, bus 1 on PB10 / PB11 with 0x28 and 0x29, bus 2 on PB8 /
PB9 with 0x28; sensor k of the frame is the k-th of that list. The pull-ups are on the sensor
boards, so an idle line reads high. The host link is USART1 (``make LINK=uart``): the bytes the
image sends are ``usart1.tx``, decoded with :func:`psmat.protocol.decode_v2`.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

from ._bno055 import Bno055
from ._i2c import I2cBus
from ._machine import DEFAULT_UID, Machine

__all__ = ["IMU_BUS_PINS", "IMU_SENSOR_SLOTS", "ImuBoard"]

IMU_BUS_PINS: tuple[tuple[int, int], ...] = ((6, 7), (10, 11), (8, 9))
"""(SCL, SDA) pins of GPIOB for buses 0, 1, 2."""
IMU_SENSOR_SLOTS: tuple[tuple[int, int], ...] = ((0, 0x28), (0, 0x29), (1, 0x28), (1, 0x29), (2, 0x28))
"""(bus, address) of sensors 0..4, the rows of an IMU frame."""


class ImuBoard:
    """The IMU image running with its buses and sensors.

    Parameters
    ----------
    elf_path : str or Path
        The IMU image built with ``LINK=uart`` (``BUILD/stm32-uart/imu.elf``).
    sensors : mapping of (bus, address) to Bno055 or None, optional
        The devices on the buses; None (or a slot left out) leaves that address empty, so it
        does not acknowledge. By default a :class:`Bno055` in each of :data:`IMU_SENSOR_SLOTS`.
    cycles_per_instruction, hse_hz, uid, max_slice_s
        Passed to :class:`Machine`. A longer ``max_slice_s`` makes the image's busy waits
        (``delay_us``, the BNO055 boot wait) cheaper to emulate at the cost of timing inside a
        slice: the microsecond counter reads the slice's start time, so each wait ends up to
        one slice late (the I²C bit rate drops; frame timing comes from TIM2 and is unchanged).

    Attributes
    ----------
    machine : Machine
    buses : tuple of I2cBus
        Buses 0, 1, 2.
    sensors : dict
        The sensors present, by (bus, address).
    """

    def __init__(self, elf_path: str | Path, sensors: Mapping[tuple[int, int], Bno055 | None] | None = None,
                 *, cycles_per_instruction: float = 1.0, hse_hz: float = 8e6,
                 uid: tuple[int, int, int] = DEFAULT_UID, max_slice_s: float = 1e-6) -> None:
        if sensors is None:
            sensors = {slot: Bno055(slot[1]) for slot in IMU_SENSOR_SLOTS}
        for (bus, address), sensor in sensors.items():
            if bus not in range(len(IMU_BUS_PINS)):
                raise ValueError(f"sensor at bus {bus}: the IMU board has buses 0, 1, 2")
            if sensor is not None and sensor.address != address:
                raise ValueError(f"sensor keyed ({bus}, 0x{address:02X}) has address "
                                 f"0x{sensor.address:02X}")
        self.machine = Machine(elf_path, cycles_per_instruction=cycles_per_instruction,
                               hse_hz=hse_hz, uid=uid, max_slice_s=max_slice_s)
        gpiob = self.machine.peripheral("GPIOB")
        self.buses = tuple(I2cBus(gpiob, scl, sda, name=f"I2C bus {k} (PB{scl} SCL, PB{sda} SDA)")
                           for k, (scl, sda) in enumerate(IMU_BUS_PINS))
        self.sensors = {slot: s for slot, s in sensors.items() if s is not None}
        for (bus, _), sensor in self.sensors.items():
            self.buses[bus].attach(sensor)

    @property
    def usart1(self) -> Any:
        """The USART1 model (``tx``: the bytes sent, ``feed``: host bytes)."""
        return self.machine.peripheral("USART1")

    def run(self, until_s: float | None = None, **limits: Any) -> None:
        """Runs the image (``Machine.run``: ``until_s`` in s, ``instructions``, ``until``)."""
        self.machine.run(until_s, **limits)

    def frames(self) -> dict[str, Any]:
        """The IMU frames sent so far: :func:`psmat.protocol.decode_v2` of ``usart1.tx``, kind "imu"."""
        from psmat.protocol import decode_v2

        return decode_v2(bytes(self.usart1.tx), "imu")

"""The STM32F103 firmware images executed in an emulator (docs/spec.md §5 "Firmware executed").

The unmodified ELF built by ``make -C firmware stm32`` runs on unicorn's Cortex-M3 (Thumb) with
register-level Python models of exactly the peripherals it touches; any access to an address
without a model fails the run with :class:`UnmodelledAccess`, naming the address and the PC.

* :mod:`psmat.emulator._errors` — :class:`EmulationError`, :class:`UnmodelledAccess`, :class:`Misuse`.
* :mod:`psmat.emulator._peripheral` — :class:`Peripheral`, the base of every model.
* :mod:`psmat.emulator._machine` — :class:`Machine`: unicorn's Cortex-M3, the memory map, the
  run loop (time, WFI, interrupts between slices); :mod:`~psmat.emulator._nvic` — :class:`Nvic`
  (NVIC/SCB registers, exception entry and return); :mod:`~psmat.emulator._elf` — :class:`Image`.
* The peripheral models (``PERIPHERAL_CLASSES``, in ``_stm32f103``): :class:`Rcc` and
  :class:`Flash` (``_rcc``), :class:`Afio`, :class:`GpioA`/``B``/``C`` (``_gpio``),
  :class:`Tim2`/``3``/``4`` (``_tim``), :class:`Adc1`, :class:`Usart1`, :class:`Uid`.
* :func:`build_images` (``_build``) — ``make -C firmware stm32 LINK=uart`` in a source checkout.
* :class:`ImuBoard` (``_imu_board``) — the IMU image with five :class:`Bno055` models on three
  bit-banged, open-drain :class:`I2cBus` lines (``_bno055``, ``_i2c``).
* :class:`PsmBoard` (``_psm_board``) — the PSM image reading a mat of known counts through the
  board's multiplexer wiring, with the settling time of every conversion.
"""

from ._adc import Adc1
from ._afio import Afio
from ._build import ARM_GCC, BuildUnavailable, build_images, firmware_dir
from ._elf import Image, load_image
from ._errors import EmulationError, Misuse, UnmodelledAccess
from ._gpio import Gpio, GpioA, GpioB, GpioC
from ._machine import Machine
from ._nvic import Nvic
from ._peripheral import Peripheral
from ._psm_board import Conversion, PsmBoard
from ._rcc import Flash, Rcc
from ._stm32f103 import PERIPHERAL_CLASSES
from ._tim import Tim2, Tim3, Tim4, Timer
from ._uid import Uid
from ._usart import Usart1
from ._i2c import I2cBus, I2cDevice, I2cEvent
from ._bno055 import Bno055
from ._imu_board import IMU_BUS_PINS, IMU_SENSOR_SLOTS, ImuBoard

__all__ = [
    "PERIPHERAL_CLASSES",
    "ARM_GCC",
    "BuildUnavailable",
    "build_images",
    "firmware_dir",
    "PsmBoard",
    "Conversion",
    "Adc1",
    "Afio",
    "EmulationError",
    "Flash",
    "Gpio",
    "GpioA",
    "GpioB",
    "GpioC",
    "Image",
    "Machine",
    "Misuse",
    "Nvic",
    "Peripheral",
    "Rcc",
    "Tim2",
    "Tim3",
    "Tim4",
    "Timer",
    "Uid",
    "UnmodelledAccess",
    "Usart1",
    "load_image",
    "I2cBus",
    "I2cDevice",
    "I2cEvent",
    "Bno055",
    "IMU_BUS_PINS",
    "IMU_SENSOR_SLOTS",
    "ImuBoard",
]

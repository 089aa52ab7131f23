"""The STM32F103C8 peripherals the PSM and IMU images touch, in one list for the machine.

``PERIPHERAL_CLASSES`` holds a model class per peripheral; each is built as ``cls(machine)``
and is found by its ``name`` ("RCC", "FLASH", "AFIO", "GPIOA", "GPIOB", "GPIOC", "TIM2", "TIM3",
"TIM4", "ADC1", "USART1", "UID"). The RCC model is the machine's ``rcc``.
"""

from __future__ import annotations

from ._adc import Adc1
from ._afio import Afio
from ._gpio import GpioA, GpioB, GpioC
from ._peripheral import Peripheral
from ._rcc import Flash, Rcc
from ._tim import Tim2, Tim3, Tim4
from ._uid import Uid
from ._usart import Usart1

__all__ = ["PERIPHERAL_CLASSES"]

PERIPHERAL_CLASSES: tuple[type[Peripheral], ...] = (
    Rcc, Flash, Afio, GpioA, GpioB, GpioC, Tim2, Tim3, Tim4, Adc1, Usart1, Uid,
)

"""An open-drain I²C bus on two GPIO pins, decoded bit by bit (docs/spec.md §5 "Firmware executed").

The IMU image bit-bangs I²C (firmware/stm32/imu/i2c_soft.c): SCL and SDA are open-drain outputs
that the MCU pulls low (ODR 0) or releases (ODR 1). A line is wired-AND: low when any driver — the
MCU pin, configured as an output with ODR 0, or a device on the bus — pulls it low, else high
through the pull-up. :class:`I2cBus` hooks the GPIO model: every ODR/BSRR/BRR write (``on_write``)
recomputes both lines, decodes the transition, lets the devices react, and presents the line
levels to the pins (``set_input``), so IDR reads what a real bus would show.

Decoding (I²C-bus specification UM10204 §3.1): SDA falling while SCL is high is a START (a
repeated START inside a transaction), SDA rising while SCL is high a STOP; otherwise SDA is
sampled on the rising edge of SCL, eight bits MSB first and a ninth acknowledge bit (low = ACK).
The first byte after a START is the 7-bit address and the R/W bit (1 = read). The addressed
device drives the ACK and, in a read, the data bits while SCL is low: it changes SDA right after
the falling edge of SCL.

Not modelled: clock stretching (the devices here never hold SCL low, so the image's stretch
wait in ``scl_high`` always finds SCL high at once), timing (setup/hold times, the 100 kHz bit
rate: only the order of line changes matters), arbitration between masters, 10-bit addresses,
general call. Misuse caught: SCL and SDA changed by one register write (the order of the two
edges, hence START/STOP or a data bit, is undefined), a push-pull output driving SDA high while
a device pulls it low (a short).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Protocol

from ._errors import Misuse

if TYPE_CHECKING:  # pragma: no cover - typing only
    from ._gpio import Gpio

__all__ = ["I2cBus", "I2cDevice", "I2cEvent"]


@dataclass(frozen=True, slots=True)
class I2cEvent:
    """One decoded bus event.

    Attributes
    ----------
    kind : {"start", "stop", "address", "write", "read"}
        ``start`` covers a repeated START too; ``address`` is the first byte after a START,
        ``write`` a data byte from the MCU, ``read`` a data byte from a device.
    value : int or None
        The byte on the wire (``address``: ``addr << 1 | R/W``); None for start/stop.
    ack : bool or None
        Whether the byte was acknowledged (by the device for address/write, by the MCU for read).
    now_s : float
        Emulated time (s) of the event (the ninth clock's rising edge for a byte).
    """

    kind: str
    value: int | None
    ack: bool | None
    now_s: float


class I2cDevice(Protocol):
    """What a device on an :class:`I2cBus` implements (see :class:`psmat.emulator.Bno055`)."""

    address: int

    def attached(self, bus: I2cBus) -> None:
        """Called once when the device is put on ``bus`` (to keep it for failures)."""

    def i2c_start(self, read: bool, now_s: float) -> bool:
        """Addressed after a (repeated) START, for a read or a write; True to ACK."""

    def i2c_write(self, byte: int, now_s: float) -> bool:
        """A data byte from the MCU; True to ACK."""

    def i2c_read(self, now_s: float) -> int:
        """The next data byte (0-255) to send to the MCU."""

    def i2c_stop(self, now_s: float) -> None:
        """The transaction it was addressed in ended with a STOP."""


# Decoder phases.
IDLE, ADDRESS, WRITE, DEVICE_ACK, READ, MASTER_ACK, IGNORE = range(7)


class I2cBus:
    """One open-drain bus on two pins of a GPIO port, with its devices.

    Parameters
    ----------
    gpio : Gpio
        The port model (``on_write`` hooks, ``set_input``, ``pin_mode``, ``odr``, ``machine``).
    scl, sda : int
        Pin numbers (0-15) of the clock and data lines.
    name : str
        For messages, e.g. ``"I2C bus 0 (PB6 SCL, PB7 SDA)"``.

    Attributes
    ----------
    log : list of I2cEvent
        Every decoded event since the bus was built.
    devices : dict of int to I2cDevice
        The devices by 7-bit address.
    scl_level, sda_level : int
        The line levels (0 or 1) now.
    """

    def __init__(self, gpio: Gpio, scl: int, sda: int, *, name: str = "I2C") -> None:
        if not (0 <= scl < 16 and 0 <= sda < 16) or scl == sda:
            raise ValueError(f"{name}: SCL {scl} and SDA {sda} must be two pins in 0..15")
        self.gpio, self.scl, self.sda, self.name = gpio, scl, sda, name
        self.devices: dict[int, I2cDevice] = {}
        self.log: list[I2cEvent] = []
        self._device_low = False          # the addressed device pulls SDA low
        self._phase = IDLE
        self._shift = self._bits = 0
        self._rose = False                # a rising SCL edge since the last falling one
        self._target: I2cDevice | None = None
        self._read = False
        self._byte = 0                    # the byte a device is sending
        self._acked = self._master_ack = False
        self.scl_level, self.sda_level = self._levels()
        self._present()
        gpio.on_write.append(self._on_gpio_write)

    # -- devices ------------------------------------------------------------------------------

    def attach(self, device: I2cDevice) -> None:
        """Puts ``device`` on the bus at its ``address`` (7-bit, 0x08-0x77)."""
        address = device.address
        if not 0x08 <= address <= 0x77:
            raise ValueError(f"{self.name}: address 0x{address:02X} outside 0x08..0x77 (7-bit, "
                             f"not reserved)")
        if address in self.devices:
            raise ValueError(f"{self.name}: address 0x{address:02X} already taken")
        self.devices[address] = device
        device.attached(self)

    def fail(self, text: str) -> None:
        """Fails the run with :class:`Misuse` ``"<bus name>: <text> at PC ..."``."""
        self.gpio.machine.fail(Misuse, f"{self.name}: {text}")
        raise Misuse(f"{self.name}: {text}")  # pragma: no cover - machine.fail raises

    # -- lines --------------------------------------------------------------------------------

    def _mcu_low(self, pin: int) -> bool:
        return self.gpio.pin_mode(pin).startswith("output") and not self.gpio.odr >> pin & 1

    def _levels(self) -> tuple[int, int]:
        scl = 0 if self._mcu_low(self.scl) else 1
        sda = 0 if self._device_low or self._mcu_low(self.sda) else 1
        return scl, sda

    def _present(self) -> None:
        if self._device_low and self.gpio.pin_mode(self.sda) == "output push-pull" \
                and self.gpio.odr >> self.sda & 1:
            self.fail(f"SDA (pin {self.sda}) is a push-pull output driven high while a device "
                      f"pulls it low")
        self.gpio.set_input(self.scl, self.scl_level)
        self.gpio.set_input(self.sda, self.sda_level)

    def _on_gpio_write(self, _port: str, _before: int, _after: int, now_s: float) -> None:
        scl, sda = self._levels()
        old_scl, old_sda = self.scl_level, self.sda_level
        if scl != old_scl and sda != old_sda:
            self.fail(f"SCL (pin {self.scl}) and SDA (pin {self.sda}) changed by one write: "
                      f"the order of the two edges is undefined")
        self.scl_level, self.sda_level = scl, sda
        if sda != old_sda and scl:
            if sda:
                self._stop(now_s)
            else:
                self._start(now_s)
        elif scl != old_scl:
            if scl:
                self._rise(now_s)
            else:
                self._fall(now_s)
        self.sda_level = self._levels()[1]   # a device may have changed SDA (SCL is low then)
        self._present()

    # -- decoding -----------------------------------------------------------------------------

    def _start(self, now_s: float) -> None:
        self.log.append(I2cEvent("start", None, None, now_s))
        self._device_low = False
        self._phase, self._shift, self._bits, self._rose = ADDRESS, 0, 0, False

    def _stop(self, now_s: float) -> None:
        self.log.append(I2cEvent("stop", None, None, now_s))
        if self._target is not None:
            self._target.i2c_stop(now_s)
        self._target, self._device_low, self._phase = None, False, IDLE

    def _rise(self, now_s: float) -> None:
        self._rose = True
        phase, bit = self._phase, self.sda_level
        if phase in (ADDRESS, WRITE, READ):
            self._shift = (self._shift << 1 | bit) & 0xFF
            self._bits += 1
        elif phase == DEVICE_ACK:
            kind = "address" if self._bits == -1 else "write"
            self.log.append(I2cEvent(kind, self._shift, not bit, now_s))
        elif phase == MASTER_ACK:
            self.log.append(I2cEvent("read", self._byte, not bit, now_s))
            self._master_ack = not bit

    def _fall(self, now_s: float) -> None:
        if not self._rose:
            return                            # SCL pulled low after a START: no bit yet
        self._rose = False
        phase = self._phase
        if phase in (ADDRESS, WRITE) and self._bits == 8:
            self._byte_in(now_s)
        elif phase == DEVICE_ACK:
            self._device_low = False
            if not self._acked:
                self._phase = IGNORE
            elif self._read:
                self._send(now_s)
            else:
                self._phase, self._shift, self._bits = WRITE, 0, 0
        elif phase == READ:
            if self._bits < 8:
                self._device_low = not self._byte >> (7 - self._bits) & 1
            else:
                self._device_low, self._phase = False, MASTER_ACK
        elif phase == MASTER_ACK:
            if self._master_ack:
                self._send(now_s)
            else:
                self._phase = IGNORE

    def _byte_in(self, now_s: float) -> None:
        byte = self._shift
        if self._phase == ADDRESS:
            self._target = self.devices.get(byte >> 1)
            self._read = bool(byte & 1)
            self._acked = self._target is not None and self._target.i2c_start(self._read, now_s)
            if not self._acked:
                self._target = None
            self._bits = -1                   # marks the address byte for the log
        else:
            self._acked = self._target is not None and self._target.i2c_write(byte, now_s)
            self._bits = 0
        self._device_low = self._acked
        self._phase = DEVICE_ACK

    def _send(self, now_s: float) -> None:
        assert self._target is not None
        self._byte = self._target.i2c_read(now_s) & 0xFF
        self._phase, self._shift, self._bits = READ, 0, 0
        self._device_low = not self._byte >> 7 & 1

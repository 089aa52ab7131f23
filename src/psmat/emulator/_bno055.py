"""A Bosch BNO055 on an emulated I²C bus: page 0 of its register map, Euler angles set by a test.

Facts from the BNO055 datasheet (BST-BNO055-DS000):

* I²C address 0x28 (COM3 low) or 0x29 (COM3 high) (§4.6); a register write is the register
  address then data bytes, a read sets the address in a write and reads after a repeated START;
  the address auto-increments after every byte, in reads and writes (§4.6.1, §4.6.2).
* Page 0 register map (§4.2.1, Table 4-2): CHIP_ID 0x00 = 0xA0, ACC_ID 0x01 = 0xFB, MAG_ID 0x02 =
  0x32, GYR_ID 0x03 = 0x0F, PAGE_ID 0x07, the Euler angles at 0x1A..0x1F (heading, roll, pitch,
  int16 little-endian), UNIT_SEL 0x3B (bit 2: Euler in degrees, 0, or radians, 1; reset 0x80),
  OPR_MODE 0x3D (bits 3:0, CONFIGMODE 0x00 after reset; fusion modes IMU 0x08 .. NDOF 0x0C),
  PWR_MODE 0x3E, SYS_TRIGGER 0x3F (bit 5 RST_SYS).
* Euler angles: 1 degree = 16 LSB, 1 radian = 900 LSB (§3.6.5.4, Table 3-29).
* In CONFIGMODE all output data is reset to zero and fusion is halted; it is the only mode in
  which the writable registers can be changed, except OPR_MODE and the interrupt registers (§3.3.1).
* Operating mode switching time (§3.3, Table 3-6): CONFIGMODE to any other mode 7 ms, any mode to
  CONFIGMODE 19 ms.

Misuse caught (a firmware bug on real hardware): a configuration register written outside
CONFIGMODE or less than 19 ms after OPR_MODE was set to CONFIGMODE; fusion output (Euler,
quaternion, linear acceleration, gravity: 0x1A..0x33) read less than 7 ms after OPR_MODE was set
to a fusion mode; a read-only register written; an OPR_MODE value that is no mode. Page 1
(PAGE_ID = 1) fails as unmodelled. Registers not listed here read 0; the raw sensor data, the
quaternion and the other outputs are not modelled (0). PAGE_ID and SYS_TRIGGER may be written in
any mode (the driver's page switch and reset need that). Not modelled: the start-up time unless
``boot_s`` is given (a chip still booting does not acknowledge its address), calibration,
interrupts, the fusion itself (the angles are what :meth:`Bno055.set_euler` set).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from ._errors import Misuse, UnmodelledAccess

if TYPE_CHECKING:  # pragma: no cover - typing only
    from ._i2c import I2cBus

__all__ = ["Bno055"]

CHIP_ID, ACC_ID, MAG_ID, GYR_ID, PAGE_ID = 0x00, 0x01, 0x02, 0x03, 0x07
EUL_HEADING_LSB = 0x1A
FUSION_FIRST, FUSION_LAST = 0x1A, 0x33      # Euler, quaternion, linear acceleration, gravity
ST_RESULT, SYS_STATUS = 0x36, 0x39
UNIT_SEL, OPR_MODE, PWR_MODE, SYS_TRIGGER = 0x3B, 0x3D, 0x3E, 0x3F
RST_SYS = 1 << 5
EUL_RADIANS = 1 << 2
CONFIGMODE, FUSION_MODES = 0x00, range(0x08, 0x0D)
TO_CONFIG_S, FROM_CONFIG_S = 19e-3, 7e-3    # Table 3-6
LSB_PER_DEGREE, LSB_PER_RADIAN = 16, 900
# Writable registers of page 0 (Table 4-2); those writable in any mode.
WRITABLE = frozenset({PAGE_ID, UNIT_SEL, OPR_MODE, PWR_MODE, SYS_TRIGGER, 0x40, 0x41, 0x42}
                     | set(range(0x43, 0x6B)))
ANY_MODE = frozenset({PAGE_ID, OPR_MODE, SYS_TRIGGER})
RESET = {CHIP_ID: 0xA0, ACC_ID: 0xFB, MAG_ID: 0x32, GYR_ID: 0x0F, ST_RESULT: 0x0F,
         UNIT_SEL: 0x80, 0x41: 0x24}


class Bno055:
    """One BNO055 as an I²C device (:class:`psmat.emulator.I2cBus` ``attach``).

    Parameters
    ----------
    address : int
        0x28 or 0x29.
    boot_s : float
        Emulated time (s) after power-up (time 0) or a RST_SYS reset during which the chip does
        not acknowledge its address; 0 (default) answers at once. The datasheet gives the
        power-on-reset to CONFIGMODE time in Table 0-2; pass it to test a firmware's wait.

    Attributes
    ----------
    registers : bytearray
        Page 0 (128 bytes) as last written or reset; the outputs are computed on read.
    euler_deg : tuple of 3 float
        Heading, roll, pitch (degrees) that fusion modes report.
    writes : list of tuple
        ``(now_s, register, value)`` of every register write, for tests.
    """

    def __init__(self, address: int = 0x28, *, boot_s: float = 0.0) -> None:
        if address not in (0x28, 0x29):
            raise ValueError(f"BNO055 address must be 0x28 or 0x29, got 0x{address:02X}")
        if not boot_s >= 0:
            raise ValueError(f"boot_s must be >= 0 s, got {boot_s}")
        self.address = address
        self.boot_s = float(boot_s)
        self.bus: I2cBus | None = None
        self.euler_deg = (0.0, 0.0, 0.0)
        self.writes: list[tuple[float, int, int]] = []
        self._reset(0.0)

    def __repr__(self) -> str:
        return f"<Bno055 at 0x{self.address:02X} mode 0x{self.mode:02X}>"

    # -- the test's side ----------------------------------------------------------------------

    def set_euler(self, heading_deg: float, roll_deg: float, pitch_deg: float) -> None:
        """Sets the orientation the fusion modes report (degrees; registers keep 1/16 degree)."""
        angles = (float(heading_deg), float(roll_deg), float(pitch_deg))
        for name, value in zip(("heading", "roll", "pitch"), angles):
            if not (math.isfinite(value) and -32768 <= round(value * LSB_PER_DEGREE) <= 32767):
                raise ValueError(f"BNO055 0x{self.address:02X}: {name} {value} degrees does not fit "
                                 f"an int16 of 1/16 degree")
        self.euler_deg = angles

    @property
    def mode(self) -> int:
        """OPR_MODE bits 3:0 as last written."""
        return self.registers[OPR_MODE] & 0x0F

    # -- I²C device -------------------------------------------------------------------------

    def attached(self, bus: I2cBus) -> None:
        """Keeps the bus (for failures)."""
        self.bus = bus

    def i2c_start(self, read: bool, now_s: float) -> bool:
        """ACKs its address once booted."""
        return now_s >= self._ready_s

    def i2c_write(self, byte: int, now_s: float) -> bool:
        """First byte of a write: the register address; then data at auto-incremented addresses."""
        if self._expect_address:
            self._pointer, self._expect_address = byte & 0x7F, False
            return True
        self._write(self._pointer, byte, now_s)
        self._pointer = (self._pointer + 1) & 0x7F
        return True

    def i2c_read(self, now_s: float) -> int:
        """The register at the pointer, which then auto-increments."""
        value = self._read(self._pointer, now_s)
        self._pointer = (self._pointer + 1) & 0x7F
        return value

    def i2c_stop(self, now_s: float) -> None:
        """A STOP: the next write starts with a register address again."""
        self._expect_address = True

    # -- registers ----------------------------------------------------------------------------

    def _reset(self, now_s: float) -> None:
        self.registers = bytearray(128)
        for register, value in RESET.items():
            self.registers[register] = value
        self._pointer, self._expect_address = 0, True
        self._mode_ready_s = now_s
        self._ready_s = now_s + self.boot_s

    def _fail(self, cls: type[Exception], text: str) -> None:
        message = f"BNO055 0x{self.address:02X}: {text}"
        if self.bus is None:
            raise cls(message)
        self.bus.gpio.machine.fail(cls, f"{self.bus.name}: {message}")

    def _check_page(self, register: int) -> None:
        if register != PAGE_ID and self.registers[PAGE_ID]:
            self._fail(UnmodelledAccess, f"register 0x{register:02X} of page "
                                         f"{self.registers[PAGE_ID]} not modelled (page 0 only)")

    def _read(self, register: int, now_s: float) -> int:
        self._check_page(register)
        mode = self.mode
        if FUSION_FIRST <= register <= FUSION_LAST:
            if mode in FUSION_MODES and now_s < self._mode_ready_s:
                self._fail(Misuse, f"fusion output 0x{register:02X} read "
                                   f"{(now_s - self._mode_ready_s + FROM_CONFIG_S) * 1e3:.3f} ms after "
                                   f"OPR_MODE = 0x{mode:02X}, before the 7 ms switching time "
                                   f"(datasheet Table 3-6)")
            if mode not in FUSION_MODES or not EUL_HEADING_LSB <= register < EUL_HEADING_LSB + 6:
                return 0                     # CONFIGMODE zeroes the outputs; others not modelled
            k = (register - EUL_HEADING_LSB) // 2
            if self.registers[UNIT_SEL] & EUL_RADIANS:
                raw = round(math.radians(self.euler_deg[k]) * LSB_PER_RADIAN)
            else:
                raw = round(self.euler_deg[k] * LSB_PER_DEGREE)
            return (raw & 0xFFFF) >> (8 * ((register - EUL_HEADING_LSB) & 1)) & 0xFF
        if register == SYS_STATUS:
            return 5 if mode in FUSION_MODES and now_s >= self._mode_ready_s else 0
        return self.registers[register]

    def _write(self, register: int, value: int, now_s: float) -> None:
        self._check_page(register)
        self.writes.append((now_s, register, value))
        if register not in WRITABLE:
            self._fail(Misuse, f"register 0x{register:02X} is read-only (datasheet Table 4-2)")
        if register not in ANY_MODE:
            if self.mode != CONFIGMODE:
                self._fail(Misuse, f"register 0x{register:02X} written in operating mode "
                                   f"0x{self.mode:02X}: only CONFIGMODE allows it (datasheet §3.3.1)")
            if now_s < self._mode_ready_s:
                self._fail(Misuse, f"register 0x{register:02X} written "
                                   f"{(now_s - self._mode_ready_s + TO_CONFIG_S) * 1e3:.3f} ms after "
                                   f"OPR_MODE = CONFIGMODE, before the 19 ms switching time "
                                   f"(datasheet Table 3-6)")
        if register == OPR_MODE:
            mode = value & 0x0F
            if mode > 0x0C:
                self._fail(Misuse, f"OPR_MODE 0x{value:02X}: operating mode 0x{mode:X} does not exist "
                                   f"(datasheet §3.3)")
            if mode != self.mode:
                self._mode_ready_s = now_s + (TO_CONFIG_S if mode == CONFIGMODE else FROM_CONFIG_S)
        if register == SYS_TRIGGER and value & RST_SYS:
            self._reset(now_s)
            return
        self.registers[register] = value & 0xFF

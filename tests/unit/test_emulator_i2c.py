"""The open-drain I²C bus model and the BNO055 model, driven by hand-made line waveforms.

A stand-in machine (emulated time set by hand) holds the real RCC, AFIO and GPIOB models; the
test is the bus master, writing GPIOB.BSRR and reading GPIOB.IDR as firmware would. The
waveforms follow the I²C-bus specification (UM10204 §3.1): START = SDA falling while SCL is high,
STOP = SDA rising while SCL is high, data sampled while SCL is high, MSB first, ACK = SDA low on
the ninth clock. Register values and their encoding come from the BNO055 datasheet
(BST-BNO055-DS000 Table 4-2, §3.6.5.4: CHIP_ID 0xA0, ACC_ID 0xFB, MAG_ID 0x32, GYR_ID 0x0F,
Euler 16 LSB per degree) and the timing checks from its Table 3-6 (7 ms / 19 ms).
"""

from __future__ import annotations

import pytest

from psmat.emulator import PERIPHERAL_CLASSES, Bno055, I2cBus, I2cEvent, Misuse

RCC_APB2ENR, IOPBEN = 0x18, 1 << 3
CRL, IDR, BSRR = 0x00, 0x08, 0x10
SCL, SDA = 6, 7
OPEN_DRAIN_2MHZ = 0x6                     # MODE = 10 (2 MHz), CNF = 01 (open-drain)
MS = 1e-3


class StandIn:
    """The machine services the models use: now_s, pc, fail, rcc, peripheral."""

    def __init__(self) -> None:
        self.now_s = 0.0
        self.pc = 0x08000200
        self.hse_hz = 8e6
        self.uid = (1, 2, 3)
        self.nvic = self
        self.models = {}
        for cls in PERIPHERAL_CLASSES:
            if cls.__name__ in ("Rcc", "Flash", "Afio", "GpioB"):
                model = cls(self)
                self.models[model.name] = model
        self.rcc = self.models["RCC"]

    def set_pending(self, irq: int) -> None:
        raise AssertionError(f"no interrupt expected, got IRQ {irq}")

    def fail(self, cls: type[Exception], text: str) -> None:
        raise cls(f"{text} at PC 0x{self.pc:08X}")

    def peripheral(self, name: str):
        return self.models[name]


class Master:
    """A bit-banging bus master on GPIOB pins 6 (SCL) and 7 (SDA), open-drain."""

    def __init__(self, machine: StandIn) -> None:
        self.m = machine
        self.gpio = machine.models["GPIOB"]
        rcc = machine.models["RCC"]
        rcc.write(RCC_APB2ENR, 4, rcc.read(RCC_APB2ENR, 4) | IOPBEN)
        self.line(SCL, 1)
        self.line(SDA, 1)
        crl = self.gpio.read(CRL, 4) & ~(0xFF << 4 * SCL)
        self.gpio.write(CRL, 4, crl | OPEN_DRAIN_2MHZ << 4 * SCL | OPEN_DRAIN_2MHZ << 4 * SDA)

    def line(self, pin: int, level: int) -> None:
        self.gpio.write(BSRR, 4, 1 << pin if level else 1 << (pin + 16))

    def sda_in(self) -> int:
        return self.gpio.read(IDR, 4) >> SDA & 1

    def start(self) -> None:
        self.line(SDA, 1)
        self.line(SCL, 1)
        self.line(SDA, 0)
        self.line(SCL, 0)

    def stop(self) -> None:
        self.line(SDA, 0)
        self.line(SCL, 1)
        self.line(SDA, 1)

    def bit(self, level: int) -> int:
        """Clocks one bit out (1 = release SDA); the SDA level read while SCL is high."""
        self.line(SDA, level)
        self.line(SCL, 1)
        seen = self.sda_in()
        self.line(SCL, 0)
        return seen

    def put(self, byte: int) -> bool:
        for k in range(7, -1, -1):
            self.bit(byte >> k & 1)
        return self.bit(1) == 0

    def get(self, ack: bool) -> int:
        byte = 0
        for _ in range(8):
            byte = byte << 1 | self.bit(1)
        self.bit(0 if ack else 1)
        return byte

    def write(self, address: int, *data: int) -> list[bool]:
        self.start()
        acks = [self.put(address << 1)] + [self.put(b) for b in data]
        self.stop()
        return acks

    def read(self, address: int, register: int, n: int) -> tuple[list[bool], list[int]]:
        self.start()
        acks = [self.put(address << 1), self.put(register)]
        self.start()                                      # repeated START
        acks.append(self.put(address << 1 | 1))
        data = [self.get(ack=k + 1 < n) for k in range(n)]
        self.stop()
        return acks, data


@pytest.fixture
def rig() -> tuple[StandIn, Master, I2cBus, Bno055]:
    machine = StandIn()
    bus = I2cBus(machine.models["GPIOB"], SCL, SDA, name="bus 0")
    sensor = Bno055(0x28)
    bus.attach(sensor)
    return machine, Master(machine), bus, sensor


def kinds(bus: I2cBus) -> list[tuple[str, int | None, bool | None]]:
    return [(e.kind, e.value, e.ack) for e in bus.log]


def test_idle_lines_read_high_through_the_pull_up(rig) -> None:
    machine, master, bus, _ = rig
    assert master.gpio.read(IDR, 4) >> SCL & 3 == 0b11
    master.line(SDA, 0)                                   # START with nothing else on the bus
    assert master.sda_in() == 0
    assert bus.log[-1].kind == "start"


def test_write_transaction_is_decoded_and_acknowledged(rig) -> None:
    machine, master, bus, sensor = rig
    machine.now_s = 1 * MS
    acks = master.write(0x28, 0x3B, 0x04)                 # UNIT_SEL = Euler in radians
    assert acks == [True, True, True]
    assert kinds(bus) == [("start", None, None), ("address", 0x50, True), ("write", 0x3B, True),
                          ("write", 0x04, True), ("stop", None, None)]
    assert sensor.registers[0x3B] == 0x04
    assert sensor.writes == [(1 * MS, 0x3B, 0x04)]
    assert all(isinstance(e, I2cEvent) and e.now_s == 1 * MS for e in bus.log)
    assert master.sda_in() == 1                           # the device let go after the ACK


def test_repeated_start_read_of_the_id_registers(rig) -> None:
    _, master, bus, _ = rig
    acks, data = master.read(0x28, 0x00, 4)
    assert acks == [True, True, True]
    assert data == [0xA0, 0xFB, 0x32, 0x0F]               # CHIP_ID, ACC_ID, MAG_ID, GYR_ID
    assert kinds(bus) == [("start", None, None), ("address", 0x50, True), ("write", 0x00, True),
                          ("start", None, None), ("address", 0x51, True),
                          ("read", 0xA0, True), ("read", 0xFB, True), ("read", 0x32, True),
                          ("read", 0x0F, False), ("stop", None, None)]


def test_absent_address_is_not_acknowledged(rig) -> None:
    _, master, bus, _ = rig
    acks = master.write(0x29, 0x3D, 0x0C)
    assert acks == [False, False, False]
    assert kinds(bus)[:2] == [("start", None, None), ("address", 0x52, False)]
    assert [e.kind for e in bus.log] == ["start", "address", "stop"]


def test_euler_registers_after_the_switch_to_ndof(rig) -> None:
    machine, master, _, sensor = rig
    sensor.set_euler(359.9375, -12.5, 45.0625)
    assert master.read(0x28, 0x1A, 6)[1] == [0] * 6       # CONFIGMODE: outputs are zero
    master.write(0x28, 0x3D, 0x0C)                        # NDOF at t = 0
    machine.now_s = 7.5 * MS
    # 359.9375 * 16 = 5759 = 0x167F; -12.5 * 16 = -200 = 0xFF38; 45.0625 * 16 = 721 = 0x02D1
    assert master.read(0x28, 0x1A, 6)[1] == [0x7F, 0x16, 0x38, 0xFF, 0xD1, 0x02]


def test_euler_in_radians(rig) -> None:
    machine, master, _, sensor = rig
    sensor.set_euler(90.0, 0.0, -180.0)
    master.write(0x28, 0x3B, 0x04)
    master.write(0x28, 0x3D, 0x0C)
    machine.now_s = 10 * MS
    # pi/2 * 900 = 1413.7 -> 1414 = 0x0586; -pi * 900 = -2827.4 -> -2827 = 0xF4F5
    assert master.read(0x28, 0x1A, 6)[1] == [0x86, 0x05, 0, 0, 0xF5, 0xF4]


def test_euler_read_before_the_7_ms_switching_time_is_misuse(rig) -> None:
    machine, master, _, _ = rig
    master.write(0x28, 0x3D, 0x0C)
    machine.now_s = 5 * MS
    with pytest.raises(Misuse, match=r"bus 0: BNO055 0x28: fusion output 0x1A read 5\.000 ms .*7 ms"):
        master.read(0x28, 0x1A, 6)


def test_configuration_write_outside_configmode_is_misuse(rig) -> None:
    machine, master, _, _ = rig
    master.write(0x28, 0x3D, 0x0C)
    machine.now_s = 30 * MS
    with pytest.raises(Misuse, match="register 0x3B written in operating mode 0x0C"):
        master.write(0x28, 0x3B, 0x00)


def test_configuration_write_before_the_19_ms_switch_to_config_is_misuse(rig) -> None:
    machine, master, _, sensor = rig
    master.write(0x28, 0x3D, 0x0C)
    machine.now_s = 10 * MS
    master.write(0x28, 0x3D, 0x00)                        # back to CONFIGMODE at 10 ms
    machine.now_s = 25 * MS
    with pytest.raises(Misuse, match=r"written 15\.000 ms after OPR_MODE = CONFIGMODE.*19 ms"):
        master.write(0x28, 0x3E, 0x00)


def test_configuration_write_after_the_19_ms_switch_is_accepted(rig) -> None:
    machine, master, _, sensor = rig
    master.write(0x28, 0x3D, 0x0C)
    machine.now_s = 10 * MS
    master.write(0x28, 0x3D, 0x00)
    machine.now_s = 30 * MS
    assert master.write(0x28, 0x3E, 0x01) == [True, True, True]
    assert sensor.registers[0x3E] == 0x01


def test_read_only_register_write_is_misuse(rig) -> None:
    _, master, _, _ = rig
    with pytest.raises(Misuse, match="register 0x00 is read-only"):
        master.write(0x28, 0x00, 0x12)


def test_a_booting_chip_does_not_answer() -> None:
    machine = StandIn()
    bus = I2cBus(machine.models["GPIOB"], SCL, SDA, name="bus 0")
    bus.attach(Bno055(0x29, boot_s=0.65))
    master = Master(machine)
    machine.now_s = 0.6
    assert master.write(0x29, 0x07, 0x00)[0] is False
    machine.now_s = 0.65
    assert master.write(0x29, 0x07, 0x00) == [True, True, True]


def test_scl_and_sda_changed_by_one_write_is_misuse(rig) -> None:
    _, master, _, _ = rig
    with pytest.raises(Misuse, match=r"bus 0: SCL \(pin 6\) and SDA \(pin 7\) changed by one write"):
        master.gpio.write(BSRR, 4, (1 << SCL | 1 << SDA) << 16)


def test_bad_set_up_is_refused(rig) -> None:
    machine, _, bus, _ = rig
    with pytest.raises(ValueError, match="address 0x28 already taken"):
        bus.attach(Bno055(0x28))
    with pytest.raises(ValueError, match="must be 0x28 or 0x29"):
        Bno055(0x30)
    with pytest.raises(ValueError, match="two pins"):
        I2cBus(machine.models["GPIOB"], 3, 3)
    with pytest.raises(ValueError, match="heading 3000.0 degrees does not fit"):
        Bno055().set_euler(3000.0, 0.0, 0.0)

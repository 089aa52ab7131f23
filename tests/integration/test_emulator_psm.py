"""The PSM image (``make -C firmware stm32 LINK=uart``) executed in the emulator (docs/spec.md §5
"Firmware executed"): the unmodified ELF on :class:`psmat.emulator.PsmBoard`, a mat of known
counts behind the board's multiplexer wiring, the host's side over USART1.

What is expected comes from outside the code under test: the clock tree and the link the
firmware's design states (HSE 8 MHz x 6 = 48 MHz, 1 Mbit/s, 100 Hz by default), RM0008's register
formulas (baud = PCLK2 / BRR, timer period = (PSC + 1)(ARR + 1) / TIMCLK), the thesis' scan order
(Code 2.5: the row multiplexer at address R-1-i, the column one at p), the protocol's encoders
(psmat.protocol, byte-exact to docs/protocol.md, tested against their own reference vectors) and
hand calculation (the serial, the XOR of the UID words). Every rate and period is read from the
device's own timestamps or the timer's registers, never from an instruction count: the emulated
time per instruction is an assumption of the emulator (cycles per instruction), not a fact.
Each test boots its own board (cheap) when it changes the device's state; the baseline run of a
few frames is shared.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("unicorn")
pytest.importorskip("elftools")

from psmat.emulator import BuildUnavailable, PsmBoard, build_images  # noqa: E402
from psmat.protocol import (CAL_RESUME, Frame, Gap, Opcode, Reply, Status, V2Decoder, cal_hold_arg,  # noqa: E402
                            encode_command, encode_v1, encode_v2, parse_identify)

#: the repository's firmware sources (the images are built from them, whether psmat is installed or not)
FIRMWARE = Path(__file__).resolve().parents[2] / "firmware"

#: the unique ID the board reports; its serial, the XOR of the words, worked out by hand byte by byte:
#: 12^0F^15 = 08, 34^0F^A5 = 9E, 56^0F^A5 = FC, 78^0F^A5 = D2 (a leading 0: the 8 digits are padded)
UID = (0x12345678, 0x0F0F0F0F, 0x15A5A5A5)
SERIAL = "089EFCD2"
#: a 16 x 16 mat whose 256 counts are all different (a swapped row/column or address bit shows)
MAT = np.random.default_rng(27).permutation(4096)[:256].reshape(16, 16).astype(np.uint16)
ROWS = COLS = 16                     # the image's mat (firmware/stm32/psm/main.c)
V2_FRAME = 16 + 2 * ROWS * COLS + 2  # header, cells, CRC (docs/protocol.md): 530 bytes
V1_FRAME = 2 + 2 * ROWS * COLS + 2   # FF FF, cells, check: 516 bytes
REPLY = 16 + 2 + 2                   # a reply without text
STEP_S = 0.5e-3                      # how far the host lets the board run between looks (s)


@pytest.fixture(scope="module")
def elf(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The PSM image, built once for the module (LINK=uart: the emulator models USART1)."""
    try:
        return build_images(tmp_path_factory.mktemp("firmware"), link="uart", source=FIRMWARE)["psm"]
    except BuildUnavailable as exc:
        pytest.skip(str(exc))


class Host:
    """A booted board and the host's side of its link: every byte decoded as it arrives."""

    def __init__(self, elf: Path, **kwargs: float) -> None:
        self.board = PsmBoard(elf, MAT, uid=UID, **kwargs)
        self.decoder = V2Decoder()
        self.events: list = []
        self._fed = 0
        # boot: the USART is configured (BRR set) before the host may talk to it
        usart = self.board.machine.peripheral("USART1")
        self.board.machine.run(until=lambda: usart.brr != 0, until_s=0.1)
        assert usart.brr != 0, "the image did not configure USART1 within 0.1 s"

    @property
    def now_s(self) -> float:
        return self.board.machine.now_s

    def pump(self) -> None:
        tx = self.board.tx
        self.events += self.decoder.feed(tx[self._fed:])
        self._fed = len(tx)

    def run_for(self, dt_s: float) -> None:
        self.board.run(self.now_s + dt_s)
        self.pump()

    def frames(self, since: int = 0) -> list[Frame]:
        return [e for e in self.events[since:] if isinstance(e, Frame)]

    def replies(self, since: int = 0) -> list[Reply]:
        return [e for e in self.events[since:] if isinstance(e, Reply)]

    def run_until_frames(self, n: int, since: int = 0, limit_s: float = 0.2) -> list[Frame]:
        """Runs until ``n`` frames have arrived after event ``since`` (at most ``limit_s`` more)."""
        end = self.now_s + limit_s
        while len(self.frames(since)) < n and self.now_s < end:
            self.run_for(STEP_S)
        frames = self.frames(since)
        assert len(frames) >= n, f"{len(frames)} of {n} frames in {limit_s} s"
        return frames

    def command(self, opcode: int, arg: int = 0, *, raw: bytes | None = None, replies: int = 1,
                limit_s: float = 0.05) -> tuple[int, list[Reply]]:
        """Sends a command (or ``raw`` bytes); runs until ``replies`` replies came back (at most
        ``limit_s``). The index of the first event after the sending, and the replies."""
        mark = len(self.events)
        self.board.send(encode_command(opcode, arg) if raw is None else raw)
        end = self.now_s + limit_s
        while len(self.replies(mark)) < replies and self.now_s < end:
            self.run_for(STEP_S)
        return mark, self.replies(mark)

    def after(self, reply: Reply) -> int:
        """Index of the first event after ``reply``: the device's output once it executed the command."""
        return next(k for k, e in enumerate(self.events) if e is reply) + 1


def ok(reply: Reply, opcode: int) -> None:
    assert (reply.opcode, reply.status) == (opcode, Status.OK), reply


@pytest.fixture(scope="module")
def baseline(elf: Path) -> Host:
    """Three frames at the default rate, nothing sent to the board."""
    host = Host(elf)
    host.run_until_frames(3)
    return host


# -- boot ---------------------------------------------------------------------------------------

def test_boot_sets_the_clock_tree_the_link_and_the_scan_timer(baseline: Host) -> None:
    machine = baseline.board.machine
    rcc = machine.rcc
    assert rcc.clock_hz("SYSCLK") == 48e6                  # HSE 8 MHz x PLLMUL 6
    assert rcc.flash_acr & 7 == 1                           # RM0008 §3.3.3: 1 wait state, 24-48 MHz
    usart = machine.peripheral("USART1")
    assert rcc.clock_hz("PCLK2") / usart.brr == 1_000_000   # RM0008 §27.3.4: baud = PCLK2 / BRR
    tim2 = machine.peripheral("TIM2")
    period_s = (tim2.psc + 1) * (tim2.arr + 1) / rcc.clock_hz("TIMCLK1")
    assert period_s == pytest.approx(1 / 100, abs=1e-12)     # the default 100 Hz


# -- frames -------------------------------------------------------------------------------------

def test_every_cell_is_the_count_wired_to_the_address_the_firmware_selected(baseline: Host) -> None:
    board = baseline.board
    frames = baseline.frames()
    assert len(frames) >= 3 and all(f.valid for f in frames)
    for f in frames:
        assert f.data.shape == (ROWS, COLS)
        np.testing.assert_array_equal(f.data, MAT)
    # the conversions of each scan, in order: row multiplexer at 15 - i, column multiplexer at p
    # (Code 2.5), each reading the count the wiring gives for that address
    conv = board.conversions
    assert len(conv) >= len(frames) * ROWS * COLS
    for k in range(len(frames)):
        scan = conv[k * ROWS * COLS:(k + 1) * ROWS * COLS]
        addresses = [(c.row_address, c.col_address) for c in scan]
        assert addresses == [(ROWS - 1 - i, p) for i in range(ROWS) for p in range(COLS)]
        cells = np.array([board.cell(c.row_address, c.col_address) for c in scan]).reshape(ROWS, COLS)
        np.testing.assert_array_equal(frames[k].data, cells)


def test_frames_are_byte_identical_to_the_protocol_encoder(baseline: Host) -> None:
    tx = baseline.board.tx
    frames = baseline.frames()
    assert [f.seq for f in frames] == list(range(len(frames)))
    assert frames[0].offset == 0                      # nothing before the first frame
    for f in frames:
        assert tx[f.offset:f.offset + V2_FRAME] == encode_v2(MAT, f.seq, f.t_us)
    gaps = np.diff([f.t_us for f in frames])
    assert np.all(np.abs(gaps - 10_000) <= 1), gaps   # 100 Hz by the device's clock (µs)
    assert baseline.decoder.invalid == 0 and baseline.decoder.dropped == 0


def test_set_protocol_1_gives_v1_frames(elf: Path) -> None:
    host = Host(elf)
    _, replies = host.command(Opcode.SET_PROTOCOL, 1)
    ok(replies[0], Opcode.SET_PROTOCOL)
    reply = replies[0]
    host.run_for(0.035)                                # 3 periods: 3 v1 frames of 5.2 ms each
    tail = host.board.tx[reply.offset + REPLY:]
    n = len(tail) // V1_FRAME
    assert n >= 2
    assert tail[:n * V1_FRAME] == encode_v1(MAT) * n
    assert not host.frames(host.after(reply))          # no v2 frame after the switch


# -- commands -----------------------------------------------------------------------------------

def test_identify(elf: Path) -> None:
    host = Host(elf)
    _, replies = host.command(Opcode.IDENTIFY)
    assert len(replies) == 1
    ok(replies[0], Opcode.IDENTIFY)
    info = parse_identify(replies[0].text)
    assert info["serial"] == SERIAL == f"{UID[0] ^ UID[1] ^ UID[2]:08X}"
    assert info["device"] == "psm"
    assert (info["rows"], info["cols"], info["rate"], info["proto"], info["bits"]) == (16, 16, 100, 2, 12)
    assert info["r_o"] == 2200 and info["v_ref"] == 3.3   # the thesis' board (2.2 kΩ, 3.3 V)
    assert info["fw"].count(".") == 2


def test_set_rate_165_retimes_the_scan(elf: Path) -> None:
    host = Host(elf)
    _, replies = host.command(Opcode.SET_RATE, 165)
    ok(replies[0], Opcode.SET_RATE)
    # 1 MHz count (PSC = 47 at 48 MHz), ARR = 1e6 / 165 - 1 = 6059 (integer division): 6060 µs
    tim2 = host.board.machine.peripheral("TIM2")
    assert (tim2.psc, tim2.arr) == (47, 6059)
    frames = host.run_until_frames(4, host.after(replies[0]))
    assert all(f.valid for f in frames)
    gaps = np.diff([f.t_us for f in frames])
    assert np.all(np.abs(gaps - 6060) <= 1), gaps
    assert host.decoder.dropped == 0                     # 530 bytes per 6.06 ms fit 1 Mbit/s


def test_stop_stops_the_frames_and_start_resumes_them(elf: Path) -> None:
    host = Host(elf)
    before = host.run_until_frames(1)
    _, replies = host.command(Opcode.STOP)
    ok(replies[0], Opcode.STOP)
    stop = replies[0]
    host.run_for(0.035)                                  # 3.5 periods
    assert len(host.board.tx) == stop.offset + REPLY     # not a byte after the reply
    last = host.frames()[-1].seq
    assert last >= before[-1].seq
    _, replies = host.command(Opcode.START)
    ok(replies[0], Opcode.START)
    frames = host.run_until_frames(2, host.after(replies[0]))
    assert [f.seq for f in frames[:2]] == [last + 1, last + 2]   # the count goes on
    assert not any(isinstance(e, Gap) for e in host.events)
    assert all(f.valid for f in frames)


def test_cal_hold_reads_the_held_cell_in_every_slot(elf: Path) -> None:
    host = Host(elf)
    i, p = 3, 11
    _, replies = host.command(Opcode.CAL_HOLD, cal_hold_arg(i, p))
    ok(replies[0], Opcode.CAL_HOLD)
    held = host.run_until_frames(2, host.after(replies[0]))
    for f in held:
        assert f.valid
        np.testing.assert_array_equal(f.data, np.full((ROWS, COLS), MAT[i, p]))
    _, replies = host.command(Opcode.CAL_HOLD, CAL_RESUME)
    ok(replies[0], Opcode.CAL_HOLD)
    resumed = host.run_until_frames(1, host.after(replies[0]))
    np.testing.assert_array_equal(resumed[0].data, MAT)


def test_a_command_with_a_bad_crc_is_ignored(elf: Path) -> None:
    # firmware/core/command.c: a failed CRC resyncs the parser and sends no reply
    host = Host(elf)
    bad = bytearray(encode_command(Opcode.SET_RATE, 50))
    bad[-1] ^= 0x01
    mark, replies = host.command(Opcode.SET_RATE, raw=bytes(bad), limit_s=0.005)
    assert replies == []
    _, replies = host.command(Opcode.IDENTIFY)
    assert len(host.replies(mark)) == 1                   # IDENTIFY's alone
    ok(replies[0], Opcode.IDENTIFY)
    assert parse_identify(replies[0].text)["rate"] == 100
    tim2 = host.board.machine.peripheral("TIM2")
    assert tim2.arr == 9999                               # 100 Hz: 1e6 / 100 - 1


def test_an_unknown_opcode_gets_unknown_opcode(elf: Path) -> None:
    host = Host(elf)
    _, replies = host.command(0x7F, 0x12345678)
    assert len(replies) == 1
    assert (replies[0].opcode, replies[0].status) == (0x7F, Status.UNKNOWN_OPCODE)


def test_garbage_between_two_commands_loses_neither(elf: Path) -> None:
    host = Host(elf)
    # garbage, including the start of a command that never completes and one cut short by the next
    stream = (b"\x00\xff\xa5\xa5\x5a\x02" + encode_command(Opcode.SET_RATE, 50)
              + b"\x5a\xa5\x5a\x02\x10\x03" + encode_command(Opcode.IDENTIFY) + b"\xa5\x5a\x13")
    _, replies = host.command(Opcode.SET_RATE, raw=stream, replies=2)
    assert len(replies) == 2
    ok(replies[0], Opcode.SET_RATE)
    ok(replies[1], Opcode.IDENTIFY)
    assert parse_identify(replies[1].text)["rate"] == 50


def test_a_rate_beyond_the_link_shows_as_sequence_gaps_never_as_corrupt_frames(elf: Path) -> None:
    # 400 frames/s x 530 bytes x 10 bits = 2.12 Mbit/s > 1 Mbit/s: the transmit ring fills and
    # whole frames are dropped (link_write is all or nothing), each still counted by seq
    host = Host(elf)
    _, replies = host.command(Opcode.SET_RATE, 400)
    ok(replies[0], Opcode.SET_RATE)
    since = host.after(replies[0])
    frames = host.run_until_frames(10, since)
    assert host.decoder.invalid == 0
    assert all(f.valid for f in frames)
    for f in frames:
        np.testing.assert_array_equal(f.data, MAT)
    seqs = np.array([f.seq for f in frames])
    assert np.all(np.diff(seqs) >= 1)
    assert np.any(np.diff(seqs) > 1) and host.decoder.dropped > 0
    assert any(isinstance(e, Gap) for e in host.events[since:])
    # the missing frames were scanned at 400 Hz: 2500 µs of device time per seq step
    t = np.array([f.t_us for f in frames])
    assert np.all(np.abs(np.diff(t) - 2500 * np.diff(seqs)) <= 1)


# -- the analog side ------------------------------------------------------------------------------

def test_the_multiplexer_settles_at_least_1_us_before_every_conversion(elf: Path) -> None:
    # Within one slice of instructions every register access sees the slice's start time, so the
    # logged settling time is exact only to max_slice_s (1 µs by default, as long as the bound
    # itself): slices of 0.1 µs measure it to a tenth of the 1 µs the firmware promises.
    host = Host(elf, max_slice_s=0.1e-6)
    board = host.board
    board.machine.run(until=lambda: len(board.conversions) >= ROWS * COLS, until_s=host.now_s + 0.05)
    assert len(board.conversions) >= ROWS * COLS
    assert board.min_settle_s is not None and board.min_settle_s >= 1e-6

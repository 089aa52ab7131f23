"""What ``psmat firmware run`` does: the PSM image on the emulated board until N frames are out.

:func:`load_mat` reads and checks the mat's counts; :func:`capture` boots the image on
:class:`psmat.emulator.PsmBoard`, sends SET_RATE / SET_PROTOCOL as a host would once the image
has configured its USART, and runs until N complete frames have been sent, decoding the bytes as
they leave USART1. The statistics it keeps: the instructions the image executes in its scan
interrupt (TIM2: select, convert, encode, queue the frame; the USART interrupts nested in it
included), the frames' device timestamps, the emulated time.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..protocol import Frame, Opcode, Reply, Status, V1Decoder, V2Decoder, encode_command

__all__ = ["MAX_LINES", "MAX_COUNT", "IMAGE_SHAPE", "Capture", "load_mat", "capture"]

#: the board's multiplexers have 16 channels each (firmware/README.md "Pins and links")
MAX_LINES = 16
#: the 12-bit ADC's full scale
MAX_COUNT = 4095
#: the frame the PSM image sends (firmware/stm32/psm/main.c scans 16 x 16)
IMAGE_SHAPE = (16, 16)
#: emulated time (s) the image has to configure its USART before the host gives up
BOOT_LIMIT_S = 1.0
#: the longest a frame takes on the 1 Mbit/s link (s): 530 bytes x 10 bits
FRAME_ON_LINK_S = 5.3e-3
US_PER_S = 1_000_000


def load_mat(path: str | Path) -> NDArray[np.uint16]:
    """The counts of ``path`` (a .npy file): integers, R x C with 1 <= R, C <= 16, 0 ... 4095.

    Raises
    ------
    ValueError
        The file is not a .npy array of that kind; the message is one line.
    """
    try:
        arr = np.load(path, allow_pickle=False)
    except (OSError, ValueError, EOFError) as exc:
        raise ValueError(f"{path}: not a .npy array ({' '.join(str(exc).split())})") from None
    if not isinstance(arr, np.ndarray):
        raise ValueError(f"{path}: a .npz archive; give one .npy array of counts")
    if arr.dtype.kind not in "ui":
        raise ValueError(f"{path}: the counts must be integers (uint16), got dtype {arr.dtype}")
    if arr.ndim != 2 or not (1 <= arr.shape[0] <= MAX_LINES and 1 <= arr.shape[1] <= MAX_LINES):
        raise ValueError(f"{path}: the counts must be a rows x columns array with at most {MAX_LINES} of each "
                         f"(the board's multiplexers), got shape {arr.shape}")
    if arr.size and (int(arr.min()) < 0 or int(arr.max()) > MAX_COUNT):
        raise ValueError(f"{path}: the counts must be 0 ... {MAX_COUNT} (12-bit ADC), got {int(arr.min())} ... "
                         f"{int(arr.max())}")
    return arr.astype(np.uint16)


@dataclass
class Capture:
    """What a run produced.

    Attributes
    ----------
    tx : bytes
        Every byte the image sent on USART1 from power-up.
    frames : int
        Complete valid frames in ``tx`` (of the requested protocol).
    t_us : list of int
        The device timestamps of the v2 frames (µs; empty for v1).
    scan_instructions : int
        Instructions executed in the scan interrupt (TIM2), over ``scans`` scans.
    scans : int
        Scan interrupts completed.
    timer_period_us : float
        The scan timer's period from TIM2's PSC and ARR and its clock (µs).
    emulated_s : float
        Emulated time from power-up to the end of the last frame (s).
    cpu_s : float
        CPU time the emulation took (s).
    """

    tx: bytes = b""
    frames: int = 0
    t_us: list[int] = field(default_factory=list)
    scan_instructions: int = 0
    scans: int = 0
    timer_period_us: float = 0.0
    emulated_s: float = 0.0
    cpu_s: float = 0.0

    def instructions_per_frame(self) -> float | None:
        """Instructions per scan interrupt, None before a scan completed."""
        return self.scan_instructions / self.scans if self.scans else None

    def period_us(self) -> float | None:
        """Mean spacing of the frames' device timestamps (µs), None with fewer than two (or v1)."""
        return (self.t_us[-1] - self.t_us[0]) / (len(self.t_us) - 1) if len(self.t_us) > 1 else None


class _Watch:
    """Called between the machine's slices: decodes new bytes, times the scan interrupt."""

    def __init__(self, board: Any, decoder: Any, frames: int) -> None:
        self.board, self.decoder, self.want = board, decoder, frames
        self.machine = board.machine
        self.usart = self.machine.peripheral("USART1")
        self.tim2_bit = 1 << self.machine.peripheral("TIM2").irq
        self.events: list = []
        self.frames = 0
        self.fed = 0
        self.in_scan_since: int | None = None
        self.scan_instructions = 0
        self.scans = 0

    def __call__(self) -> bool:
        active = bool(self.machine.nvic.active & self.tim2_bit)
        if active and self.in_scan_since is None:
            self.in_scan_since = self.machine.instructions
        elif not active and self.in_scan_since is not None:
            self.scan_instructions += self.machine.instructions - self.in_scan_since
            self.scans += 1
            self.in_scan_since = None
        if len(self.usart.tx) != self.fed:
            new = self.decoder.feed(bytes(self.usart.tx[self.fed:]))
            self.fed = len(self.usart.tx)
            self.events += new
            self.frames += sum(1 for e in new if isinstance(e, Frame) and e.valid)
        return self.frames >= self.want


def capture(image: str | Path, counts: NDArray[np.uint16], *, frames: int, rate_hz: int | None = None,
            protocol: int | None = None) -> Capture:
    """Runs the PSM image until ``frames`` complete frames have been sent.

    Parameters
    ----------
    image : path
        The PSM image (``make -C firmware stm32 LINK=uart``: ``stm32-uart/psm.elf``).
    counts : ndarray (R, C) of uint16
        The mat (:func:`load_mat`); the cells of the image's 16 x 16 frame beyond it read full scale.
    frames : int
        Frames to wait for, >= 1.
    rate_hz : int, optional
        SET_RATE sent once the image has booted (frames/s, 1 ... 1000); default: the image's own.
    protocol : {1, 2}, optional
        SET_PROTOCOL sent once the image has booted; default: the image's own (v2).

    Raises
    ------
    psmat.emulator.EmulationError
        The image did something the emulator does not model, or answered a command with an error,
        or sent too few frames in the emulated time they need (one line).
    """
    from ..emulator import EmulationError, PsmBoard

    cpu0 = time.process_time()
    board = PsmBoard(image, counts)
    machine = board.machine
    usart = machine.peripheral("USART1")
    machine.run(until=lambda: usart.brr != 0, until_s=BOOT_LIMIT_S)
    if usart.brr == 0:
        raise EmulationError(f"{image}: USART1 not configured within {BOOT_LIMIT_S:g} s of emulated time (is it "
                             "the PSM image built with LINK=uart?)")
    sent = []
    if rate_hz is not None:
        sent.append((Opcode.SET_RATE, int(rate_hz)))
    if protocol is not None:
        sent.append((Opcode.SET_PROTOCOL, int(protocol)))
    for opcode, arg in sent:
        board.send(encode_command(opcode, arg))
    decoder = V1Decoder(IMAGE_SHAPE) if protocol == 1 else V2Decoder()
    watch = _Watch(board, decoder, frames)
    rate = rate_hz or 100
    limit_s = machine.now_s + 0.1 + frames * (2.0 / rate + FRAME_ON_LINK_S)
    machine.run(until=watch, until_s=limit_s)
    if watch.frames < frames:
        raise EmulationError(f"{image}: {watch.frames} of {frames} frames sent in {machine.now_s:.3g} s of "
                             f"emulated time")
    replies = [e for e in watch.events if isinstance(e, Reply)]
    for (opcode, arg), reply in zip(sent, replies):
        if reply.opcode != opcode or reply.status != Status.OK:
            raise EmulationError(f"{image}: {opcode.name} {arg} answered with opcode {reply.opcode}, status "
                                 f"{reply.status}")
    if len(replies) < len(sent):
        raise EmulationError(f"{image}: {len(replies)} replies to {len(sent)} commands")
    tim2, timclk = machine.peripheral("TIM2"), machine.rcc.clock_hz("TIMCLK1")
    return Capture(
        tx=board.tx, frames=watch.frames,
        t_us=[e.t_us for e in watch.events if isinstance(e, Frame) and e.valid and e.t_us is not None],
        scan_instructions=watch.scan_instructions, scans=watch.scans,
        timer_period_us=(tim2.psc + 1) * (tim2.arr + 1) / timclk * US_PER_S,
        emulated_s=machine.now_s, cpu_s=time.process_time() - cpu0)

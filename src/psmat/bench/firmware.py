"""Firmware benchmark: the PSM image's work per frame, counted instruction by instruction in the emulator.

Two PSM images are built from the repository's firmware sources (``make -C firmware stm32
LINK=uart``) into a temporary folder: the default one (table-driven CRC-16) and the baseline
(``EXTRA_CFLAGS=-DPM_CRC16_BITWISE``: the bitwise CRC, the firmware's earlier code). Each runs in
the emulator (:mod:`psmat.emulator`) on a 16x16 mat of known counts at the image's own 100 Hz
for a few frames; every frame it sends is decoded and checked against the mat.

What is counted (unicorn code hooks on address ranges from the ELF's symbols):

* instructions per frame: every instruction executed from one TIM2 interrupt entry (the first
  instruction of ``TIM2_IRQHandler``) to the next, in thread and handler mode alike: the scan,
  the frame's encoding and CRC, the USART interrupts that send the bytes and the main loop's
  wake-ups (the CPU executes nothing while it sleeps in WFI). The mean over the frames measured;
* of which in the CRC: the PC inside ``pm_crc16_update`` (its symbol's address and size);
* of which busy-waits: the PC inside ``delay_us``, inside ``micros`` when called from
  ``delay_us`` (LR inside ``delay_us``: the frame's time stamp, ``micros`` from the core, is
  not a wait), and inside the ADC's end-of-conversion loop in ``adc_read`` (from the target of
  its one backward conditional branch to that branch: ``ldr SR; lsls; bpl``);
* scan time: from the start of a frame's first conversion to the start of its last (the
  emulator's time, the board's conversion log);
* the fastest frame rate the CPU allows: SYSCLK / (instructions per frame x cycles per
  instruction). **This one figure rests on an assumption**, 1 cycle per instruction at the
  48 MHz SYSCLK (a Cortex-M3 takes more for loads, taken branches and flash wait states); the
  busy-waits are counted at that same assumption, as they wait a fixed time;
* the link's limit: the USART's baud rate / (10 bits per byte x the bytes of a 16x16 v2 frame),
  and the thesis' 165 Hz (§2.2.2) beside it;
* the shortest mux settling time before a conversion (the firmware promises at least 1 µs).
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

__all__ = ["main", "build_parser", "build_pair", "measure_image", "ImageFigures", "link_limit_hz",
           "v2_frame_bytes", "eoc_loop", "report", "THESIS_RATE_HZ", "CPI", "IMAGES"]

#: the thesis' frame rate (§2.2.2), for comparison
THESIS_RATE_HZ = 165.0
#: the cycles per instruction assumed for the one figure that needs it
CPI = 1.0
#: (name shown, EXTRA_CFLAGS) of the two images: psmat's and the baseline
IMAGES = (("table CRC (default)", ""), ("bitwise CRC (baseline)", "-DPM_CRC16_BITWISE"))
SHAPE = (16, 16)
#: first and last address of the STM32F103C8's 64 KiB flash, where the image runs (RM0008 §3.3.3)
FLASH = (0x08000000, 0x0800FFFF)


@dataclass
class ImageFigures:
    """What :func:`measure_image` found for one image (per frame: means over the frames measured)."""

    frames: int                     # frames measured (TIM2 entry to TIM2 entry)
    instructions: float             # per frame, all
    crc: float                      # per frame, PC in pm_crc16_update
    wait_delay: float               # per frame, delay_us and the micros it calls
    wait_eoc: float                 # per frame, adc_read's end-of-conversion loop
    scan_us: float                  # first to last conversion's start (µs, emulated)
    settle_us: float                # shortest mux settling before a conversion (µs, emulated)
    sysclk_hz: float
    baud: float                     # USART1's configured baud rate (bit/s)
    frame_bytes: float              # bytes sent per frame (USART1)
    frames_valid: int               # frames decoded with a good CRC and the mat's counts
    frames_sent: int
    per_frame: list[int] = field(default_factory=list)  # instructions of each frame

    @property
    def cpu_limit_hz(self) -> float:
        """SYSCLK / (instructions per frame x :data:`CPI`): the fastest rate the CPU allows (frames/s)."""
        return self.sysclk_hz / (self.instructions * CPI)


def v2_frame_bytes(shape: tuple[int, int] = SHAPE) -> int:
    """Bytes of a v2 PSM frame of ``shape`` (docs/protocol.md), from the host's encoder."""
    from ..protocol import encode_v2

    return len(encode_v2(np.zeros(shape, np.uint16), 0, 0))


def link_limit_hz(baud: float, frame_bytes: int) -> float:
    """Frames/s a UART link carries: ``baud`` / (10 bits per byte, 8N1, x ``frame_bytes``)."""
    return baud / (10.0 * frame_bytes)


def build_pair(build_dir: str | Path, source: str | Path | None = None) -> dict[str, Path]:
    """Build the two PSM images (:data:`IMAGES`) under ``build_dir`` from the firmware folder ``source``
    (default :func:`psmat.emulator.firmware_dir`); their ELF files by name.

    Raises
    ------
    psmat.emulator.BuildUnavailable
        No firmware sources, make or arm-none-eabi-gcc here.
    """
    from ..emulator import build_images

    return {name: build_images(Path(build_dir) / f"image{k}", link="uart", extra_cflags=flags, source=source)["psm"]
            for k, (name, flags) in enumerate(IMAGES)}


def eoc_loop(code: bytes, start: int) -> tuple[int, int]:
    """The end-of-conversion wait loop in ``adc_read``'s Thumb ``code`` (loaded at ``start``):
    ``(first, last)`` address, from the target of its one backward 16-bit conditional branch
    (``b<cond>`` T1, ``1101 cccc iiiiiiii``) to that branch.

    Raises
    ------
    ValueError
        When the function has no such branch, or more than one.
    """
    found = []
    for i in range(0, len(code) - 1, 2):
        half = code[i] | code[i + 1] << 8
        if half >> 12 == 0xD and (half >> 8) & 0xF < 0xE and half & 0x80:  # negative imm8
            target = start + i + 4 + (((half & 0xFF) - 0x100) << 1)
            found.append((target, start + i))
    if len(found) != 1:
        raise ValueError(f"adc_read: expected one backward conditional branch (the EOC wait), found {len(found)}")
    return found[0]


def _range(machine, name: str) -> tuple[int, int]:
    """First and last byte address of function ``name`` (ELF symbol and size)."""
    try:
        start, size = machine.symbols[name], machine.image.sizes[name]
    except KeyError:
        raise ValueError(f"{machine.image.path}: no symbol {name!r}") from None
    return start, start + size - 1


def measure_image(elf: str | Path, frames: int = 4, seed: int = 0) -> ImageFigures:
    """Run a PSM image in the emulator on a 16x16 mat of random counts for ``frames`` frames.

    Parameters
    ----------
    elf : path
        The image (``stm32-uart/psm.elf``).
    frames : int
        Frames measured, each from one TIM2 interrupt to the next (>= 1).
    seed : int
        Seed of the mat's counts (uniform 0 ... 4095).
    """
    from ..emulator import PsmBoard
    from ..protocol import V2Decoder

    if frames < 1:
        raise ValueError(f"frames must be >= 1, got {frames}")
    counts = np.random.default_rng(seed).integers(0, 4096, SHAPE)
    board = PsmBoard(elf, counts)
    m = board.machine
    crc_lo, crc_hi = _range(m, "pm_crc16_update")
    delay_lo, delay_hi = _range(m, "delay_us")
    micros_lo, micros_hi = _range(m, "micros")
    adc_lo, adc_hi = _range(m, "adc_read")
    eoc_lo, eoc_hi = eoc_loop(m.memory(adc_lo, adc_hi - adc_lo + 1), adc_lo)
    tim2 = m.symbols["TIM2_IRQHandler"]
    n = {"all": 0, "crc": 0, "delay": 0, "eoc": 0}
    marks: list[dict[str, int]] = []

    def count(key: str):  # noqa: ANN202 - a counter per range
        def hook(_address: int) -> None:
            n[key] += 1
        return hook

    def in_micros(_address: int) -> None:
        if delay_lo <= (m.reg("LR") & ~1) <= delay_hi:
            n["delay"] += 1

    def tick(_address: int) -> None:
        marks.append(dict(n, conversions=len(board.conversions), tx=len(board.tx)))

    m.on_instruction(count("all"), FLASH[0], FLASH[1])
    m.on_instruction(count("crc"), crc_lo, crc_hi)
    m.on_instruction(count("delay"), delay_lo, delay_hi)
    m.on_instruction(in_micros, micros_lo, micros_hi)
    m.on_instruction(count("eoc"), eoc_lo, eoc_hi)
    m.on_instruction(tick, tim2, tim2)
    m.run(until_s=2.0 + 0.01 * (frames + 1), until=lambda: len(marks) > frames)
    if len(marks) <= frames:
        raise RuntimeError(f"{elf}: {len(marks)} TIM2 interrupts in {m.now_s:.3f} s of emulated time, "
                           f"{frames + 1} needed")
    per = {k: [b[k] - a[k] for a, b in zip(marks, marks[1:])] for k in ("all", "crc", "delay", "eoc", "tx")}
    cells = SHAPE[0] * SHAPE[1]
    first = marks[0]["conversions"]  # the first frame measured starts with the first TIM2 entry
    conv = board.conversions[first:first + frames * cells]
    scans = [(conv[k + cells - 1].t_s - conv[k].t_s) * 1e6 for k in range(0, len(conv), cells)]
    decoder = V2Decoder()
    got = decoder.feed(board.tx) + decoder.finish()
    valid = sum(1 for f in got if f.valid and f.kind == "psm" and np.array_equal(f.data, counts))
    mean = statistics.fmean
    return ImageFigures(frames=frames, instructions=mean(per["all"]), crc=mean(per["crc"]),
                        wait_delay=mean(per["delay"]), wait_eoc=mean(per["eoc"]), scan_us=mean(scans),
                        settle_us=1e6 * (board.min_settle_s or 0.0), sysclk_hz=m.sysclk_hz,
                        baud=m.peripheral("USART1").baud(), frame_bytes=mean(per["tx"]),
                        frames_valid=valid, frames_sent=len(got), per_frame=per["all"])


def report(figures: dict[str, ImageFigures]) -> list[str]:
    """The table (one column per image, in :data:`IMAGES` order) and the comparison lines."""
    names = list(figures)
    frame_bytes = v2_frame_bytes()
    link = link_limit_hz(figures[names[0]].baud, frame_bytes)
    rows: list[tuple[str, object]] = [
        ("instructions per frame (TIM2 entry to entry)", lambda f: f"{f.instructions:,.0f}"),
        ("  in pm_crc16_update", lambda f: f"{f.crc:,.0f}"),
        ("  busy-wait: delay_us + its micros", lambda f: f"{f.wait_delay:,.0f}"),
        ("  busy-wait: ADC EOC loop in adc_read", lambda f: f"{f.wait_eoc:,.0f}"),
        ("  everything else", lambda f: f"{f.instructions - f.crc - f.wait_delay - f.wait_eoc:,.0f}"),
        ("scan time, first to last conversion (µs)", lambda f: f"{f.scan_us:,.1f}"),
        (f"CPU-bound frame rate at {CPI:g} cycle/instr (frames/s) *", lambda f: f"{f.cpu_limit_hz:,.1f}"),
        ("shortest mux settling (µs)", lambda f: f"{f.settle_us:.2f}"),
        ("bytes sent per frame (USART1)", lambda f: f"{f.frame_bytes:,.0f}"),
        ("frames decoded valid, the mat's counts", lambda f: f"{f.frames_valid} of {f.frames_sent}"),
    ]
    width = max(len(label) for label, _ in rows)
    cols = [max(len(name), 12) for name in names]
    lines = [f"{'':<{width}}  " + "  ".join(f"{name:>{w}}" for name, w in zip(names, cols))]
    for label, fmt in rows:
        lines.append(f"{label:<{width}}  " + "  ".join(f"{fmt(figures[name]):>{w}}" for name, w in zip(names, cols)))
    a, b = figures[names[0]], figures[names[1]]
    lines += [
        f"CRC instructions per frame, {names[1]} -> {names[0]}: {b.crc:,.0f} -> {a.crc:,.0f} "
        f"({b.crc / a.crc:.1f}x fewer); all instructions {b.instructions:,.0f} -> {a.instructions:,.0f}",
        f"link limit: {a.baud / 1e6:g} Mbit/s / (10 bits x {frame_bytes} bytes of a 16x16 v2 frame) = "
        f"{link:.1f} frames/s; the thesis' rate: {THESIS_RATE_HZ:g} Hz",
        f"* depends on the assumption of {CPI:g} cycle per instruction at SYSCLK {a.sysclk_hz / 1e6:g} MHz "
        "(the other figures are counts, or the emulator's time)",
    ]
    return lines


def build_parser(prog: str = "python -m psmat.bench firmware") -> argparse.ArgumentParser:
    """The benchmark's options (its help: this module's docstring, every default)."""
    from .._help import HelpFormatter, plain

    p = argparse.ArgumentParser(prog=prog, description=plain(__doc__), formatter_class=HelpFormatter)
    p.add_argument("--frames", type=int, default=4, help="frames measured per image, at the image's 100 Hz")
    p.add_argument("--seed", type=int, default=0, help="seed of the mat's random counts")
    return p


def main(argv: list[str] | None = None, prog: str = "python -m psmat.bench firmware") -> int:
    ap = build_parser(prog)
    args = ap.parse_args(argv)
    if args.frames < 1:
        ap.error(f"--frames must be >= 1, got {args.frames}")
    from ..emulator import BuildUnavailable
    from .machine import machine_info

    info = machine_info()
    print(f"firmware benchmark - {info['cpu']}, Python {info['python']}, psmat {info['psmat']}, {info['date']}")
    print(f"PSM image (LINK=uart) in the emulator, 16x16 mat, 100 Hz, {args.frames} frames per image", flush=True)
    with tempfile.TemporaryDirectory(prefix="psmat-bench-fw-") as tmp:
        try:
            images = build_pair(tmp)
        except BuildUnavailable as exc:
            print(f"{prog}: {exc}", file=sys.stderr)
            return 1
        except subprocess.CalledProcessError as exc:
            err = (exc.stderr or exc.stdout or "").strip().splitlines()
            print(f"{prog}: the firmware build failed: {err[-1] if err else exc}", file=sys.stderr)
            return 1
        figures = {name: measure_image(elf, args.frames, args.seed) for name, elf in images.items()}
    for line in report(figures):
        print(line)
    return 0

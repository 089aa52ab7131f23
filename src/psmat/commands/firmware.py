"""``psmat firmware``: the STM32 images built, and the PSM image executed in an emulator (docs/spec.md §5
"Firmware executed").

``psmat firmware build`` runs the firmware's Makefile (``make -C firmware stm32``) in a source checkout of
psmat, with make and arm-none-eabi-gcc on PATH, and prints where the PSM and IMU images are.

``psmat firmware run IMAGE.elf --mat COUNTS.npy --frames N --out BYTES.bin`` executes the unmodified PSM
image (built with ``--link uart``: the emulator models USART1) instruction by instruction, with register-level
models of the peripherals it touches, on a board whose mat reads the counts of COUNTS.npy: integers 0 ... 4095,
rows x columns, at most 16 x 16 (the cells of the image's 16 x 16 frame beyond a smaller mat read full scale).
Once the image has booted, ``--rate`` and ``--protocol`` are sent to it as SET_RATE and SET_PROTOCOL
commands, as a host would; when N complete frames have left it, every byte it sent on USART1 from
power-up is written to BYTES.bin. ``--stats`` prints the instructions the image executes per frame in
its scan interrupt, the frame period by the device's own timestamps, and the emulated and CPU seconds.
"""

from __future__ import annotations

import argparse
import sys

from . import _args

NAME = "firmware"
HELP = "build the STM32 images, or run the PSM image in the emulator on a mat of known counts"


def add_arguments(p: argparse.ArgumentParser) -> None:
    sub = p.add_subparsers(dest="action", required=True, metavar="{build,run}")
    b = sub.add_parser("build", help="build the PSM and IMU images (make -C firmware stm32) and print their paths",
                       description="Build the STM32 PSM and IMU images with the firmware's Makefile; needs the "
                                   "firmware sources (a clone of psmat), make and arm-none-eabi-gcc.")
    b.add_argument("--out", metavar="DIR", default="build",
                   help="the build folder: the images land in DIR/stm32-uart/ (uart) or DIR/stm32/ (usb)")
    b.add_argument("--link", choices=("uart", "usb"), default="uart",
                   help="the link the images talk over: USART1 at 1 Mbit/s (what the emulator runs) or USB")
    b.add_argument("--source", metavar="DIR", default=None,
                   help="the firmware folder of a psmat clone (default: the checkout psmat runs from, else "
                        "./firmware)")
    r = sub.add_parser("run", help="run the PSM image in the emulator and write the bytes it sends",
                       description="Execute the PSM image (LINK=uart) in the emulator on a mat of known counts "
                                   "and write every byte it sends on USART1 from power-up, once N frames are out.")
    r.add_argument("image", metavar="IMAGE.elf", type=_args.input_file,
                   help="the PSM image, e.g. build/stm32-uart/psm.elf")
    r.add_argument("--mat", metavar="COUNTS.npy", type=_args.input_file, required=True,
                   help="the mat: integer counts 0 ... 4095, rows x columns, at most 16 x 16")
    r.add_argument("--frames", type=_args.positive_int, required=True, help="complete frames to wait for")
    r.add_argument("--rate", type=_args.rate_hz, default=None,
                   help="SET_RATE sent once the image has booted; by default the image's 100 (Hz)")
    r.add_argument("--protocol", type=int, choices=(1, 2), default=None,
                   help="SET_PROTOCOL sent once the image has booted; by default the image's v2")
    r.add_argument("--out", metavar="BYTES.bin", required=True, help="the file of every byte sent on USART1")
    r.add_argument("--overwrite", action="store_true", help="replace an existing --out file")
    r.add_argument("--stats", action="store_true",
                   help="print instructions per frame, the frame period, emulated and CPU seconds")


def run(args: argparse.Namespace) -> int:
    return _build(args) if args.action == "build" else _run(args)


def _build(args: argparse.Namespace) -> int:
    import subprocess

    from ..emulator import BuildUnavailable, build_images

    try:
        images = build_images(args.out, link=args.link, source=args.source)
    except BuildUnavailable as exc:
        print(f"psmat firmware build: {_line(exc)}", file=sys.stderr)
        return 1
    except subprocess.CalledProcessError as exc:
        tail = (exc.stderr or exc.stdout or "").strip().splitlines()
        print(f"psmat firmware build: make failed: {_line(tail[-1]) if tail else exc}", file=sys.stderr)
        return 1
    except OSError as exc:
        print(f"psmat firmware build: {_line(exc)}", file=sys.stderr)
        return 1
    for name, path in images.items():
        print(f"{name}: {path}")
    return 0


def _run(args: argparse.Namespace) -> int:
    from .._atomic import OutputRefused, check_outputs, replacing
    from ..emulator import EmulationError
    from ._firmware_capture import capture, load_mat

    try:
        check_outputs([args.out], inputs=[args.image, args.mat], overwrite=args.overwrite)
        counts = load_mat(args.mat)
        result = capture(args.image, counts, frames=args.frames,
                         rate_hz=None if args.rate is None else int(args.rate), protocol=args.protocol)
        with replacing(args.out) as tmp:  # whole or not at all
            tmp.write_bytes(result.tx)
    except (OutputRefused, ValueError, OSError, EmulationError) as exc:
        print(f"psmat firmware run: {_line(exc)}", file=sys.stderr)
        return 1
    except ImportError as exc:
        print(f"psmat firmware run: {_line(exc)}; the emulator needs pip install 'psmat[firmware]'", file=sys.stderr)
        return 1
    print(f"{args.out}: {len(result.tx)} bytes, {result.frames} frames")
    if args.stats:
        per_frame = result.instructions_per_frame()
        period, source = result.period_us(), "device timestamps"
        if period is None:
            period, source = result.timer_period_us, "TIM2 PSC/ARR"
        print(f"instructions per frame {per_frame:.0f} (scan interrupt)" if per_frame is not None
              else "instructions per frame: no scan completed", end="")
        print(f", frame period {period:.1f} µs ({source}), {result.emulated_s:.4f} s emulated, "
              f"{result.cpu_s:.2f} s CPU")
    return 0


def _line(exc: BaseException | str) -> str:
    """An error as one line."""
    return " ".join(str(exc).split()) or type(exc).__name__

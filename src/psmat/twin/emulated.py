"""The twin serving the PSM firmware image itself, executed in the emulator (docs/spec.md §5
"Firmware executed"; ``psmat simulate --firmware IMAGE.elf``).

:class:`EmulatedTwin` runs the STM32 PSM image (``make -C firmware stm32 LINK=uart``:
``stm32-uart/psm.elf``) on :class:`psmat.emulator.PsmBoard` and serves what the image sends on
USART1 on the twin's link (a pseudo-terminal or TCP, :class:`~psmat.twin.serving.LinkServer`, as
:class:`~psmat.twin.serial_twin.SerialTwin`); the host's bytes go to the image's USART1 RX. The
mat the image scans is the twin's usual source (:class:`~psmat.twin.sources.PsmSource` through its
profile's physics): at the first conversion of every scan (every 256th: the image scans its 16x16
multiplexers whole, firmware/stm32/psm/main.c) the board's counts become the source's next frame.

The emulator runs in the twin's thread as fast as it can, in slices of emulated time, never ahead
of the wall clock; it is usually slower than real time, so the frames come at the rate it
reaches (a frame's ``t_us`` is the image's own clock, emulated time). With a ``progress`` stream
the twin writes that rate, frames per second of wall time, once a second and when it stops.

Bytes are forwarded as the USART shifts them out, not frame by frame: when the queue in front of
a slow host is full, a chunk is dropped (the decoders resync on the next frame). ``stats.ticks``
counts the image's scans; ``stats.frames_sent`` the scans made while the link took the bytes.
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import TextIO

import numpy as np

from .serving import Faults, LinkServer

__all__ = ["EmulatedTwin", "IMAGE_RATE_HZ", "IMAGE_SHAPE"]

#: the PSM image's frame rate from power-up (PSM_DEFAULT_RATE_HZ, firmware/core/psm_core.h)
IMAGE_RATE_HZ = 100.0
#: the multiplexers the image scans, whole, every frame (firmware/stm32/psm/main.c)
IMAGE_SHAPE = (16, 16)


class EmulatedTwin(LinkServer):
    """The PSM firmware image in the emulator, served on a pseudo-terminal or on TCP (127.0.0.1).

    Parameters
    ----------
    elf_path : path
        The PSM image built with ``LINK=uart`` (the emulator models USART1, not USB).
    source : optional
        The mat's counts, one frame per ``.next()`` (at most 16x16, 12-bit); default the
        ``scene`` on a ``shape`` mat (:meth:`PsmSource.named <psmat.twin.sources.PsmSource.named>`)
        at the image's 100 Hz.
    shape : (R, C)
        The default source's mat, at most 16x16; cells the mat lacks read full scale (open lines).
    scene, seed
        The default source's scene and seed.
    uid : (int, int, int)
        The 96-bit unique ID the image reads; it reports their XOR in hex as its serial.
    faults : Faults, optional
    buffer_bytes, tcp_port
        As :class:`~psmat.twin.serial_twin.SerialTwin`.
    progress : text stream, optional
        Where to write the rate the emulation reaches (frames/s of wall time), once a second
        and at the end; None: silent.
    slice_s : float
        Emulated time run between two looks at the link (s).

    Raises
    ------
    ValueError
        A source larger than 16x16, bad arguments.
    psmat.emulator.EmulationError
        The file is not an ARM ELF image.
    """

    def __init__(self, elf_path: str | Path, *, source=None, shape: tuple[int, int] = IMAGE_SHAPE,
                 scene: str = "sway", seed: int = 0,
                 uid: tuple[int, int, int] = (0x12345678, 0x9ABCDEF0, 0x0F1E2D3C),
                 faults: Faults | None = None, buffer_bytes: int = 65536, tcp_port: int | None = None,
                 progress: TextIO | None = None, slice_s: float = 0.002) -> None:
        from ..emulator import PsmBoard
        from .sources import PsmSource

        if not slice_s > 0:
            raise ValueError(f"slice_s must be > 0 s, got {slice_s}")
        self.kind = "psm"
        self.protocol = "v2"
        self.source = source if source is not None else PsmSource.named(scene, IMAGE_RATE_HZ, shape, seed=seed)
        first = self._frame()
        self.board = PsmBoard(elf_path, first, uid=tuple(uid))
        self.machine = self.board.machine
        self._usart = self.machine.peripheral("USART1")
        self._tim2 = self.machine.peripheral("TIM2")
        self._board_read = self.machine.peripheral("ADC1").source
        self.machine.peripheral("ADC1").source = self._convert
        self._next = first
        self._conversions = 0
        self.scans = 0
        self._host = bytearray()  # host bytes waiting for the image's USART to be set up
        self.progress = progress
        self.slice_s = float(slice_s)
        self._open_link(faults, buffer_bytes, tcp_port)

    def start(self) -> "EmulatedTwin":
        """Serve in a background thread; returns the twin."""
        return super().start()

    # -------------------------------------------------------------------- the board
    def _frame(self) -> np.ndarray:
        counts = np.asarray(self.source.next())
        if counts.ndim != 2 or counts.shape[0] > IMAGE_SHAPE[0] or counts.shape[1] > IMAGE_SHAPE[1]:
            raise ValueError(f"the PSM image scans at most {IMAGE_SHAPE[0]}x{IMAGE_SHAPE[1]} cells; the source "
                             f"gives frames of shape {counts.shape}")
        return np.clip(counts, 0, 4095).astype(np.uint16)

    def _convert(self, channel: int) -> int:
        """ADC1's source: at a scan's first conversion the mat takes the source's next frame."""
        if self._conversions % (IMAGE_SHAPE[0] * IMAGE_SHAPE[1]) == 0:
            self.board.counts = self._next if self.scans == 0 else self._frame()
            self.board.conversions.clear()  # the log of the scan under way only
            self.scans += 1
        self._conversions += 1
        return self._board_read(channel)

    @property
    def rate_hz(self) -> float:
        """The image's frame rate (frames/s of emulated time): TIM2's update rate once the image has
        set it, else the rate it starts with."""
        t = self._tim2
        if not t.arr or not self.machine.rcc.enabled("TIM2"):
            return IMAGE_RATE_HZ
        return self.machine.rcc.clock_hz("TIMCLK1") / ((t.psc + 1) * (t.arr + 1))

    def _to_image(self, data: bytes) -> None:
        """Host bytes to the image's USART1 RX now, or held until the image has set its baud rate."""
        self._host += data
        if self._usart.brr:
            self.board.send(bytes(self._host))
            self._host.clear()

    def _from_image(self, elapsed: float) -> None:
        """Forward what the image sent since the last call; the model's log is emptied as it goes."""
        tx = self._usart.tx
        if not tx:
            return
        data = bytes(tx)
        del tx[:]
        del self._usart.tx_times_s[:]
        new = self.scans - self.stats.ticks
        self.stats.ticks = self.scans
        taken = self.stats.bytes_sent + len(self._pending)
        self._send(data, elapsed, is_frame=False)
        if self.stats.bytes_sent + len(self._pending) > taken:
            self.stats.frames_sent += new
        else:
            self.stats.frames_unsent += new

    # -------------------------------------------------------------------- serving
    def _report(self, wall_s: float, scans: int, emulated_s: float, final: bool = False) -> None:
        if self.progress is None or wall_s <= 0:
            return
        what = "in all" if final else "in the last second"
        self.progress.write(f"emulated PSM image: {scans / wall_s:.1f} frames/s of wall time {what} "
                            f"({emulated_s / wall_s:.2f}x real time)\n")
        self.progress.flush()

    def _serve(self) -> None:
        self._t0 = time.monotonic()
        mark_t, mark_scans, mark_emu = self._t0, 0, 0.0
        m = self.machine
        try:
            while not self._stop.is_set():
                now = time.monotonic()
                elapsed = now - self._t0
                if self.faults.disconnect_after_s is not None and elapsed >= self.faults.disconnect_after_s:
                    self.disconnect()
                    return
                ahead = m.now_s - elapsed  # never run the image ahead of the wall clock
                data = self._poll_link(min(ahead, 0.05) if ahead > 0 else 0.0)
                if data:
                    self.stats.commands_bytes += len(data)
                    self._to_image(data)
                if ahead <= 0:
                    self.board.run(m.now_s + self.slice_s)  # at most one slice past the clock
                    if self._host and self._usart.brr:
                        self._to_image(b"")
                    self._from_image(elapsed)
                if now - mark_t >= 1.0:
                    self._report(now - mark_t, self.scans - mark_scans, m.now_s - mark_emu)
                    mark_t, mark_scans, mark_emu = now, self.scans, m.now_s
        except Exception as exc:  # reported, never silent
            if self._stop.is_set():  # the port was closed under us by stop()/disconnect()
                return
            self.stats.errors.append(f"{type(exc).__name__}: {exc}")
            raise
        finally:
            self._report(time.monotonic() - self._t0, self.scans, m.now_s, final=True)

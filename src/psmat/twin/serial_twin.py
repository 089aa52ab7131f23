"""The digital twin on a real pseudo-terminal or a TCP socket (docs/spec.md §5).

:class:`SerialTwin` runs a device's firmware core (``firmware/core``, compiled into
``psmat._core.firmware``) on the host, feeds its "ADC" from a source
(:mod:`psmat.twin.sources`) and serves its bytes on a pseudo-terminal
(:mod:`psmat.twin.pty_link`) or, where the system has none (Windows) or when asked, on a
TCP socket on 127.0.0.1 that a host opens as ``socket://127.0.0.1:PORT``
(:mod:`psmat.twin.tcp_link`), paced by the firmware's own timer rate — what a reader sees
is what it would see from the mat over USB: the same frames, the same replies to commands,
at the configured rate. A frame carries the timer's time of its tick (µs since the start, on
the grid of the frame period, as the MCU's timer-IRQ pacing gives, docs/spec.md §5), not the
moment the host's scheduler ran the tick; ticks that come more than a period late are lost,
like a timer's missed interrupts, and counted in ``late_ticks``.

A pty buffers unread data (about 20 KB; on TCP the system's socket buffers); the twin
writes without blocking, keeps up to ``buffer_bytes`` more queued for a host that is
briefly slow (as the device's and the host driver's buffers do on a real USB link), and
beyond that drops whole frames (counted in ``stats``) the way a device whose USB endpoint
is not polled does; on TCP, so are the frames scanned while no host is connected.

Fault injection (:class:`Faults`) for robustness tests: bit flips and dropped bytes at a
given rate per byte, stalls (the link goes silent for a while, frames scanned meanwhile
are lost, as on a device whose USB stalls), and a disconnect (the pty or the listening
socket goes away, as when the cable is pulled).

A do-it-yourself mat (``protocol="csv"``, docs/protocol.md) runs no firmware core: the twin
prints the source's counts as csv text lines at the rate, one frame per line (or ``R`` lines
per frame with ``csv_layout="block"``) after a header line, and ignores what the host sends,
as an Arduino sketch does. Its counts have the bits of the source's circuit; without a source
it is read through the circuit of the ``arduino16`` profile (an Arduino's 10-bit ADC at 5 V).

:attr:`SerialTwin.port` is what a host opens, with :func:`psmat.acquire.open_device` or
pyserial's ``serial_for_url``: a path to the pty (removed when the twin stops or is
disconnected, never handed out again) or the ``socket://`` URL.
"""

from __future__ import annotations

import math
import time

import numpy as np

from .serving import Faults, LinkServer, TwinStats

__all__ = ["Faults", "SerialTwin", "TwinStats", "CSV_PROFILE"]  # Faults, TwinStats: from .serving

#: the mat a csv twin without a source simulates: a do-it-yourself Arduino mat (firmware/arduino/README.md)
CSV_PROFILE = "arduino16"


def _source_bits(source) -> int:
    """ADC bits of a PSM source: its physics' circuit (also behind a calibration fixture), else 12."""
    physics = getattr(source, "physics", None) or getattr(getattr(source, "mat", None), "physics", None)
    circuit = getattr(physics, "circuit", None)
    return int(circuit.bits) if circuit is not None else 12


class SerialTwin(LinkServer):
    """A simulated device served on a pseudo-terminal or on TCP (127.0.0.1).

    Parameters
    ----------
    kind : {"psm", "imu", "daq"}
    rate_hz : float, optional
        Frame rate (the firmware's timer); default 100 Hz (PSM), 10 Hz (IMU), 2 Hz (DAQ).
        A SET_RATE command from the host changes it live.
    protocol : {"v1", "v2", "csv"}
        Framing of the PSM and IMU; ``"csv"`` (PSM only): a do-it-yourself mat's text lines,
        no firmware core, commands ignored.
    source : optional
        Where the firmware's ADC readings come from (``.next()``); default: the ``"sway"``
        scene for the PSM (:class:`~psmat.twin.sources.PsmSource`), the spine model for the
        IMU, the descending protocol for the DAQ.
    shape : (R, C)
        PSM array size.
    csv_layout : {"line", "block"}
        csv only: one frame per line, or ``R`` lines of ``C`` numbers closed by a blank line.
    faults : Faults, optional
    serial : str
        The serial number the device reports to IDENTIFY.
    buffer_bytes : int
        Bytes queued for a host that is slow to read, beyond the pty's own ~20 KB (what the
        device's and the host driver's buffers hold on a real link; Linux's tty layer keeps
        up to 64 KiB). When it is full, packets are dropped whole and counted.
    tcp_port : int, optional
        Serve on this TCP port of 127.0.0.1 (0: a free port the system picks) instead of a
        pseudo-terminal. Default None: a pseudo-terminal where the system has them, else a
        free TCP port (Windows).

    Attributes
    ----------
    port : str
        What a host opens: a path to the pty (a link in a private temporary folder, unique
        to this twin and removed by :meth:`stop` and :meth:`disconnect`), or the pyserial
        URL ``socket://127.0.0.1:PORT``.
    transport : {"pty", "tcp"}
        Which of the two serves.

    Raises
    ------
    ValueError
        Bad arguments (``tcp_port`` outside 0 ... 65535 included).
    OSError
        The TCP port cannot be listened on (in use).
    """

    def __init__(self, kind: str = "psm", rate_hz: float | None = None, protocol: str = "v2", *,
                 source=None, shape: tuple[int, int] = (16, 16), faults: Faults | None = None,
                 serial: str = "TWIN0001", scene: str = "sway", seed: int = 0,
                 buffer_bytes: int = 65536, tcp_port: int | None = None, csv_layout: str = "line") -> None:
        from .._core import firmware as fw
        from ..protocol import Opcode, encode_command
        from .sources import DaqSource, ImuSource, PsmSource

        if kind not in ("psm", "imu", "daq"):
            raise ValueError(f"kind must be 'psm', 'imu' or 'daq', got {kind!r}")
        if protocol not in ("v1", "v2", "csv"):
            raise ValueError(f"protocol must be 'v1', 'v2' or 'csv', got {protocol!r}")
        if protocol == "csv" and kind != "psm":
            raise ValueError(f"protocol 'csv' is a do-it-yourself psm mat's, not a {kind}'s")
        if csv_layout not in ("line", "block"):
            raise ValueError(f"csv_layout must be 'line' or 'block', got {csv_layout!r}")
        self.kind = kind
        self.protocol = protocol
        self.csv_layout = csv_layout
        proto = 1 if protocol == "v1" else 2
        default_rate = {"psm": 100.0, "imu": 10.0, "daq": 2.0}[kind]
        rate = float(rate_hz or default_rate)
        if not (0 < rate <= 1000):
            raise ValueError(f"rate must be in (0, 1000] Hz, got {rate}")
        self.bits: int | None = None
        if protocol == "csv":
            self.firmware = None  # an Arduino sketch: no firmware core, no commands
            if source is None:
                from ..profile import load_profile

                source = PsmSource.named(scene, rate, seed=seed, profile=load_profile(CSV_PROFILE).with_shape(shape))
            self.source = source
            self.bits = _source_bits(self.source)
            self._csv_header = True
        elif kind == "psm":
            self.firmware = fw.PsmFirmware(shape[0], shape[1], proto, serial)
            if int(rate) != rate:
                raise ValueError("the PSM's timer takes a whole number of frames per second")
            self.firmware.receive(encode_command(Opcode.SET_RATE, int(rate)))  # SET_RATE, as a host would
            self.source = source or PsmSource.named(scene, rate, shape, seed=seed)
        elif kind == "imu":
            self.firmware = fw.ImuFirmware(proto, serial)
            if rate != 10.0:
                self.firmware.receive(encode_command(Opcode.SET_RATE, int(rate)))
            self.source = source or ImuSource(rate, seed)
        else:
            self.firmware = fw.DaqFirmware()
            self.source = source or DaqSource(seed=seed)
        self._fixed_rate = rate if kind == "daq" or protocol == "csv" else None
        self._open_link(faults, buffer_bytes, tcp_port)

    def start(self) -> "SerialTwin":
        """Serve in a background thread; returns the twin."""
        return super().start()

    # -------------------------------------------------------------------- the device
    @property
    def rate_hz(self) -> float:
        return self._fixed_rate or float(self.firmware.rate_hz)

    def _tick(self, t_us: int) -> bytes:
        reading = self.source.next()
        if self.protocol == "csv":
            from ..protocol import encode_csv

            data = encode_csv(reading, self.csv_layout)
            if self._csv_header:  # the first line a sketch prints: a header of non-numbers
                self._csv_header = False
                R, C = np.shape(reading)
                data = f"# psmat csv twin {R}x{C} {self.bits}-bit {self.csv_layout}\n".encode("ascii") + data
            return data
        if self.kind == "daq":
            return self.firmware.tick(reading)
        return self.firmware.tick(reading, t_us & 0xFFFFFFFF)

    def _receive(self, data: bytes, t_us: int) -> bytes:
        self.stats.commands_bytes += len(data)
        if self.firmware is None:  # csv: the sketch reads nothing
            return b""
        if self.kind == "daq":
            return self.firmware.receive(data)
        return self.firmware.receive(data, t_us & 0xFFFFFFFF)

    def _serve(self) -> None:
        self._t0 = time.monotonic()
        next_t = self._t0
        try:
            while not self._stop.is_set():
                now = time.monotonic()
                elapsed = now - self._t0
                if self.faults.disconnect_after_s is not None and elapsed >= self.faults.disconnect_after_s:
                    self.disconnect()
                    return
                wait = next_t - now
                if wait > 0:
                    data = self._poll_link(min(wait, 0.05))
                    if data:
                        t_us = int((time.monotonic() - self._t0) * 1e6)
                        self._send(self._receive(data, t_us), elapsed, is_frame=False)
                    continue
                # the MCU stamps a scan with its timer's time, not with when the host got round to it
                t_us = int(round((next_t - self._t0) * 1e6))
                self.stats.ticks += 1
                self._send(self._tick(t_us), elapsed, is_frame=True)
                period = 1.0 / self.rate_hz
                next_t += period
                behind = now - next_t
                if behind > period:  # fell behind by more than a period: those ticks are lost, the grid kept
                    self.stats.late_ticks += 1
                    next_t += period * math.floor(behind / period)
        except Exception as exc:  # reported, never silent
            if self._stop.is_set():  # the port was closed under us by stop()/disconnect()
                return
            self.stats.errors.append(f"{type(exc).__name__}: {exc}")
            raise

"""One API for the three devices: the PSM mat, the material DAQ and the spine IMUs.

A :class:`Device` owns a serial port (pyserial), a reader thread that feeds every chunk
into the device's decoder (:class:`~psmat.acquire.StreamDecoder`) and a bounded
ring buffer of decoded frames (:class:`~psmat.acquire.FrameRing`). Lifecycle
(after brainflow's Board): :func:`open_device` opens the port and identifies the device;
:meth:`Device.start` starts streaming and buffering, :meth:`Device.stop` stops both,
:meth:`Device.close` releases the port. ``with open_device(...) as dev:`` starts on entry
and closes on exit.

A do-it-yourself mat speaking the csv protocol (``protocol="csv"``, docs/protocol.md) takes no
commands: it is never asked IDENTIFY, :meth:`Device.start`/:meth:`Device.stop` only gate the
buffer, and the command methods raise :class:`AcquireError`. Whatever the protocol, a PSM's
wire order of rows and columns (``row_order``/``col_order``) is undone on every frame, so the
buffer and a recorded session hold frames in logical order.
"""

from __future__ import annotations

import threading
from typing import Any, Literal, Sequence

import numpy as np
import serial

from ..protocol import (CAL_RESUME, DAQ_START, DAQ_STOP, Gap, Opcode, Reply, Status, cal_hold_arg,
                        encode_command, parse_identify)
from .._checks import is_int
from ._buffered import BufferedSource
from ._clock import HostClock
from ._errors import AcquireError, CommandRejected, CommandTimeout, DeviceDisconnected
from ._identify import describe, learn
from ._port import close_port, open_port, read_chunk
from ._stats import DeviceStats
from ._stream import Row, StreamDecoder, default_shape, frame_dtype

__all__ = ["Device", "DeviceStats", "open_device", "CSV_BAUDRATE"]

#: Default baud rate of a csv mat (an Arduino sketch's ``Serial.begin(115200)``); the binary
#: protocols default to 1 Mbit/s (USB CDC ignores it).
CSV_BAUDRATE = 115_200
_NO_COMMANDS = "a csv mat takes no commands (it streams its lines from power-up; docs/protocol.md, csv)"

_LINK_ERRORS = (serial.SerialException, OSError)
_JOIN_S = 1.0
_START_TRIES = 3  # START sent at most this many times when its reply does not come (a noisy link)


class _Waiter:
    __slots__ = ("opcode", "event", "reply")

    def __init__(self, opcode: int) -> None:
        self.opcode = opcode
        self.event = threading.Event()
        self.reply: Reply | None = None


class Device(BufferedSource):
    """A PSM mat, material DAQ or spine-IMU DAQ on a serial port (see :func:`open_device`).

    Attributes
    ----------
    port : str
        Port name or pyserial URL.
    kind : {"psm", "daq", "imu"}
    protocol : int or "csv"
        Current frame format, 1 or 2 (follows :meth:`set_protocol`; unused for the DAQ), or
        ``"csv"`` for a do-it-yourself mat's text lines.
    shape : tuple of int
        Frame shape: ``(R, C)`` PSM, ``(5, 3)`` IMU, ``(10,)`` DAQ.
    dtype : numpy.dtype
        uint16 counts (PSM, DAQ) or float32 degrees (IMU).
    description : dict
        Parsed IDENTIFY reply (``rows``, ``cols``, ``rate``, ``fw``, ``r_o``, ...). Fields
        the device did not report (no reply after the retries, or a reply that lacks them)
        are listed under ``"unknown"`` with a ``"note"`` saying why
        (:func:`._identify.describe`). Empty for the DAQ (no IDENTIFY) and when
        opened with ``identify=False``. A csv mat's says ``proto="csv"``, holds the
        ``rows``, ``cols`` and ``bits`` it was opened with, and lists the rest as unknown.
    bits : int
        ADC resolution a csv mat's counts are checked against (unused by v1/v2).
    row_order, col_order : tuple of int or None
        Wire order of a PSM's rows / columns: ``row_order[k]`` is the logical row of the
        ``k``-th row sent; None: the identity (no reordering, no copy).
    identified : bool
        Whether the device answered IDENTIFY (then :meth:`start` and :meth:`stop` wait for
        their replies).
    read_timeout_s : float
        Longest wait of :meth:`read` when ``n`` is given without a timeout (s).
    clock : HostClock
        Stamps ``host_time_s`` of every frame; devices recorded together share one
        (``clock=`` of :func:`open_device`), so that their times are on one host clock.
    """

    def __init__(self, port: str, kind: Literal["psm", "daq", "imu"] = "psm", protocol: str | int = "v2",
                 shape: tuple[int, ...] | None = None, baudrate: int | None = None, buffer_frames: int = 60_000,
                 reconnect: bool = False, *, reconnect_attempts: int | None = 20, reconnect_delay_s: float = 0.1,
                 reconnect_max_delay_s: float = 2.0, read_timeout_s: float = 1.0,
                 clock: HostClock | None = None, bits: int = 12, row_order: Sequence[int] | None = None,
                 col_order: Sequence[int] | None = None) -> None:
        if kind not in ("psm", "daq", "imu"):
            raise ValueError(f"kind must be 'psm', 'daq' or 'imu', got {kind!r}")
        protocols: dict[Any, int | str] = {"v1": 1, "v2": 2, 1: 1, 2: 2, "csv": "csv"}
        proto = None if isinstance(protocol, bool) else protocols.get(protocol)
        if proto is None:
            raise ValueError(f"protocol must be 'v1', 'v2' or 'csv', got {protocol!r}")
        if proto == "csv" and kind != "psm":
            raise ValueError(f"protocol 'csv' is a do-it-yourself psm mat's, not a {kind}'s")
        if not is_int(bits) or not 1 <= bits <= 16:
            raise ValueError(f"bits must be an integer 1 ... 16, got {bits!r}")
        if baudrate is None:
            baudrate = CSV_BAUDRATE if proto == "csv" else 1_000_000
        fixed = default_shape(kind)
        if shape is None:
            shape = fixed
        shape = tuple(int(x) for x in shape)
        if kind != "psm" and shape != fixed:
            raise ValueError(f"a {kind} frame has shape {fixed}, got {shape}")
        if kind == "psm" and (len(shape) != 2 or min(shape) < 1 or max(shape) > 255):
            raise ValueError(f"a psm frame shape is (R, C) with 1 <= R, C <= 255, got {shape}")
        if kind != "psm" and (row_order is not None or col_order is not None):
            raise ValueError(f"row_order/col_order are a psm mat's wire order, not a {kind}'s")
        self.row_order = _order("row_order", row_order, shape[0]) if kind == "psm" else None
        self.col_order = _order("col_order", col_order, shape[1]) if kind == "psm" else None
        self._unwire = _unwire(self.row_order, self.col_order)
        self.bits = int(bits)
        if reconnect_attempts is not None and reconnect_attempts < 1:
            raise ValueError("reconnect_attempts must be >= 1 or None")
        if not (reconnect_delay_s > 0 and reconnect_max_delay_s >= reconnect_delay_s):
            raise ValueError("need 0 < reconnect_delay_s <= reconnect_max_delay_s")
        self.port = str(port)
        self.kind = kind
        self.shape = shape
        self.dtype = frame_dtype(kind)
        self.baudrate = int(baudrate)
        self.reconnect = bool(reconnect)
        self.reconnect_attempts = reconnect_attempts
        self.reconnect_delay_s = float(reconnect_delay_s)
        self.reconnect_max_delay_s = float(reconnect_max_delay_s)
        self.read_timeout_s = float(read_timeout_s)
        self.description: dict[str, Any] = {}
        self.identified = False
        self._init_buffer(buffer_frames)
        self._decoder = StreamDecoder(kind, proto, shape, bits=self.bits)
        self.clock = clock if clock is not None else HostClock()
        self._ser: Any = None
        self._write_lock = threading.Lock()
        self._waiters: list[_Waiter] = []
        self._waiters_lock = threading.Lock()
        self._thread: threading.Thread | None = None
        self._halt = threading.Event()          # ends the reader thread (close)
        self._connected = False
        self._gone = False                      # disconnected for good
        self._started = False
        self._closed = False
        self._ignored = 0
        self._dropped_wire = 0
        self._last_row_buffered = False         # the last decoded row went to the buffer
        self._reconnects = 0
        self._last_error: str | None = None
        self._rate_asked: int | None = None     # the rate set_rate gave the device, given again on reconnect
        self._lost_at: float | None = None      # when the port was lost (self.clock), while it is
        self._last_gap: tuple[float, float] | None = None   # (lost at, s away) of the last reconnection

    # -- properties ----------------------------------------------------------------------
    @property
    def protocol(self) -> int | str:
        return self._decoder.protocol

    @property
    def commands(self) -> bool:
        """Whether the device takes commands (False for the csv protocol; the DAQ takes only ``s``/``f``)."""
        return self._decoder.protocol != "csv"

    @property
    def connected(self) -> bool:
        """Whether the port is open and being read."""
        return self._connected

    @property
    def started(self) -> bool:
        """Whether frames are being buffered (between :meth:`start` and :meth:`stop`)."""
        return self._started

    @property
    def serial(self) -> Any:
        """The underlying pyserial object (advanced use and ``loop://`` tests); None when closed."""
        return self._ser

    @property
    def stats(self) -> DeviceStats:
        """A snapshot of the counters (:class:`DeviceStats`)."""
        c = self._decoder.counters
        return DeviceStats(frames=c["frames"], invalid=c["invalid"], dropped_wire=self._dropped_wire,
                           dropped_buffer=self._ring.dropped, skipped_bytes=c["skipped"], replies=c["replies"],
                           reconnects=self._reconnects, ignored=self._ignored, mismatched=c["mismatched"],
                           bytes_in=c["bytes_in"], buffered=len(self._ring), connected=self._connected,
                           last_error=self._last_error, invalid_reasons=self._decoder.invalid_reasons,
                           lost_at=self._lost_at, last_gap=self._last_gap)

    def __repr__(self) -> str:
        state = "closed" if self._closed else ("started" if self._started else "open")
        proto = self.protocol if self.protocol == "csv" else f"v{self.protocol}"
        return (f"<Device {self.kind} {proto} {self.shape} on {self.port!r}, {state}, "
                f"{'connected' if self._connected else 'disconnected'}>")

    # -- lifecycle -----------------------------------------------------------------------
    def open(self, identify: bool = True, identify_timeout_s: float = 0.5, identify_attempts: int = 3) -> Device:
        """Open the port, start the reader thread and (PSM, IMU) ask IDENTIFY.

        Parameters
        ----------
        identify : bool
            Send IDENTIFY and wait up to ``identify_timeout_s`` s for the reply, at most
            ``identify_attempts`` times (a link that stalls at open loses the first ones).
            Fields that stay unknown are listed in :attr:`description` with a note (a thesis
            firmware never answers).
        identify_timeout_s : float
            Seconds per attempt.
        identify_attempts : int
            IDENTIFY commands sent at most, >= 1.

        Raises
        ------
        serial.SerialException
            The port cannot be opened.
        ValueError
            ``identify_attempts`` < 1.
        """
        if identify_attempts < 1:
            raise ValueError(f"identify_attempts must be >= 1, got {identify_attempts}")
        if self._closed:
            raise AcquireError(f"device on {self.port} is closed")
        if self._thread is not None:
            return self
        self._ser = open_port(self.port, self.baudrate)
        self._connected = True
        self._thread = threading.Thread(target=self._run, name=f"psmat-acquire({self.port})", daemon=True)
        self._thread.start()
        if not self.commands:
            self.description = describe(self.kind, {"device": self.kind, "proto": "csv", "rows": self.shape[0],
                                                    "cols": self.shape[1], "bits": self.bits},
                                        "a csv mat does not identify itself: rows, cols and bits are as opened, "
                                        "not reported by the device")
        elif identify and self.kind != "daq":
            self._identify(identify_timeout_s, identify_attempts)
            self._check_description()
        return self

    def _identify(self, timeout_s: float, attempts: int) -> None:
        """Ask IDENTIFY until it is answered or ``attempts`` ran out; set :attr:`description`."""
        note = f"no reply to IDENTIFY after {attempts} attempt{'s' if attempts > 1 else ''} of {timeout_s:g} s"
        reported: dict[str, Any] = {}
        for _ in range(attempts):
            try:
                reply = self.send_command(Opcode.IDENTIFY, timeout_s=timeout_s, check=True)
            except CommandTimeout:
                continue
            except CommandRejected as exc:
                self.identified = True
                note = f"IDENTIFY rejected: {exc}"
                break
            self.identified = True
            try:
                reported = parse_identify(reply.text)
                note = ""
            except ValueError as exc:
                note = f"IDENTIFY reply unreadable: {exc}"
            break
        if note:
            self._last_error = f"IDENTIFY: {note}"
        self.description = describe(self.kind, reported, note or None)

    def _check_description(self) -> None:
        d = self.description
        if self.kind == "psm" and "rows" in d and "cols" in d and (d["rows"], d["cols"]) != self.shape:
            self._last_error = (f"IDENTIFY reports a {d['rows']}x{d['cols']} mat but shape={self.shape}; frames of "
                                f"another shape are discarded (counted as mismatched)")

    def start(self) -> None:
        """Start buffering frames and tell the device to stream.

        PSM/IMU: sends START (waits for its reply when the device answered IDENTIFY, else
        just writes it); DAQ: sends ``s``; a csv mat: nothing (it streams from power-up).
        Frames decoded before :meth:`start` are not buffered (counted in ``stats.ignored``).

        Raises
        ------
        DeviceDisconnected
            The port is gone for good.
        CommandRejected, CommandTimeout
            The device refused START, or did not answer it in three tries of 1 s.
        """
        self._check_open()
        if self._gone:
            raise DeviceDisconnected(self.port, self._last_error)
        self._started = True
        self._send_start()

    def _send_start(self, wait: bool = True) -> None:
        if not self.commands:
            return
        if self.kind == "daq":
            self._write(DAQ_START)
        elif wait and self.identified:
            # START is idempotent: on a noisy link its reply (or the command) can be lost to a
            # corrupted byte, so it is sent again before the recording is given up
            for attempt in range(_START_TRIES):
                try:
                    self.send_command(Opcode.START)
                    break
                except CommandTimeout:
                    if attempt == _START_TRIES - 1:
                        raise
        else:
            self._write(encode_command(Opcode.START))

    def stop(self) -> None:
        """Stop buffering and tell the device to stop streaming; returns within about 1 s.

        Never raises for a lost link. Frames already buffered stay readable.
        """
        if not self._started:
            return
        self._started = False
        if self._closed or not self._connected or not self.commands:
            return
        try:
            if self.kind == "daq":
                self._write(DAQ_STOP)
            elif self.identified:
                self.send_command(Opcode.STOP, timeout_s=0.5, check=False)
            else:
                self._write(encode_command(Opcode.STOP))
        except (AcquireError, TimeoutError) as exc:
            self._last_error = f"STOP: {exc}"

    def close(self) -> None:
        """Stop, end the reader thread and close the port (idempotent; returns within ~1 s)."""
        if self._closed:
            return
        self.stop()
        self._closed = True
        self._halt.set()
        ser = self._ser
        if ser is not None:
            try:
                ser.cancel_read()
            except Exception:  # noqa: BLE001 - best effort wake-up
                pass
        if self._thread is not None and self._thread is not threading.current_thread():
            self._thread.join(_JOIN_S)
        self._close_port()
        self._connected = False
        self._ring.wake()
        self._fail_waiters()
        self.stop_recording()

    def _check_open(self) -> None:
        if self._closed:
            raise AcquireError(f"device on {self.port} is closed")
        if self._thread is None:
            raise AcquireError(f"device on {self.port} is not open (call open() or use open_device)")

    # -- commands ------------------------------------------------------------------------
    def send_command(self, opcode: int, arg: int = 0, timeout_s: float = 1.0, check: bool = True) -> Reply:
        """Send a v2 command and wait for the device's reply to that opcode.

        Parameters
        ----------
        opcode : int
            :class:`~psmat.protocol.Opcode`.
        arg : int
            uint32 argument.
        timeout_s : float
            Longest wait for the reply (s).
        check : bool
            Raise :class:`CommandRejected` when the reply's status is not OK.

        Returns
        -------
        psmat.protocol.Reply

        Raises
        ------
        CommandTimeout
            (a TimeoutError) no reply within ``timeout_s``.
        CommandRejected
            non-OK status (with ``check``).
        DeviceDisconnected
            The port is gone.
        AcquireError
            The device is closed, is a csv mat (no commands), or is the material DAQ (its only
            commands are ``s``/``f``: use :meth:`start`/:meth:`stop`).
        """
        if not self.commands:
            raise AcquireError(_NO_COMMANDS)
        if self.kind == "daq":
            raise AcquireError("the material DAQ takes no v2 commands, only 's'/'f' (use start()/stop())")
        self._check_open()
        packet = encode_command(opcode, arg)
        name = _opname(opcode)
        waiter = _Waiter(int(opcode))
        with self._waiters_lock:
            self._waiters.append(waiter)
        try:
            if opcode == Opcode.SET_PROTOCOL:
                self._decoder.expect_protocol_switch(int(arg))
            self._write(packet)
            if not waiter.event.wait(timeout_s):
                raise CommandTimeout(f"no reply to {name} from {self.kind} on {self.port} within {timeout_s:g} s")
        finally:
            with self._waiters_lock:
                if waiter in self._waiters:
                    self._waiters.remove(waiter)
        reply = waiter.reply
        if reply is None:  # woken by a lost link or close()
            raise DeviceDisconnected(self.port, self._last_error)
        if check and reply.status != Status.OK:
            raise CommandRejected(f"{self.kind} on {self.port} rejected {name} (arg {arg}): status "
                                  f"{_status_name(reply.status)}{': ' + reply.text if reply.text else ''}", reply)
        return reply

    def set_rate(self, hz: int) -> Reply:
        """Set the frame rate (frames/s, integer 1 ... 1000); AcquireError for a csv mat."""
        if not self.commands:
            raise AcquireError(_NO_COMMANDS)
        if isinstance(hz, bool) or int(hz) != hz or not 1 <= hz <= 1000:
            raise ValueError(f"rate must be an integer 1 ... 1000 frames/s, got {hz!r}")
        reply = self.send_command(Opcode.SET_RATE, int(hz))
        learn(self.description, "rate", int(hz))
        self._rate_asked = int(hz)
        return reply

    def set_protocol(self, protocol: int) -> Reply:
        """Switch the device's frame format to 1 or 2; the decoder follows at the reply (not for a csv mat)."""
        if not self.commands:
            raise AcquireError(_NO_COMMANDS)
        if protocol not in (1, 2) or isinstance(protocol, bool):
            raise ValueError(f"protocol must be 1 or 2, got {protocol!r}")
        try:
            reply = self.send_command(Opcode.SET_PROTOCOL, protocol)
        except BaseException:
            self._decoder.cancel_protocol_switch()
            raise
        learn(self.description, "proto", protocol)
        return reply

    def cal_hold(self, row: int, col: int) -> Reply:
        """Calibration mode: every cell reads the held row-column pair (0-based logical indices).

        The box selects multiplexer channels, so a mat wired in another order (``row_order``,
        ``col_order``) is asked for the wire position of the logical cell.
        """
        if self.kind != "psm":
            raise AcquireError("cal_hold is a PSM command")
        r, c = self.shape
        if not (0 <= row < r and 0 <= col < c):
            raise ValueError(f"cell ({row}, {col}) is outside the {r}x{c} mat")
        wire_row = row if self.row_order is None else self.row_order.index(row)
        wire_col = col if self.col_order is None else self.col_order.index(col)
        return self.send_command(Opcode.CAL_HOLD, cal_hold_arg(wire_row, wire_col))

    def cal_resume(self) -> Reply:
        """Leave calibration mode (full scans again)."""
        return self.send_command(Opcode.CAL_HOLD, CAL_RESUME)

    # -- internals -----------------------------------------------------------------------
    def _write(self, data: bytes) -> None:
        with self._write_lock:
            ser = self._ser
            if ser is None or not self._connected:
                raise DeviceDisconnected(self.port, self._last_error)
            try:
                ser.write(data)
                ser.flush()
            except _LINK_ERRORS as exc:
                raise DeviceDisconnected(self.port, str(exc)) from exc

    def _close_port(self) -> None:
        ser, self._ser = self._ser, None
        if ser is not None:
            close_port(ser)

    def _fail_waiters(self) -> None:
        with self._waiters_lock:
            for w in self._waiters:
                w.event.set()

    def _run(self) -> None:
        """Reader thread: read chunks, decode, buffer; handle a vanishing port."""
        try:
            while not self._halt.is_set():
                ser = self._ser
                try:
                    chunk = read_chunk(ser)
                except _LINK_ERRORS + (TypeError, AttributeError) as exc:
                    if self._halt.is_set():
                        break
                    self._lost(exc)
                    if not (self.reconnect and self._reconnect()):
                        break
                    continue
                if chunk:
                    self._handle(self._decoder.feed(chunk), self.clock.now())
        except Exception as exc:  # noqa: BLE001 - never let the reader die silently
            self._last_error = f"reader thread: {type(exc).__name__}: {exc}"
            self._gone = True
            self._connected = False
            self._ring.wake()
            self._fail_waiters()

    def _handle(self, events: list[Row | Reply | Gap], t: float) -> None:
        started = self._started
        rows = []
        for e in events:
            if isinstance(e, Row):
                rows.append(e)
                self._last_row_buffered = started
            elif isinstance(e, Gap):
                # a loss only between two buffered rows: what was received has a hole
                if started and self._last_row_buffered:
                    self._dropped_wire += e.count
            else:
                self._dispatch(e)
        if not rows:
            return
        if not started:
            self._ignored += len(rows)
            return
        n = len(rows)
        frames = np.stack([r.data for r in rows]).astype(self.dtype, copy=False)
        if self._unwire is not None:
            frames = frames[self._unwire]   # wire order -> logical order
        valid = np.fromiter((r.valid for r in rows), np.bool_, n)
        seq = np.fromiter((r.seq for r in rows), np.int64, n)
        dev = np.fromiter((r.device_time_us for r in rows), np.int64, n)
        host = np.full(n, t, np.float64)
        self._deliver(frames, host, valid, seq, dev)

    def _dispatch(self, reply: Reply) -> None:
        with self._waiters_lock:
            for w in self._waiters:
                if w.opcode == reply.opcode and w.reply is None:
                    w.reply = reply
                    w.event.set()
                    return

    def _lost(self, exc: BaseException) -> None:
        self._last_error = f"{type(exc).__name__}: {exc}"
        self._connected = False
        self._lost_at = self.clock.now()
        with self._write_lock:
            self._close_port()
        try:  # what the lost connection left held is judged; a failure there is said, not raised
            self._handle(self._decoder.reset(), self.clock.now())
        except Exception as exc:  # noqa: BLE001
            self._last_error += f"; its last bytes could not be read: {type(exc).__name__}: {exc}"
        if not self.reconnect:
            self._gone = True
        self._ring.wake()
        self._fail_waiters()

    def _reconnect(self) -> bool:
        """Re-open the port with exponential backoff; False when it gave up or was halted."""
        delay = self.reconnect_delay_s
        attempt = 0
        while self.reconnect_attempts is None or attempt < self.reconnect_attempts:
            if self._halt.wait(delay):
                return False
            attempt += 1
            try:
                ser = open_port(self.port, self.baudrate)
            except _LINK_ERRORS as exc:
                self._last_error = f"reconnect attempt {attempt}: {exc}"
                delay = min(delay * 2, self.reconnect_max_delay_s)
                continue
            with self._write_lock:
                self._ser = ser
                self._connected = True
            if self._lost_at is not None:
                self._last_gap = (self._lost_at, max(0.0, self.clock.now() - self._lost_at))
            self._lost_at = None
            self._reconnects += 1
            if self._rate_asked is not None:   # a box that lost power starts again at its own rate
                try:
                    self._write(encode_command(Opcode.SET_RATE, self._rate_asked))
                except AcquireError as exc:
                    self._last_error = f"rate after reconnect: {exc}"
            if self._started:
                try:
                    self._send_start(wait=False)   # the reader cannot wait for its own replies
                except AcquireError as exc:
                    self._last_error = f"restart after reconnect: {exc}"
            return True
        self._last_error = f"gave up reconnecting after {attempt} attempts ({self._last_error})"
        self._gone = True
        self._ring.wake()
        return False


def _order(name: str, order: Sequence[int] | None, n: int) -> tuple[int, ...] | None:
    """A wire order checked as a permutation of ``range(n)``; None for None or the identity."""
    if order is None:
        return None
    try:
        items = list(order)
    except TypeError:
        raise ValueError(f"{name} must be a sequence of {n} line indices, got {order!r}") from None
    if not all(is_int(k) for k in items) or sorted(int(k) for k in items) != list(range(n)):
        raise ValueError(f"{name} must be a permutation of 0 ... {n - 1} (each line once), got {items!r}")
    out = tuple(int(k) for k in items)
    return None if out == tuple(range(n)) else out


def _unwire(row_order: tuple[int, ...] | None, col_order: tuple[int, ...] | None) -> Any:
    """Index of a (T, R, C) batch that puts wire rows/columns in logical order, or None (identity).

    ``row_order[k]`` is the logical row of the ``k``-th row sent, so logical row ``j`` is wire
    row ``argsort(row_order)[j]``; likewise for the columns.
    """
    if row_order is None and col_order is None:
        return None
    rows = slice(None) if row_order is None else np.argsort(row_order)
    cols = slice(None) if col_order is None else np.argsort(col_order)
    if row_order is not None and col_order is not None:
        return (slice(None), rows[:, None], cols[None, :])  # type: ignore[index]
    return (slice(None), rows, cols)


def _opname(opcode: int) -> str:
    try:
        return f"{Opcode(opcode).name} (0x{int(opcode):02X})"
    except ValueError:
        return f"opcode 0x{int(opcode):02X}"


def _status_name(status: int | None) -> str:
    try:
        return Status(status).name  # type: ignore[arg-type]
    except (ValueError, TypeError):
        return repr(status)


def open_device(port: str, kind: Literal["psm", "daq", "imu"] = "psm", protocol: str | int = "v2",
                shape: tuple[int, ...] | None = None, baudrate: int | None = None, buffer_frames: int = 60_000,
                reconnect: bool = False, identify: bool = True, *, identify_timeout_s: float = 0.5,
                identify_attempts: int = 3, **options: Any) -> Device:
    """Open a device and start reading it.

    Parameters
    ----------
    port : str
        ``/dev/ttyACM0``, a pty such as ``/dev/pts/3``, ``COM4``, or a pyserial URL
        (``socket://127.0.0.1:5555`` - the twin on TCP, ``rfc2217://host:2217``, ``loop://``).
    kind : {"psm", "daq", "imu"}
        PSM mat, material DAQ (text lines, ``s``/``f``) or spine IMUs.
    protocol : {"v2", "v1", "csv"}
        Frame format the device streams (ignored for the DAQ); ``"csv"``: a do-it-yourself
        PSM mat printing text lines (docs/protocol.md, "csv"): no IDENTIFY, no commands.
    shape : tuple of int, optional
        PSM ``(R, C)``, default (16, 16); IMU (5, 3) and DAQ (10,) are fixed. A csv mat's
        shape is not on the wire: give it.
    baudrate : int, optional
        Bit/s (USB CDC ignores it); default 1 000 000, or :data:`CSV_BAUDRATE` (115 200) for csv.
    buffer_frames : int
        Ring-buffer capacity in frames (default 60 000: 6 min at 165 Hz, 31 MB for 16x16);
        when full the oldest frames are dropped and counted.
    reconnect : bool
        Re-open the port with backoff when it vanishes (``reconnect_attempts`` = 20,
        ``reconnect_delay_s`` = 0.1 doubling up to ``reconnect_max_delay_s`` = 2.0 s; pass
        them as keywords).
    identify : bool
        Ask IDENTIFY for :attr:`Device.description`, waiting up to ``identify_timeout_s`` s
        (0.5) per attempt, at most ``identify_attempts`` (3) times.
    **options
        Further keywords of :class:`Device` (``read_timeout_s``, reconnection settings,
        ``clock``: a :class:`HostClock` shared by devices recorded together; ``bits``: a csv
        mat's ADC resolution, 1 ... 16, default 12; ``row_order``/``col_order``: a PSM's wire
        order of rows/columns, undone on every frame).

    Returns
    -------
    Device
        Open, reader thread running, not started (call :meth:`Device.start` or use it as a
        context manager).

    Raises
    ------
    serial.SerialException
        The port cannot be opened.
    ValueError
        Bad arguments.
    """
    dev = Device(port, kind, protocol, shape, baudrate, buffer_frames, reconnect, **options)
    try:
        dev.open(identify=identify, identify_timeout_s=identify_timeout_s, identify_attempts=identify_attempts)
    except BaseException:
        dev.close()
        raise
    return dev

"""Acquisition from the three devices through one API (docs/spec.md §5): PSM mat, material DAQ, spine IMUs.

>>> with open_device("/dev/ttyACM0", kind="psm", protocol="v2") as dev:   # doctest: +SKIP
...     batch = dev.read(165, timeout_s=2.0)      # FrameBatch: frames (N, 16, 16) uint16, ...
...     print(dev.description, dev.stats)

* :func:`open_device` / :class:`Device` - lifecycle ``open`` (identify) / ``start`` / ``stop``
  / ``close``, a reader thread per device (protocols v1, v2 and a do-it-yourself mat's csv), a bounded ring buffer, commands, reconnection,
  an optional :class:`psmat.io.SessionWriter` hook (:meth:`Device.record_to`);
* :class:`FrameBatch` - frames with ``host_time_s``, ``valid``, ``seq``, ``device_time_us``;
* :class:`DeviceStats` - counters; errors :class:`DeviceDisconnected`,
  :class:`CommandTimeout`, :class:`CommandRejected` (all :class:`AcquireError`);
* :func:`find_devices` / :func:`is_psmat_port` - the psmat boxes among the serial ports;
  :data:`IDENTIFY_FIELDS` - what a box's IDENTIFY reply names, per kind;
* :func:`open_playback` / :class:`PlaybackDevice` - a recorded session played back through the
  same API at its recorded times (``speed``, ``pause``/``resume``/``seek``, ``loop``);
* :func:`open_port` / :func:`read_chunk` / :func:`close_port` - one port (a device path or a
  pyserial URL) as the reader thread uses it;
* Lab Streaming Layer (optional ``pylsl``): :class:`PressureOutlets` (a mat's pressure, CoP and
  marker outlets), :class:`LslInlet` (another program's stream, its samples on the host clock),
  :func:`open_lsl` / :class:`LslDevice` (such a stream with the Device API, for recording),
  :class:`LslClock` (the host clock against LSL's ``local_clock``), :func:`frame_times` (frames that
  arrived together spread by the device clock).

The code lives in private modules (``_device``, ``_stream``, ``_ring_buffer``, ...); the names
above are the package's API.
"""

from ._clock import HostClock
from ._device import CSV_BAUDRATE, Device, DeviceStats, open_device
from ._discover import FoundPort, find_devices, is_psmat_port
from ._errors import AcquireError, CommandRejected, CommandTimeout, DeviceDisconnected
from ._explain import invalid_line, link_line, silence_line
from ._identify import IDENTIFY_FIELDS
from ..io import frame_times  # (psmat.io: frames of one serial chunk, spread)
from ._lsl import LslClock, PressureOutlets
from ._lsl_inlet import LslChunk, LslDevice, LslInlet, open_lsl
from ._playback import PlaybackDevice, open_playback
from ._port import close_port, open_port, read_chunk
from ._recording import SessionRecorder
from ._ring_buffer import FrameBatch, FrameRing
from ._stream import StreamDecoder

__all__ = [
    "open_device", "find_devices", "FoundPort", "Device", "DeviceStats", "FrameBatch", "FrameRing", "StreamDecoder", "HostClock",
    "SessionRecorder", "AcquireError", "DeviceDisconnected", "CommandTimeout", "CommandRejected",
    "is_psmat_port", "IDENTIFY_FIELDS", "open_port", "read_chunk", "close_port", "CSV_BAUDRATE",
    "open_playback", "PlaybackDevice",
    "LslClock", "PressureOutlets", "frame_times", "LslInlet", "LslChunk", "LslDevice", "open_lsl",
    "invalid_line", "silence_line", "link_line",
]

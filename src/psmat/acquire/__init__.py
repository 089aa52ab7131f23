"""Acquisition from the three devices through one API (docs/spec.md §5): PSM mat, material DAQ, spine IMUs.

>>> with open_device("/dev/ttyACM0", kind="psm", protocol="v2") as dev:   # doctest: +SKIP
...     batch = dev.read(165, timeout=2.0)      # FrameBatch: frames (N, 16, 16) uint16, ...
...     print(dev.description, dev.stats)

* :func:`open_device` / :class:`Device` - lifecycle ``open`` (identify) / ``start`` / ``stop``
  / ``close``, a reader thread per device, a bounded ring buffer, commands, reconnection,
  an optional :class:`psmat.io.SessionWriter` hook (:meth:`Device.record_to`);
* :class:`FrameBatch` - frames with ``host_time_s``, ``valid``, ``seq``, ``device_time_us``;
* :class:`DeviceStats` - counters; errors :class:`DeviceDisconnected`,
  :class:`CommandTimeout`, :class:`CommandRejected` (all :class:`AcquireError`).
"""

from .clock import HostClock
from .device import Device, DeviceStats, open_device
from .discover import FoundPort, find_devices
from .errors import AcquireError, CommandRejected, CommandTimeout, DeviceDisconnected
from .recording import SessionRecorder
from .ring_buffer import FrameBatch, FrameRing
from .stream import StreamDecoder

__all__ = [
    "open_device", "find_devices", "FoundPort", "Device", "DeviceStats", "FrameBatch", "FrameRing", "StreamDecoder", "HostClock",
    "SessionRecorder", "AcquireError", "DeviceDisconnected", "CommandTimeout", "CommandRejected",
]

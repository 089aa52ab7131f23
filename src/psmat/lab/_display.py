"""The lab's display feed: a worker thread that takes the newest frames of a source, runs the
processing chain on them and publishes one message for the page, at most ``display_hz`` times
a second.

The recording never waits for it: the device's reader thread hands every frame to the session
writer (:meth:`psmat.acquire.Device.record_to`) and to the device's bounded ring buffer; this
worker drains the ring, keeps the newest frames (as many as its time budget lets it process,
the older ones are skipped and counted) and forgets the rest. A slow machine or a slow page
costs display frames only.

The message (JSON text, built once per update and shared by every WebSocket client)::

    {"type": "frame", "n": update number, "seq": device seq, "device_time_us": ...,
     "host_time_s": host time of the frame (s, Unix epoch), "shape": [R, C],
     "counts": base64 of uint16 little-endian, "pressure": base64 of float32 little-endian (kPa),
     "counts_range": [min, max], "pressure_max": kPa, "cop_cm": [x, y] or null,
     "trace": [[t_s, x_cm, y_cm], ...] (the CoP points since the previous message),
     "extent_cm": [x0, x1, y0, y1], "rates": {...}, "recording": bool}

Both images are in the mat's coordinates, ready for drawing with row 0 at the bottom
(:func:`psmat.live.mat_image`; ``extent_cm`` as :func:`psmat.live.mat_extent_cm`).
"""

from __future__ import annotations

import base64
import json
import math
import threading
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from ..acquire import DeviceDisconnected
from ..live import mat_extent_cm, mat_image
from ..live.view import SlidingRate
from ..process import Processor

__all__ = ["DisplayFeed"]

#: conductance of an unloaded cell subtracted before the sensor model (S), as psmat view's default
_G_REST = 1e-7
#: share of the display period the processing may take
_BUDGET = 0.5


class DisplayFeed:
    """Worker thread: newest frames of ``source`` → chain → one JSON message per update.

    Parameters
    ----------
    source : Device or PlaybackDevice
        Started; read with ``read(None, timeout_s)``.
    profile : psmat.Profile
        The mat's profile: geometry (cm), circuit.
    display_hz : float
        Most updates per second (> 0).
    publish : callable
        Called from the worker with each message's text (JSON).
    recording : callable
        Returns whether a recording is running (shown in each message).
    """

    def __init__(self, source: Any, profile: Any, display_hz: float, publish: Callable[[str], None],
                 recording: Callable[[], bool]) -> None:
        if not display_hz > 0:
            raise ValueError(f"display_hz must be > 0, got {display_hz!r}")
        self.source = source
        self.profile = profile
        self.period_s = 1.0 / float(display_hz)
        self._publish = publish
        self._recording = recording
        self.shape = tuple(int(x) for x in source.shape)
        self.geometry = profile.geometry if profile.geometry is not None and tuple(profile.geometry.shape) == \
            self.shape else None
        self._chain = Processor(self.shape, circuit=profile.circuit(), g_rest=_G_REST, geometry=self.geometry,
                                method="newton", threads=1)
        self.geometry = self._chain.geometry
        self.extent_cm = [float(v) for v in mat_extent_cm(self.geometry)]
        self.received = 0
        self.processed = 0
        self.skipped = 0
        self.updates = 0
        self.message: str | None = None
        #: the largest and smallest count of every valid frame received, and how many (psmat.process.adc_hint)
        self.max_count: int | None = None
        self.min_count: int | None = None
        self.valid_frames = 0
        self.started_s = time.monotonic()
        self._cost_s = 2e-3
        self._t_prev: float | None = None
        self._rx, self._proc, self._shown = SlidingRate(), SlidingRate(), SlidingRate()
        self._halt = threading.Event()
        self._thread = threading.Thread(target=self._run, name="psmat-lab-display", daemon=True)

    def start(self) -> DisplayFeed:
        self._thread.start()
        return self

    def stop(self) -> None:
        """Stop the worker (returns within about one display period plus one update)."""
        self._halt.set()
        if self._thread.is_alive() and self._thread is not threading.current_thread():
            self._thread.join(5.0)
        self._chain.close()

    @property
    def rates(self) -> dict[str, float | None]:
        """Frames/s received from the source, processed for display, and display updates/s
        (None until measurable)."""
        def v(r: SlidingRate) -> float | None:
            x = r.value
            return round(x, 2) if math.isfinite(x) else None
        return {"received_hz": v(self._rx), "processed_hz": v(self._proc), "displayed_hz": v(self._shown)}

    # ------------------------------------------------------------------ worker
    def _run(self) -> None:
        while not self._halt.is_set():
            t0 = time.monotonic()
            try:
                batch = self.source.read(None, timeout_s=self.period_s)
            except DeviceDisconnected as exc:
                self.message = str(exc)
                self._halt.wait(0.5)
                continue
            except Exception as exc:  # noqa: BLE001 - a closed source while switching: report, go on
                self.message = f"{type(exc).__name__}: {exc}"
                self._halt.wait(0.5)
                continue
            now = time.monotonic()
            stats = self.source.stats
            self.received += len(batch)
            self._rx.add(now, int(getattr(stats, "frames", 0)) + int(getattr(stats, "invalid", 0)))
            if len(batch):
                try:
                    text = self._update(batch)
                except Exception as exc:  # noqa: BLE001 - the display must not die on one bad batch
                    self.message = f"display: {type(exc).__name__}: {exc}"
                    text = None
                if text is not None:
                    self.updates += 1
                    self._shown.add(time.monotonic(), self.updates)
                    self._publish(text)
            self._proc.add(now, self.processed)
            self._halt.wait(max(0.0, self.period_s - (time.monotonic() - t0)))

    def _times(self, batch: Any) -> np.ndarray:
        dev = np.asarray(batch.device_time_us, np.int64)
        return np.where(dev >= 0, dev * 1e-6, np.asarray(batch.host_time_s, np.float64))

    def _update(self, batch: Any) -> str | None:
        frames = np.asarray(batch.frames)
        valid = np.asarray(batch.valid, bool)
        candidates = np.flatnonzero(valid)
        if candidates.size == 0:
            return None
        top, low = int(frames[candidates].max()), int(frames[candidates].min())  # every valid frame, shown or not
        self.max_count = top if self.max_count is None else max(self.max_count, top)
        self.min_count = low if self.min_count is None else min(self.min_count, low)
        self.valid_frames += int(candidates.size)
        fit = min(max(1, int(_BUDGET * self.period_s / max(self._cost_s, 1e-6))), 50)
        if candidates.size > fit:
            self.skipped += int(candidates.size - fit)
            candidates = candidates[-fit:]
        times = self._times(batch)[candidates]
        prev = np.concatenate([[np.nan if self._t_prev is None else self._t_prev], times[:-1]])
        dt = times - prev
        rate = float(getattr(self.profile, "rate_hz", 100.0) or 100.0)
        dt = np.where(np.isfinite(dt) & (dt > 0), dt, 1.0 / rate)
        self._t_prev = float(times[-1])
        t0 = time.perf_counter()
        out = self._chain.push(frames[candidates], dt)
        self._cost_s = 0.8 * self._cost_s + 0.2 * (time.perf_counter() - t0) / len(candidates)
        ok = out.usable
        self.processed += int(ok.sum())
        k = int(candidates[-1])
        last = len(candidates) - 1
        counts = mat_image(frames[k], self.geometry).astype("<u2")
        pressure = np.nan_to_num(mat_image(out.pressure_kpa[last], self.geometry), nan=0.0).astype("<f4")
        cop = out.cop_cm[last]
        trace = [[round(float(t), 4), round(float(x), 3), round(float(y), 3)]
                 for t, (x, y) in zip(times[ok], out.cop_cm[ok]) if math.isfinite(x) and math.isfinite(y)]
        msg = {"type": "frame", "n": self.updates + 1, "seq": int(np.asarray(batch.seq)[k]),
               "device_time_us": int(np.asarray(batch.device_time_us)[k]),
               "host_time_s": float(np.asarray(batch.host_time_s)[k]), "shape": list(counts.shape),
               "counts": base64.b64encode(counts.tobytes()).decode("ascii"),
               "pressure": base64.b64encode(pressure.tobytes()).decode("ascii"),
               "counts_range": [int(counts.min()), int(counts.max())], "pressure_max": float(pressure.max()),
               "cop_cm": [float(cop[0]), float(cop[1])] if np.all(np.isfinite(cop)) else None, "trace": trace,
               "extent_cm": self.extent_cm, "rates": self.rates, "recording": bool(self._recording())}
        return json.dumps(msg, separators=(",", ":"))

"""Live view of a pressure-sensitive mat (``psmat view``).

Three panels, refreshed a few tens of times per second:

1. **raw** - equivalent conductance ``G`` (mS) of the newest frame (docs/spec.md §2);
2. **pressure** - crosstalk removed (docs/spec.md §3), unloaded leakage ``g_rest`` subtracted, the
   inverse sensor model applied (docs/spec.md §4); in kPa, the current CoP marked;
3. **CoP** - the last ``history_s`` seconds of the centre of pressure (docs/spec.md §7,
   :func:`psmat.balance.cop`): M-L (x) and A-P (y) in cm, in the coordinates of the mat's
   profile (:class:`psmat.profile.Geometry`: pitch, origin, axis directions).

Both images are drawn in those coordinates too (:func:`psmat.live.mat_image`): whichever way a
profile runs its axes, x grows to the right and y upwards, and the CoP marker sits on the
loaded cells.

The numbers are those of the one processing chain, :class:`psmat.process.Processor`: the view
pushes the frames it shows with the time between them, and the chain carries the IECM warm
start and the sensor model's state from push to push. Open readings, short readings and
frames that failed their check on the wire follow the chain's policy (:mod:`psmat.process`);
the last two are counted in the status line as invalid / unusable and leave no CoP point.

Keeping up: every redraw takes all the frames that arrived since the previous one; every
``decimate``-th of them is a candidate, and as many of the newest candidates are processed
as fit in a time budget (60 % of the time since the previous update, at least ``budget_s``,
divided by the measured cost per frame). When the machine cannot keep up with the mat the
view therefore *decimates* - it processes the newest frames and skips older ones (the
sensor model is then stepped with the real time between the frames it sees) - and the
status line reports the effective processing rate beside the rate of frames received.
"""

from __future__ import annotations

import time
from collections import deque
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np
from numpy.typing import NDArray

from ..acquire import DeviceDisconnected
from ..circuit import Circuit
from ..process import Processor
from ..profile import Geometry, Profile, default_profile
from ..sensor import MPICreep
from ._mat_image import mat_extent_cm, mat_image

__all__ = ["LiveView", "ViewResult", "run_view", "FrameSource", "SlidingRate"]


#: matplotlib backends that draw no window.
NON_INTERACTIVE = frozenset({"agg", "pdf", "ps", "svg", "pgf", "cairo", "template"})


class FrameSource(Protocol):
    """What :class:`LiveView` needs from a device (:class:`psmat.acquire.Device` has it)."""

    def read(self, n: int | None = None, timeout_s: float | None = None) -> Any: ...

    @property
    def stats(self) -> Any: ...


class SlidingRate:
    """Events per second over a sliding window of cumulative counts.

    ``add(t, total)`` records the running total at time ``t`` (s); :attr:`value` is the rate
    (1/s) between the oldest sample kept and the newest, the oldest kept being the last one at
    least ``window_s`` seconds before the newest (NaN with fewer than two samples).
    """

    def __init__(self, window_s: float = 2.0) -> None:
        self.window_s = float(window_s)
        self._samples: deque[tuple[float, float]] = deque()

    def add(self, t: float, total: float) -> None:
        self._samples.append((t, float(total)))
        while len(self._samples) > 2 and t - self._samples[1][0] >= self.window_s:
            self._samples.popleft()

    @property
    def value(self) -> float:
        if len(self._samples) < 2:
            return float("nan")
        (t0, n0), (t1, n1) = self._samples[0], self._samples[-1]
        return (n1 - n0) / (t1 - t0) if t1 > t0 else float("nan")


@dataclass
class ViewResult:
    """How a :func:`run_view` session ended.

    Attributes
    ----------
    status : int
        Exit status: 0 closed by the user / ``seconds`` elapsed / Ctrl-C, 3 the port vanished.
    reason : str
        ``"seconds"``, ``"closed"``, ``"interrupted"`` or ``"disconnected"``.
    message : str
        A sentence for the user.
    updates : int
        Calls of :meth:`LiveView.update`.
    saved : str or None
        Screenshot path, when one was written.
    """

    status: int
    reason: str
    message: str
    updates: int
    saved: str | None = None


class LiveView:
    """Processing and matplotlib artists of the live view of one mat.

    Parameters
    ----------
    device : FrameSource
        A started :class:`psmat.acquire.Device`, or anything with ``read(n, timeout)``
        returning a :class:`~psmat.acquire.FrameBatch`, and ``stats``
        (``frames``, ``invalid``, ``dropped_wire``, ``dropped_buffer``).
    shape : (int, int), optional
        Mat shape (R, C); default ``device.shape``, else the geometry's, else the default
        profile's (the thesis' mat, 16 x 16).
    iecm : bool
        Remove crosstalk and compensate the sensor (the pressure panel). False shows the raw
        image and the CoP of the raw ``G`` only (for slow machines).
    decimate : int
        Process and draw every ``decimate``-th frame received (>= 1).
    history_s : float
        Length of the CoP trace, s.
    rate_hz : float, optional
        The mat's frame rate (frames/s), for frame times without a device clock (protocol v1);
        default ``device.description["rate"]``, else the profile's (else the default profile's).
    circuit : Circuit, optional
        Measurement chain; default the profile's (:meth:`psmat.Profile.circuit`), else ``Circuit()``.
    sensor : MPICreep, optional
        Sensor model; default the thesis' (Table 2.11).
    g_rest : float
        Conductance of an unloaded cell (S), subtracted before the sensor model; default
        1e-7 S (10 MΩ, the digital twin's leakage).
    pitch_cm : float, optional
        Cell pitch (cm) of a mat in the default orientation; not with ``geometry``.
    geometry : psmat.profile.Geometry, optional
        Where the cells are (cm): the CoP's coordinates and the images' extent. Default the
        profile's, else (without ``pitch_cm``) the default profile's for the shape.
    profile : psmat.Profile, optional
        The mat's profile: the default of ``geometry``, ``circuit`` and ``rate_hz``.
    budget_s : float
        Least processing time allowed per :meth:`update`, s (the budget is 60 % of the time
        since the previous update when that is more); beyond it older frames are skipped.
    port : str, optional
        Shown in the status line; default ``device.port``.
    fig : matplotlib.figure.Figure, optional
        Figure to draw into (cleared); default a new one from :mod:`matplotlib.pyplot`.

    Attributes
    ----------
    G : ndarray (R, C)
        Newest processed equivalent conductance, S (open readings at the open floor, NaN
        before the first frame).
    pressure_kpa : ndarray (R, C)
        Newest compensated pressure, kPa (NaN before the first frame, or without IECM).
    cop_t, cop_cm : ndarray (N,), (N, 2)
        CoP trace: frame time (s, device clock when known) and (M-L, A-P) in cm, in the
        coordinates of :attr:`geometry`.
    geometry : psmat.profile.Geometry
        Where the cells are (the processing chain's).
    pitch_cm : float
        Its pitch (cm).
    last_seq : int
        Device sequence number of the newest processed frame (-1 unknown).
    received, processed, unusable : int
        Frames read (valid or not), processed, and skipped as invalid / short.
    """

    def __init__(self, device: FrameSource, *, shape: tuple[int, int] | None = None, iecm: bool = True,
                 decimate: int = 1, history_s: float = 10.0, rate_hz: float | None = None,
                 circuit: Circuit | None = None, sensor: MPICreep | None = None, g_rest: float = 1e-7,
                 pitch_cm: float | None = None, budget_s: float = 0.04, port: str | None = None, fig: Any = None,
                 geometry: Geometry | None = None, profile: Profile | None = None) -> None:
        if int(decimate) != decimate or decimate < 1:
            raise ValueError(f"decimate must be a positive integer, got {decimate!r}")
        if not (history_s > 0 and budget_s > 0):
            raise ValueError("history_s and budget_s must be > 0")
        self.device = device
        if profile is not None:
            if profile.geometry is None:
                raise ValueError(f"profile {profile.name!r} describes a {profile.kind} device, not a mat")
            if geometry is None and pitch_cm is None:
                geometry = profile.geometry
            if circuit is None:
                circuit = profile.circuit()
        shape = (shape or getattr(device, "shape", None) or (geometry.shape if geometry is not None else None)
                 or default_profile().shape)
        if len(shape) != 2 or min(shape) < 2:
            raise ValueError(f"shape must be (R, C) with R, C >= 2, got {shape}")
        self.shape: tuple[int, int] = (int(shape[0]), int(shape[1]))
        self.use_iecm = bool(iecm)
        self.decimate = int(decimate)
        self.history_s = float(history_s)
        desc = getattr(device, "description", None) or {}
        self.rate_hz = float(rate_hz or desc.get("rate") or (profile or default_profile()).rate_hz)
        self._chain = Processor(self.shape, circuit=circuit, sensor=sensor, g_rest=g_rest, pitch_cm=pitch_cm,
                                geometry=geometry, method="newton" if self.use_iecm else None, threads=1)
        self.geometry: Geometry = self._chain.geometry
        self.pitch_cm = self.geometry.pitch_cm
        self.budget_s = float(budget_s)
        self.port = str(port if port is not None else getattr(device, "port", "?"))
        self._t_prev: float | None = None     # frame time of the previous pushed frame (s)
        self._cost_s = 1e-3                    # measured processing cost per frame (EMA, s)
        self.G = np.full(self.shape, np.nan)
        self.pressure_kpa = np.full(self.shape, np.nan)
        self._trace: deque[tuple[float, float, float]] = deque()
        self.last_seq = -1
        self.received = 0
        self.processed = 0
        self.unusable = 0
        self.skipped = 0          # candidates not processed for lack of time
        self.draws = 0
        self.updates = 0
        self.message = ""         # shown in the status line (e.g. disconnected)
        self._rx_rate, self._proc_rate, self._draw_rate = SlidingRate(), SlidingRate(), SlidingRate()
        self._last_frame_wall = time.monotonic()
        self._last_update: float | None = None
        self._limits_dirty = True
        self._limit_check = 0.0
        self._bg: Any = None
        self._build_figure(fig)

    # ------------------------------------------------------------------ properties
    @property
    def cop_t(self) -> NDArray[np.float64]:
        return np.array([r[0] for r in self._trace], np.float64)

    @property
    def cop_cm(self) -> NDArray[np.float64]:
        return np.array([r[1:] for r in self._trace], np.float64).reshape(-1, 2)

    @property
    def rates(self) -> dict[str, float]:
        """Frames/s received and processed, and display frames/s (NaN until measurable)."""
        return {"received": self._rx_rate.value, "processed": self._proc_rate.value, "display": self._draw_rate.value}

    @property
    def status_text(self) -> str:
        """The status line as drawn."""
        return self._status.get_text()

    # ------------------------------------------------------------------ processing
    def update(self, timeout: float = 0.0) -> bool:
        """Read the frames that arrived, process the newest ones, update the artists.

        Does not draw (see :meth:`draw`), so it runs headless.

        Parameters
        ----------
        timeout : float
            Longest wait for a first frame when none is buffered, s.

        Returns
        -------
        bool
            Whether a new frame was processed (the images changed).

        Raises
        ------
        DeviceDisconnected
            The port vanished and every frame it delivered has been shown.
        """
        self.updates += 1
        now = time.monotonic()
        batch = self.device.read(None, timeout_s=timeout)
        n = len(batch)
        first_index = self.received
        self.received += n
        stats = self.device.stats
        self._rx_rate.add(now, getattr(stats, "frames", self.received) + getattr(stats, "invalid", 0))
        changed = False
        if n:
            self._last_frame_wall = now
            # time for processing: the budget, or a share of the time since the last update
            since = now - self._last_update if self._last_update is not None else 0.0
            changed = self._process(batch, first_index, max(self.budget_s, 0.6 * min(since, 1.0)))
        self._last_update = now
        self._proc_rate.add(now, self.processed)
        self._update_artists(stats, now)
        return changed

    def _frame_times(self, batch: Any, first_index: int) -> NDArray[np.float64]:
        dev = np.asarray(batch.device_time_us)
        t = (first_index + np.arange(len(batch))) / self.rate_hz
        known = dev >= 0
        if known.all():
            return dev * 1e-6
        if known.any() or np.asarray(batch.seq).max(initial=-1) >= 0:
            seq = np.asarray(batch.seq)
            return np.where(known, dev * 1e-6, np.where(seq >= 0, seq / self.rate_hz, t))
        return t

    def _process(self, batch: Any, first_index: int, budget_s: float) -> bool:
        frames = np.asarray(batch.frames)
        valid = np.asarray(batch.valid, bool)
        idx = first_index + np.arange(len(frames))
        candidates = np.flatnonzero((idx % self.decimate == 0) & valid)
        self.unusable += int((~valid).sum())
        if candidates.size == 0:
            return False
        n_fit = min(max(1, int(budget_s / max(self._cost_s, 1e-6))), 200)
        if candidates.size > n_fit:
            self.skipped += int(candidates.size - n_fit)
            candidates = candidates[-n_fit:]
        times = self._frame_times(batch, first_index)[candidates]
        t0 = time.perf_counter()
        out = self._chain.push(frames[candidates], self._periods(times))
        cost = (time.perf_counter() - t0) / len(candidates)
        self._cost_s = 0.8 * self._cost_s + 0.2 * cost if self.processed else cost
        ok = out.usable
        self.unusable += int((~ok).sum())  # a short reading
        if not ok.any():
            return False
        last = int(np.flatnonzero(ok)[-1])
        self.G = out.G[last]
        if self.use_iecm:
            self.pressure_kpa = out.pressure_kpa[last]
        self.last_seq = int(np.asarray(batch.seq)[candidates[last]])
        self.processed += int(ok.sum())
        cops = out.cop_cm if self.use_iecm else out.cop_raw_cm
        for t, (x, y) in zip(times[ok], cops[ok]):
            self._trace.append((float(t), float(x), float(y)))
        t_new = float(times[last])
        while self._trace and (self._trace[0][0] < t_new - self.history_s or self._trace[0][0] > t_new):
            self._trace.popleft()
        return True

    def _periods(self, times: NDArray[np.float64]) -> NDArray[np.float64]:
        """Time since the previously pushed frame, s, for each frame pushed now (1/rate_hz for the
        first frame, or where the clock did not advance)."""
        prev = np.concatenate([[np.nan if self._t_prev is None else self._t_prev], times[:-1]])
        periods = times - prev
        self._t_prev = float(times[-1])
        return np.where(np.isfinite(periods) & (periods > 0), periods, 1.0 / self.rate_hz)

    # ------------------------------------------------------------------ figure
    def _build_figure(self, fig: Any) -> None:
        import matplotlib.pyplot as plt

        panels = 3 if self.use_iecm else 2
        if fig is None:
            fig = plt.figure(figsize=(5.0 * panels, 4.8))
        else:
            fig.clear()
        self.fig = fig
        extent = mat_extent_cm(self.geometry)  # the mat in its profile's coordinates (cm)
        span_cm = (min(extent[0], extent[2]), max(extent[1], extent[3]))
        gs = fig.add_gridspec(1, panels, left=0.8 / fig.get_figwidth(), right=0.98, bottom=0.12, top=0.80, wspace=0.35,
                              width_ratios=[1] * (panels - 1) + [1.5])
        blank = mat_image(np.zeros(self.shape), self.geometry)
        self.ax_raw = fig.add_subplot(gs[0, 0])
        self.im_raw = self.ax_raw.imshow(blank, origin="lower", cmap="viridis", extent=extent, vmin=0, vmax=1,
                                         interpolation="nearest")
        self.cb_raw = fig.colorbar(self.im_raw, ax=self.ax_raw, shrink=0.85, label="G (mS)")
        self.ax_raw.set_title("raw: equivalent conductance G\n(crosstalk included, open = open floor)", fontsize=10)
        self._label_mat_axes(self.ax_raw)
        self.ax_p = self.im_p = self.cb_p = self.cop_marker = None
        if self.use_iecm:
            self.ax_p = fig.add_subplot(gs[0, 1])
            self.im_p = self.ax_p.imshow(blank, origin="lower", cmap="magma", extent=extent, vmin=0, vmax=1,
                                         interpolation="nearest")
            self.cb_p = fig.colorbar(self.im_p, ax=self.ax_p, shrink=0.85, label="pressure (kPa)")
            self.ax_p.set_title("pressure: IECM + inverse sensor model\n(+ = centre of pressure)", fontsize=10)
            self._label_mat_axes(self.ax_p)
            (self.cop_marker,) = self.ax_p.plot([], [], "+", color="cyan", ms=14, mew=2)
        self.ax_cop = fig.add_subplot(gs[0, -1])
        (self.line_x,) = self.ax_cop.plot([], [], color="tab:blue", lw=1.3, label="M-L (x)")
        (self.line_y,) = self.ax_cop.plot([], [], color="tab:red", lw=1.3, label="A-P (y)")
        self.ax_cop.set_xlim(-self.history_s, 0.0)
        self.ax_cop.set_ylim(*span_cm)
        self.ax_cop.set_xlabel("time relative to the newest frame (s)")
        self.ax_cop.set_ylabel("CoP (cm)")
        what = "pressure" if self.use_iecm else "raw G (no IECM)"
        self.ax_cop.set_title(f"centre of pressure of the {what}, last {self.history_s:g} s", fontsize=10)
        self.ax_cop.grid(alpha=0.3)
        self.ax_cop.legend(loc="upper left", fontsize=8)
        self._status = fig.text(0.5, 0.965, f"psmat view: {self.port} - waiting for frames", ha="center", va="top",
                                fontsize=10, family="monospace")
        self._animated = [a for a in (self.im_raw, self.im_p, self.cop_marker, self.line_x, self.line_y,
                                      self._status) if a is not None]
        self._vmax = {"raw": 0.0, "p": 0.0}
        self._ylim = span_cm
        fig.canvas.mpl_connect("draw_event", self._on_draw)

    def _label_mat_axes(self, ax: Any) -> None:
        ax.set_xlabel("M-L x (cm)")
        ax.set_ylabel("A-P y (cm)")

    def _rescale(self, key: str, image: Any, data: NDArray[np.float64], now: float) -> None:
        """Colour limits with hysteresis: grow at once, shrink (to 1.2 x max) when < 40 % for a while."""
        finite = data[np.isfinite(data)]
        peak = float(finite.max()) if finite.size else 0.0
        vmax = self._vmax[key]
        if peak <= 0:
            return
        if peak > vmax or (peak < 0.4 * vmax and now >= self._limit_check):
            self._vmax[key] = 1.2 * peak
            image.set_clim(0.0, 1.2 * peak)
            self._limits_dirty = True

    def _update_artists(self, stats: Any, now: float) -> None:
        if self.processed:
            self.im_raw.set_data(mat_image(self.G * 1e3, self.geometry))
            self._rescale("raw", self.im_raw, self.G * 1e3, now)
            if self.im_p is not None:
                p = np.nan_to_num(self.pressure_kpa)
                self.im_p.set_data(mat_image(p, self.geometry))
                self._rescale("p", self.im_p, p, now)
            tr = np.array(self._trace, np.float64).reshape(-1, 3)
            if len(tr):
                t = tr[:, 0] - tr[-1, 0]
                self.line_x.set_data(t, tr[:, 1])
                self.line_y.set_data(t, tr[:, 2])
                if self.cop_marker is not None:
                    self.cop_marker.set_data(tr[-1:, 1], tr[-1:, 2])
                if now >= self._limit_check:
                    ok = tr[:, 1:][np.all(np.isfinite(tr[:, 1:]), axis=1)]
                    if len(ok):
                        lo, hi = float(ok.min()), float(ok.max())
                        y0, y1 = self._ylim
                        span = max(hi - lo, 1.0)
                        if lo < y0 or hi > y1 or (y1 - y0) > 4 * span:
                            self._ylim = (lo - 0.3 * span, hi + 0.3 * span)
                            self.ax_cop.set_ylim(*self._ylim)
                            self._limits_dirty = True
            if now >= self._limit_check:
                self._limit_check = now + 1.0
        self._status.set_text(self._format_status(stats, now))

    def _format_status(self, stats: Any, now: float) -> str:
        r = self.rates

        def f(v: float) -> str:
            return "-" if not np.isfinite(v) else f"{v:.1f}"

        lost = int(getattr(stats, "dropped_wire", 0)) + int(getattr(stats, "dropped_buffer", 0))
        proc = "IECM+sensor" if self.use_iecm else "raw only"
        line1 = (f"{self.port}   received {f(r['received'])} frames/s   invalid {int(getattr(stats, 'invalid', 0))}"
                 f"   lost {lost}   frames {self.received}")
        line2 = f"processed {f(r['processed'])} frames/s ({proc}"
        line2 += f", 1 in {self.decimate} frames)" if self.decimate > 1 else ")"
        line2 += f"   display {f(r['display'])} fps"
        if self.skipped:
            line2 += f"   skipped {self.skipped} (decimating to keep up)"
        if self.message:
            return f"{self.message}\n{line1}\n{line2}"
        if self.received and now - self._last_frame_wall > 1.0:
            line2 += f"   no frames for {now - self._last_frame_wall:.0f} s"
        return f"{line1}\n{line2}"

    # ------------------------------------------------------------------ drawing
    def _on_draw(self, event: Any) -> None:
        canvas = self.fig.canvas
        if getattr(canvas, "supports_blit", False) and not getattr(canvas, "is_saving", lambda: False)():
            try:
                self._bg = canvas.copy_from_bbox(self.fig.bbox)
            except Exception:  # noqa: BLE001 - a canvas that cannot copy: no blitting
                self._bg = None

    def draw(self, blit: bool = True) -> None:
        """Render the figure: blit the changing artists, or redraw all when limits changed."""
        canvas = self.fig.canvas
        self.draws += 1
        self._draw_rate.add(time.monotonic(), self.draws)
        if blit and self._bg is not None and not self._limits_dirty and getattr(canvas, "supports_blit", False):
            canvas.restore_region(self._bg)
            for a in self._animated:
                self.fig.draw_artist(a)
            canvas.blit(self.fig.bbox)
            return
        self._limits_dirty = False
        if blit and getattr(canvas, "supports_blit", False):
            # background without the changing artists, then the artists on top
            for a in self._animated:
                a.set_visible(False)
            canvas.draw()
            for a in self._animated:
                a.set_visible(True)
            for a in self._animated:
                self.fig.draw_artist(a)
            canvas.blit(self.fig.bbox)
        else:
            canvas.draw()

    def save(self, path: str) -> str:
        """Write a screenshot of the figure (PNG) and return its path; ``path`` gets the whole
        image or keeps what it had (:func:`psmat._atomic.replacing`)."""
        from .._atomic import replacing

        with replacing(path) as tmp:
            self.fig.savefig(tmp, dpi=110)
        return str(path)

    def close(self) -> None:
        """Stop the processing chain's IECM worker (the device is its owner's to close)."""
        self._chain.close()


def run_view(view: LiveView, *, seconds: float | None = None, interval_s: float = 0.05,
             save: str | None = None, interactive: bool | None = None,
             on_close: Any = None) -> ViewResult:
    """Drive a :class:`LiveView` until the window closes, ``seconds`` pass, Ctrl-C or the port vanishes.

    Parameters
    ----------
    view : LiveView
    seconds : float, optional
        Stop after this long (s); None runs until the window is closed (or Ctrl-C).
    interval_s : float
        Pause between redraws (s); the event loop runs meanwhile.
    save : str, optional
        PNG path for a screenshot of the figure at the end (also after a disconnection).
    interactive : bool, optional
        Show a window (default: when matplotlib's backend is an interactive one).
    on_close : callable, optional
        Called once at the end, before saving (e.g. stopping the device).

    Returns
    -------
    ViewResult
        Never raises for a vanished port: it becomes ``status`` 3 with a message.
    """
    import matplotlib
    import matplotlib.pyplot as plt

    if interactive is None:
        interactive = matplotlib.get_backend().lower() not in NON_INTERACTIVE
    closed = {"v": False}
    view.fig.canvas.mpl_connect("close_event", lambda _e: closed.__setitem__("v", True))
    if interactive:
        plt.show(block=False)
    t0 = time.monotonic()
    reason, status, message = "closed", 0, "window closed"
    try:
        while True:
            if closed["v"]:
                break
            if seconds is not None and time.monotonic() - t0 >= seconds:
                reason, message = "seconds", f"{seconds:g} s elapsed"
                break
            try:
                view.update(timeout=0.0 if interactive else interval_s)
            except DeviceDisconnected as exc:
                reason, status = "disconnected", 3
                message = f"DISCONNECTED: {exc}"
                view.message = message
                view._update_artists(view.device.stats, time.monotonic())
                break
            view.draw()
            if interactive:
                view.fig.canvas.flush_events()
                view.fig.canvas.start_event_loop(interval_s)
    except KeyboardInterrupt as exc:  # Ctrl-C, or SIGTERM/SIGHUP (psmat._signals.Terminated: "stopped by SIGTERM")
        reason, message = "interrupted", f"interrupted ({exc or 'Ctrl-C'})"
    finally:
        if on_close is not None:
            on_close()
        view.close()
    saved = None
    if save:
        saved = view.save(save)
    if interactive and reason == "disconnected" and not closed["v"]:
        try:  # show the message in the window for a moment; never wait on the user
            view.draw(blit=False)
            view.fig.canvas.flush_events()
            view.fig.canvas.start_event_loop(1.5)
        except Exception:  # noqa: BLE001
            pass
    plt.close(view.fig)
    return ViewResult(status, reason, message, view.updates, saved)

"""The lab's state in the server process: the source, the display feed, the recording, the replay.

One source is shown at a time: the live device (a mat on a port or the digital twin) or a
session being replayed. The recording takes the shown source's frames from its reader thread
(:meth:`psmat.acquire.Device.record_to`), never through the display. There is at most one
recording (one :class:`psmat.io.SessionWriter`) at a time; a page that reloads finds it running
(:meth:`LabSession.status`). Every file is named inside the data folder (:func:`._security.confine`).

All methods are thread-safe (one lock); the slow ones (opening and closing a session file, the
trial's sway metrics) are meant to run off the server's event loop.
"""

from __future__ import annotations

import dataclasses
import datetime as _dt
import math
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from .._folders import hidden
from ._calibrate import CalibrationWalk, parse_pairs
from ._display import DisplayFeed
from ._errors import LabConflict
from ._replay import Replay, open_replay, session_profile_of
from ._security import confine, safe_component

__all__ = ["LabSession", "LabConflict", "trial_sway"]

#: longest wait for the device's reader thread to finish the batch it was recording (s)
_DETACH_WAIT_S = 0.5


class LabSession:
    """The server's acquisition, recording and display state.

    Parameters
    ----------
    data_dir : path
        The data folder: sessions are written and listed there, and nowhere else.
    display_hz : float
        Most display updates per second.
    publish : callable
        Called (from the display worker) with each display message's JSON text.
    """

    def __init__(self, data_dir: str | Path, *, display_hz: float = 30.0,
                 publish: Callable[[str], None] | None = None) -> None:
        self.data_dir = Path(data_dir).resolve()
        self.display_hz = float(display_hz)
        self._publish_cb = publish or (lambda text: None)
        self._lock = threading.RLock()
        self.live: Any = None            # the live device, or None (--replay)
        self.live_profile: Any = None
        self.live_label = ""
        self.live_simulated = False
        self._set_fixture: Callable[[Any], None] | None = None
        self.walk: CalibrationWalk | None = None   # the calibration walk-through in progress
        self.calibration: Any = None     # the psmat.Calibration made in this server run (stored in recordings)
        self.calibration_path: Path | None = None
        self.replay: Replay | None = None
        self._feed: DisplayFeed | None = None
        self._writer: Any = None
        self._recorded_dev: Any = None
        self._rec_meta: dict[str, Any] = {}
        self._rec_t0 = 0.0
        self._last_stop: dict[str, Any] | None = None
        self.latest: str | None = None   # the newest display message (JSON text)
        self._closed = False

    # ------------------------------------------------------------------ sources
    @property
    def source(self) -> Any:
        """The device shown and recorded now: the replay's, else the live one."""
        return self.replay.device if self.replay is not None else self.live

    def attach_live(self, device: Any, profile: Any, label: str, *, simulated: bool = False,
                    set_fixture: Callable[[Any], None] | None = None) -> None:
        """Show a started live device (a mat or the twin: ``simulated``) of ``profile``; ``label``
        names it (its port). ``set_fixture`` switches the twin's calibration set-up
        (:class:`psmat.twin.CalibrationFixture`'s ``mode``) during a calibration walk-through."""
        with self._lock:
            self.live, self.live_profile, self.live_label = device, profile, label
            self.live_simulated = bool(simulated)
            self._set_fixture = set_fixture
            if self.replay is None:
                self._show(device, profile)

    def _show(self, device: Any, profile: Any) -> None:
        if self._feed is not None:
            self._feed.stop()
        self.latest = None
        self._feed = DisplayFeed(device, profile, self.display_hz, self._publish,
                                 recording=lambda: self._writer is not None).start()

    def _publish(self, text: str) -> None:
        self.latest = text
        self._publish_cb(text)

    def open_replay(self, name: str, speed: float = 1.0) -> dict[str, Any]:
        """Replay the session ``name`` (inside the data folder) instead of what is shown now."""
        path = confine(self.data_dir, name)
        if not path.is_file():
            raise FileNotFoundError(f"no session {name!r} in the data folder")
        return self.replay_file(path, speed)

    def replay_file(self, path: Path, speed: float = 1.0) -> dict[str, Any]:
        """Replay the session file ``path`` (not confined: the command line's ``--replay FILE``)."""
        with self._lock:
            if self._writer is not None:
                raise LabConflict("a recording is running: stop it before replaying a session")
            if self.walk is not None:
                raise LabConflict("a calibration is in progress: finish or cancel it before replaying a session")
            rep = open_replay(path, speed)
            try:
                prof = session_profile_of(path, rep.device)
            except Exception:
                rep.close()
                raise
            old, self.replay = self.replay, rep
            self._show(rep.device, prof)
            if old is not None:
                old.close()
            return rep.state()

    def close_replay(self) -> None:
        """End the replay; the live device (if any) is shown again."""
        with self._lock:
            if self._writer is not None and self.replay is not None:
                raise LabConflict("a recording of the replay is running: stop it first")
            rep, self.replay = self.replay, None
            if rep is None:
                raise LabConflict("no session is being replayed")
            if self.live is not None:
                self._show(self.live, self.live_profile)
            elif self._feed is not None:
                self._feed.stop()
                self._feed = None
            rep.close()

    def replay_do(self, action: str, value: Any = None) -> dict[str, Any]:
        """``play``, ``pause``, ``seek`` (``value`` s) or ``speed`` (``value``) on the replay."""
        with self._lock:
            rep = self.replay
            if rep is None:
                raise LabConflict("no session is being replayed (POST /api/replay/open first)")
            if action == "play":
                rep.play()
            elif action == "pause":
                rep.pause()
            elif action == "seek":
                rep.seek(value)
            elif action == "speed":
                rep.set_speed(value)
            else:
                raise ValueError(f"unknown replay action {action!r}")
            return rep.state()

    # ------------------------------------------------------------------ recording
    @property
    def recording(self) -> bool:
        return self._writer is not None

    def start_recording(self, subject: str, trial: str, note: str) -> Path:
        """Record the shown source into ``DATA/<subject>_<trial>_<UTC time>.h5``; the path.

        ``subject`` and ``trial`` are reduced to safe file-name components for the name
        (:func:`._security.safe_component`) and stored as given in the metadata.
        """
        from ..io import SessionWriter, journal_path

        for key, value in (("subject", subject), ("trial", trial), ("note", note)):
            if not isinstance(value, str):
                raise ValueError(f"{key} must be a string, got {type(value).__name__}")
        with self._lock:
            if self._writer is not None:
                raise LabConflict(f"a recording is running ({self._writer.path.name}): one at a time")
            if self.walk is not None:
                raise LabConflict("a calibration is in progress: finish or cancel it before recording")
            dev = self.source
            if dev is None:
                raise LabConflict("no device to record")
            if not getattr(dev, "connected", True):
                raise LabConflict("the device is disconnected")
            self.data_dir.mkdir(parents=True, exist_ok=True)
            stamp = _dt.datetime.now(_dt.timezone.utc).strftime("%Y%m%dT%H%M%SZ")
            base = f"{safe_component(subject)}_{safe_component(trial)}_{stamp}"
            k = 1
            while True:
                path = confine(self.data_dir, f"{base}{'' if k == 1 else f'-{k}'}.h5")
                if not (path.exists() or journal_path(path).exists() or journal_path(path, "events").exists()):
                    break
                k += 1
            replaying = self.replay is not None
            prof = self._shown_profile()
            meta = {"subject": subject, "trial": trial, "note": note, "app": "psmat lab",
                    "port": str(self.replay.path) if replaying else self.live_label,
                    "simulated": self.live_simulated and not replaying, "replayed": replaying}
            cal = self.calibration.to_dict() if self.calibration is not None and not replaying else None
            if cal is not None:
                meta["calibration_file"] = str(self.calibration_path)
            writer = SessionWriter(path, dev.shape, device=dict(dev.description or {}), metadata=meta, kind=dev.kind,
                                   profile=prof.to_dict() if prof is not None else None, calibration=cal)
            try:
                dev.record_to(writer)
            except BaseException:
                writer.close()
                raise
            self._writer, self._recorded_dev, self._rec_meta = writer, dev, meta
            self._rec_t0 = dev.clock.now()
            return path

    def _shown_profile(self) -> Any:
        return self._feed.profile if self._feed is not None else self.live_profile

    def add_marker(self, label: str) -> float:
        """Mark ``label`` in the recording at the host time now; that time (s)."""
        if not isinstance(label, str) or not label.strip():
            raise ValueError("a marker needs a label (non-empty text)")
        with self._lock:
            if self._writer is None:
                raise LabConflict("no recording is running: start one before marking events")
            t = float(self._recorded_dev.clock.now())
            self._writer.add_event(t, label)
            return t

    def stop_recording(self) -> dict[str, Any]:
        """Stop the recording and close its file; ``{"session", "name", "frames", "events", ...}``."""
        with self._lock:
            writer, dev = self._writer, self._recorded_dev
            if writer is None:
                raise LabConflict("no recording is running")
            self._writer = self._recorded_dev = None
            _detach(dev)
            t1 = dev.clock.now()
            frames, events = writer.n_frames, writer.n_events
            try:
                writer.close()
            finally:
                stats = dev.stats
            out = {"session": str(writer.path), "name": writer.path.name, "frames": int(frames),
                   "events": int(events), "duration_s": round(t1 - self._rec_t0, 3),
                   "metadata": dict(self._rec_meta), "device_counters": _counters(stats)}
            self._last_stop = out
            return out

    # ------------------------------------------------------------------ calibration
    def calibrate_start(self, pairs: Any = None, seconds: Any = 1.0) -> dict[str, Any]:
        """Begin the box's calibration walk-through (:mod:`._calibrate`) on the live device: its
        steps. An unfinished walk-through is replaced."""
        with self._lock:
            if self._writer is not None:
                raise LabConflict("a recording is running: stop it before calibrating the box")
            if self.replay is not None:
                raise LabConflict("a session is being replayed: close the replay before calibrating the box")
            if self.live is None:
                raise LabConflict("no live box to calibrate (psmat lab PORT or --simulate)")
            if self.live.kind != "psm":
                raise LabConflict(f"the electronics calibration is for a PSM box, not a {self.live.kind} device")
            old = self.walk
            if old is not None and old.busy:
                raise LabConflict("a calibration step is being recorded: wait for it or cancel")
            walk = CalibrationWalk(self.live, self.live_profile, parse_pairs(pairs, tuple(self.live.shape)),
                                   seconds, set_fixture=self._set_fixture)
            if old is not None:
                old.cancel()
            self.walk = walk
            return walk.state()

    def _walk(self) -> CalibrationWalk:
        with self._lock:
            if self.walk is None:
                raise LabConflict("no calibration in progress (POST /api/calibrate/start first)")
            return self.walk

    def calibrate_step(self, step: Any, row: Any = None, col: Any = None) -> dict[str, Any]:
        """Record one step (about the walk's ``seconds``; the display keeps running): its diagnostics."""
        return self._walk().record(step, row, col)

    def calibrate_finish(self) -> dict[str, Any]:
        """Estimate R_adc and R_mux from the recorded steps (``psmat calibrate``'s code) and write
        ``DATA/calibration/<serial or unknown>.json`` (whole or not at all); recordings started
        afterwards store it."""
        walk = self._walk()
        if walk.busy:
            raise LabConflict("a calibration step is being recorded: wait for it")
        if not walk.state()["ready"]:
            raise LabConflict("record the open step and at least one short step before finishing")
        log: list[str] = []
        try:
            cal = walk.estimate(lambda text: log.append(str(text).strip()))
        except (ValueError, RuntimeError) as exc:
            raise LabConflict(f"the calibration failed: {exc}") from exc
        path = confine(self.data_dir, f"calibration/{safe_component(cal.serial, 'unknown')}.json")
        path.parent.mkdir(parents=True, exist_ok=True)
        cal.save(path, overwrite=True)
        with self._lock:
            if self.walk is walk:
                self.walk = None
            self.calibration, self.calibration_path = cal, path
        walk.reset_fixture()
        return {"path": str(path), "name": f"calibration/{path.name}", **self._calibration_values(), "log": log}

    def calibrate_cancel(self) -> dict[str, Any]:
        """End the walk-through without a file (a step being recorded stops); ``{"cancelled": bool}``."""
        with self._lock:
            walk, self.walk = self.walk, None
        if walk is not None:
            walk.cancel()
        return {"cancelled": walk is not None}

    def _calibration_values(self) -> dict[str, Any]:
        cal = self.calibration
        if cal is None:
            return {}
        r_mux = cal.r_mux if isinstance(cal.r_mux, float) else float(__import__("numpy").median(cal.r_mux))
        return {"serial": cal.serial, "r_adc_ohm": None if not math.isfinite(cal.r_adc) else float(cal.r_adc),
                "r_mux_ohm": float(r_mux), "r_o_ohm": float(cal.r_o), "v_ref_volt": float(cal.v_ref),
                "bits": int(cal.bits), "date": cal.date}

    # ------------------------------------------------------------------ status
    def sessions(self) -> list[dict[str, Any]]:
        """The session files of the data folder (``*.h5``, newest first)."""
        rows = []
        if self.data_dir.is_dir():
            for p in self.data_dir.glob("*.h5"):
                if hidden(p):  # a Mac's ._NAME beside a copied file is no session
                    continue
                try:
                    st = p.stat()
                    confine(self.data_dir, p.name)   # a symbolic link out of the folder is not listed
                except (OSError, ValueError):
                    continue
                rows.append({"name": p.name, "session": str(p), "bytes": st.st_size,
                             "modified_utc": _dt.datetime.fromtimestamp(st.st_mtime, _dt.timezone.utc)
                             .strftime("%Y-%m-%dT%H:%M:%SZ")})
        rows.sort(key=lambda r: r["modified_utc"], reverse=True)
        return rows

    def status(self) -> dict[str, Any]:
        """What ``GET /api/status`` returns."""
        with self._lock:
            dev, feed, writer = self.source, self._feed, self._writer
            prof = self._shown_profile()
            device = None
            if dev is not None:
                device = {"kind": dev.kind, "shape": list(dev.shape), "protocol": str(dev.protocol),
                          "port": str(self.replay.path) if self.replay is not None else self.live_label,
                          "profile": getattr(prof, "name", None), "description": _jsonable(dev.description or {}),
                          "counters": _counters(dev.stats), "warnings": _warnings(dev, feed, prof)}
            rates = feed.rates if feed is not None else {"received_hz": None, "processed_hz": None,
                                                         "displayed_hz": None}
            rec = None
            if writer is not None:
                rec = {"frames": int(writer.n_frames), "events": int(writer.n_events),
                       "elapsed_s": round(self._recorded_dev.clock.now() - self._rec_t0, 3),
                       "metadata": dict(self._rec_meta),
                       # why the file takes no more frames (a full disk): the display goes on, the file not
                       "stopped": getattr(self._recorded_dev, "recording_error", None)}
            return {"device": device, "source": "replay" if self.replay is not None else
                    ("live" if self.live is not None else None),
                    "rates": {**rates, "display_limit_hz": self.display_hz},
                    "display": {"updates": feed.updates if feed else 0, "frames_skipped": feed.skipped if feed else 0,
                                "message": feed.message if feed else None,
                                "extent_cm": feed.extent_cm if feed else None},
                    "recording": writer is not None, "session": str(writer.path) if writer is not None else None,
                    "record": rec, "last_stop": self._last_stop,
                    "replay": self.replay.state() if self.replay is not None else None,
                    "calibration": self.walk.state() if self.walk is not None else None,
                    "calibrated": ({"path": str(self.calibration_path), **self._calibration_values()}
                                   if self.calibration is not None else None),
                    "data_dir": str(self.data_dir), "time_s": time.time()}

    def close(self) -> None:
        """Stop the display, close a running recording into its file, close the replay (idempotent).
        The live device is the caller's."""
        with self._lock:
            if self._closed:
                return
            self._closed = True
            if self._feed is not None:
                self._feed.stop()
                self._feed = None
            if self._writer is not None:
                self.stop_recording()
            if self.walk is not None:
                self.walk.cancel()
                self.walk = None
            if self.replay is not None:
                self.replay.close()
                self.replay = None


def _detach(dev: Any) -> None:
    """Detach the device's session writer and wait (briefly) for its reader thread to finish the
    batch it may be appending, so that the writer is closed after its last append."""
    dev.stop_recording()
    c0 = int(getattr(dev.stats, "frames", 0)) + int(getattr(dev.stats, "invalid", 0))
    t_end = time.monotonic() + _DETACH_WAIT_S
    while time.monotonic() < t_end:
        s = dev.stats
        if int(getattr(s, "frames", 0)) + int(getattr(s, "invalid", 0)) > c0 or not getattr(s, "connected", True):
            return
        time.sleep(0.005)


#: how long a device may give no frame at all before the page says what to check (s)
_SILENT_S = 3.0


def _warnings(dev: Any, feed: DisplayFeed | None, profile: Any) -> list[str]:
    """What the device's counters and frames say went wrong, a line each, with what to check (as
    ``psmat record`` says after a recording): a port lost (and found again), invalid rows by reason, no
    frame at all, counts of a narrower ADC than the profile's."""
    from ..acquire import invalid_line, link_line, silence_line
    from ..process import adc_hint

    st, out = dev.stats, []
    if why := link_line(st, dev):
        out.append(why)
    rows = int(getattr(st, "frames", 0)) + int(getattr(st, "invalid", 0))
    if why := invalid_line(dict(getattr(st, "invalid_reasons", {}) or {}), dev, rows,
                           losses=int(getattr(st, "reconnects", 0) or 0)):
        out.append(why)
    silent = rows == 0
    if silent and feed is not None and time.monotonic() - feed.started_s >= _SILENT_S and \
            (why := silence_line(int(getattr(st, "bytes_in", 0)), dev)):
        out.append(why)
    if feed is not None and feed.max_count is not None and getattr(profile, "kind", None) == "psm" and \
            (why := adc_hint(feed.max_count, int(feed.min_count or 0), feed.valid_frames, profile.circuit())):
        out.append(why)
    return out


def _counters(stats: Any) -> dict[str, Any]:
    return _jsonable(dataclasses.asdict(stats)) if dataclasses.is_dataclass(stats) else {}


def _jsonable(d: dict[str, Any]) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for k, v in d.items():
        if isinstance(v, (str, int, bool)) or v is None:
            out[str(k)] = v
        elif isinstance(v, float):
            out[str(k)] = v if math.isfinite(v) else None
        elif isinstance(v, dict):
            out[str(k)] = _jsonable(v)
        elif isinstance(v, (list, tuple)):
            out[str(k)] = [x if isinstance(x, (str, int, float, bool)) or x is None else str(x) for x in v]
        else:
            out[str(k)] = str(v)
    return out


def trial_sway(path: str | Path) -> dict[str, Any]:
    """Sway metrics of a recorded trial: the session processed as a whole
    (:func:`psmat.process.process_session`, ``save=False``: the file is not changed), its CoP
    (cm; frames without one left out) and :func:`psmat.balance.sway` at the session's frame
    rate (the median frame period's inverse). ``{"metrics": {...}, "frames": n, "fs_hz": ...,
    "cop_from": ...}``, or ``{"metrics": None, "error": "..."}`` for a trial too short or still.
    """
    import numpy as np

    from ..balance import sway
    from ..process import process_session

    try:
        out = process_session(path, save=False, progress=False)
        cop = out.cop_cm[np.all(np.isfinite(out.cop_cm), axis=1)]
        fs = 1.0 / out.clock.step_s
        metrics = sway(cop, fs).as_dict()
    except Exception as exc:  # noqa: BLE001 - the recording is safe; only the metrics are missing
        return {"metrics": None, "error": " ".join(str(exc).split()) or type(exc).__name__}
    return {"metrics": {k: float(v) for k, v in metrics.items()}, "frames": int(len(cop)), "fs_hz": float(fs),
            "cop_from": "the recorded session processed whole (psmat.process.process_session, not saved)"}

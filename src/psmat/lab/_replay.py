"""A recorded session played back in the lab: the playback device and its controls.

The source is :func:`psmat.acquire.open_playback` (a :class:`psmat.acquire.PlaybackDevice`: the
Device API plus ``pause``, ``resume``, ``seek``, ``speed``, ``position_s``, ``duration_s``,
``finished``); the lab shows it through the same display feed as a live mat.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

__all__ = ["Replay", "open_replay", "PlaybackUnavailable", "session_profile_of"]


class PlaybackUnavailable(RuntimeError):
    """This psmat has no playback device (:func:`psmat.acquire.open_playback`)."""


def open_replay(path: Path, speed: float = 1.0) -> Replay:
    """Open ``path`` (a session file) for playback at ``speed``, playing.

    Raises
    ------
    PlaybackUnavailable
        No :func:`psmat.acquire.open_playback` in this installation.
    ValueError
        A bad speed, or a file that is not a mat session (the loader's message).
    """
    try:
        from ..acquire import open_playback  # type: ignore[attr-defined]
    except ImportError:
        raise PlaybackUnavailable("this psmat cannot replay sessions (no psmat.acquire.open_playback)") from None
    speed = check_speed(speed)
    dev = open_playback(str(path), speed=speed, loop=False, start=True)
    if getattr(dev, "kind", "psm") != "psm":
        dev.close()
        raise ValueError(f"{path.name} is a {dev.kind} session; the lab replays mat (psm) sessions")
    return Replay(path, dev)


def check_speed(speed: Any) -> float:
    """A playback speed: a number > 0 (``inf``: as fast as read), else ValueError."""
    if isinstance(speed, bool) or not isinstance(speed, (int, float)) or math.isnan(speed) or speed <= 0:
        raise ValueError(f"speed must be a number > 0, got {speed!r}")
    return float(speed)


def session_profile_of(path: Path, dev: Any) -> Any:
    """The mat profile a played-back session was recorded with (stored, else rebuilt from the file)."""
    from ..profile import Profile

    stored = getattr(dev, "profile", None)
    if stored:
        try:
            return Profile.from_dict(dict(stored))
        except ValueError:
            pass
    from ..io import load_session
    from ..profile import session_profile

    return session_profile(load_session(path))


class Replay:
    """A session being played back: the device and what the page's controls do to it."""

    def __init__(self, path: Path, device: Any) -> None:
        self.path = path
        self.device = device
        self.paused = False

    def play(self) -> None:
        self.device.resume()
        self.paused = False

    def pause(self) -> None:
        self.device.pause()
        self.paused = True

    def seek(self, t_s: Any) -> None:
        """Go to ``t_s`` s from the session's start (0 ... duration)."""
        if isinstance(t_s, bool) or not isinstance(t_s, (int, float)) or not math.isfinite(t_s):
            raise ValueError(f"t_s must be a finite number of seconds, got {t_s!r}")
        duration = float(self.device.duration_s)
        if not 0 <= t_s <= duration:
            raise ValueError(f"t_s must lie in 0 ... {duration:g} s, got {t_s!r}")
        self.device.seek(float(t_s))

    def set_speed(self, speed: Any) -> None:
        self.device.speed = check_speed(speed)

    def state(self) -> dict[str, Any]:
        """The replay's state for ``/api/status``."""
        d = self.device
        speed = float(d.speed)
        return {"session": str(self.path), "name": self.path.name, "position_s": float(d.position_s),
                "duration_s": float(d.duration_s), "speed": speed if math.isfinite(speed) else "inf",
                "paused": bool(getattr(d, "paused", self.paused)), "finished": bool(d.finished)}

    def close(self) -> None:
        self.device.close()

"""``psmat view S.h5``: a recorded session given as the port, played back (:func:`psmat.acquire.open_playback`)."""

from __future__ import annotations

import os
from pathlib import Path
from types import SimpleNamespace
from typing import Any

__all__ = ["is_session_file", "open_replay", "replay_label", "REPLAY_FIXED"]

#: The first 8 bytes of every HDF5 file (HDF5 file format specification, the superblock): a
#: session file, as opposed to any other file given where a port belongs.
_HDF5_SIGNATURE = b"\x89HDF\r\n\x1a\n"

#: options of a live mat that a replay takes from the session instead (option, attribute)
REPLAY_FIXED = (("--shape", "shape"), ("--protocol", "protocol"), ("--bits", "bits"), ("--rate", "rate"))


def is_session_file(port: str | None) -> bool:
    """Whether ``port`` names an existing HDF5 file (a recorded session, not a serial port)."""
    if port is None or not os.path.isfile(port):
        return False
    try:
        with open(port, "rb") as f:
            return f.read(8) == _HDF5_SIGNATURE
    except OSError:
        return False


def replay_label(path: str | os.PathLike[str], speed: float) -> str:
    """The status line's name of a replay: ``replay of S.h5 at 2×``."""
    return f"replay of {Path(path).name} at {speed:g}×"


def open_replay(path: str, speed: float, profile: Any = None) -> tuple[Any, Any, str | None]:
    """Open ``path`` for playback at ``speed`` and pick the profile the view draws it with.

    Parameters
    ----------
    path : str
        A session file of a pressure mat.
    speed : float
        Recorded seconds per second (> 0).
    profile : psmat.Profile, optional
        ``--profile``: used instead of the session's own (it must be a mat of the session's shape).

    Returns
    -------
    dev : psmat.acquire.PlaybackDevice
        Started.
    profile : psmat.Profile
        ``profile``, else the session's stored one, else one rebuilt from the session (its shape
        and device record, the rest ``psm16``'s: :func:`psmat.profile.session_profile`).
    note : str or None
        Why the session's stored profile was not used, when it was unreadable.

    Raises
    ------
    FileNotFoundError, ValueError
        One line: not a session (:class:`psmat.io.SessionFormatError`), not a mat's session, a
        ``--profile`` of another shape.
    """
    from ..acquire import open_playback
    from ..profile import ProfileError, session_profile

    dev = open_playback(path, speed=speed, start=False)
    try:
        if dev.kind != "psm":
            raise ValueError(f"{path} holds {dev.kind} frames of shape {dev.shape}; psmat view shows a pressure "
                             f"mat's (psmat info {path} summarises it)")
        note = None
        if profile is not None:
            if profile.kind != "psm" or tuple(profile.shape) != tuple(dev.shape):
                raise ValueError(f"--profile {profile.name} describes a {profile.kind} device of shape "
                                 f"{tuple(profile.shape)}, {path} holds a {dev.shape[0]}x{dev.shape[1]} mat")
            prof = profile
        else:
            recorded = SimpleNamespace(kind=dev.kind, device=dev.description, frame_shape=dev.shape,
                                       profile=dev.profile, path=path)
            try:
                prof = session_profile(recorded)
                if prof.kind != "psm" or prof.geometry is None or tuple(prof.shape) != tuple(dev.shape):
                    raise ProfileError(f"{path}: stored profile: a {prof.kind} profile of shape {tuple(prof.shape)}")
            except ProfileError as exc:  # rebuilt from the device record and the frame shape instead
                note = f"its stored profile is not usable ({exc}); rebuilt from the session"
                recorded.profile = None
                prof = session_profile(recorded)
        dev.start()
    except BaseException:
        dev.close()
        raise
    return dev, prof, note

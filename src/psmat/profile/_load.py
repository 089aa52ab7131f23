"""Profiles from TOML files: the shipped ones (``psmat/profile/profiles/*.toml``) and a user's."""

from __future__ import annotations

import functools
import math
import numbers
import os
import sys
from pathlib import Path
from typing import Any

from ._errors import ProfileError
from ._geometry import Geometry
from ._profile import Profile

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - Python 3.10
    import tomli as tomllib

__all__ = ["DEFAULT_PROFILE", "load_profile", "list_profiles", "profile_names", "default_profile",
           "default_geometry", "geometry_for", "parse_toml"]

#: The profile of the thesis' mat: the default geometry and circuit of the processing.
DEFAULT_PROFILE = "psm16"
#: Where the shipped profiles live (package data of the wheel).
_SHIPPED = Path(__file__).resolve().parent / "profiles"


def profile_names() -> list[str]:
    """Names of the shipped profiles, sorted."""
    return sorted(p.stem for p in _SHIPPED.glob("*.toml"))


def parse_toml(text: str, where: str) -> Profile:
    """A profile from the text of a TOML file; ``where`` names it in the messages and is its source."""
    try:
        data: dict[str, Any] = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ProfileError(f"{where}: not valid TOML: {exc}") from None
    return Profile.from_dict(data, where)


def _read(path: Path, where: str) -> Profile:
    try:
        text = path.read_text(encoding="utf-8-sig")  # TOML is UTF-8; Notepad may add a byte-order mark
    except UnicodeDecodeError as exc:
        raise ProfileError(f"{where}: not UTF-8 text (byte 0x{exc.object[exc.start]:02x} at offset {exc.start})"
                           ) from None
    except OSError as exc:
        raise ProfileError(f"{where}: cannot be read ({exc.strerror or exc})") from None
    return parse_toml(text, where)


@functools.lru_cache(maxsize=None)
def _shipped(name: str) -> Profile:
    prof = _read(_SHIPPED / f"{name}.toml", f"builtin:{name}")
    if prof.name != name:
        raise ProfileError(f"builtin:{name}: name: must be the file's name {name!r}, got {prof.name!r}")
    return prof


def load_profile(name_or_path: str | os.PathLike[str]) -> Profile:
    """A shipped profile by name (``"psm16"``) or a profile file (``.toml``).

    Parameters
    ----------
    name_or_path : str or path
        A name of :func:`list_profiles`, or the path of a TOML file (anything ending in
        ``.toml`` or containing a path separator is taken as a path).

    Returns
    -------
    Profile
        With ``source`` ``builtin:NAME`` or the file's path.

    Raises
    ------
    ProfileError
        An unknown name, a file that cannot be read, or a bad key (one line naming the file
        and the key).
    """
    text = os.fspath(name_or_path)
    as_path = (not isinstance(name_or_path, str) or text.endswith(".toml") or os.sep in text
               or (os.altsep is not None and os.altsep in text))
    if as_path:
        path = Path(text)
        if not path.is_file():
            raise ProfileError(f"{text}: no such profile file")
        return _read(path, text)
    if text not in profile_names():
        raise ProfileError(f"no profile named {text!r}; shipped: {', '.join(profile_names())} (or give a .toml file)")
    return _shipped(text)


def list_profiles() -> list[Profile]:
    """The shipped profiles, sorted by name."""
    return [_shipped(n) for n in profile_names()]


def default_profile() -> Profile:
    """The profile of :data:`DEFAULT_PROFILE` (the thesis' mat)."""
    return _shipped(DEFAULT_PROFILE)


def default_geometry(shape: tuple[int, int] | None = None) -> Geometry:
    """The default profile's geometry, for a mat of ``shape`` when given (its pitch, origin and axes kept)."""
    g = default_profile().geometry
    assert g is not None
    return g if shape is None else g.with_shape(shape)


def geometry_for(shape: tuple[int, int], *, pitch_cm: float | None = None, geometry: Geometry | None = None
                 ) -> Geometry:
    """The geometry of frames of ``shape``: ``geometry`` (checked against the shape), else a mat in the
    default orientation with ``pitch_cm`` (cm), else :func:`default_geometry` for the shape.

    Raises
    ------
    ValueError
        Both given, a bad pitch, or a geometry of another shape.
    """
    R, C = (int(n) for n in shape)
    if geometry is not None:
        if pitch_cm is not None:
            raise ValueError("give pitch_cm or geometry, not both")
        if not isinstance(geometry, Geometry):
            raise TypeError(f"geometry must be a psmat.profile.Geometry, got {type(geometry).__name__}")
        if geometry.shape != (R, C):
            raise ValueError(f"geometry is for a {geometry.shape[0]}x{geometry.shape[1]} mat, the frames are {R}x{C}")
        return geometry
    if pitch_cm is None:
        return default_geometry((R, C))
    if isinstance(pitch_cm, bool) or not isinstance(pitch_cm, numbers.Real) or not (math.isfinite(pitch_cm)
                                                                                     and pitch_cm > 0):
        raise ValueError(f"pitch_cm must be a positive number (cm), got {pitch_cm!r}")
    return Geometry((R, C), float(pitch_cm))

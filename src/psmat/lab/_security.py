"""The lab server's guards: the access token and the data folder every path is confined to.

* :func:`new_token` - a random token (``secrets.token_urlsafe(32)``: 256 bits) made when the
  server starts; every request and WebSocket must carry it (``?token=`` or
  ``Authorization: Bearer``), checked in constant time (:func:`token_matches`).
* :func:`confine` - a path named by a request, resolved (symbolic links and ``..`` included)
  and refused unless it lies inside the data folder; :func:`safe_component` - a subject or
  trial turned into a file-name component that cannot leave the folder.
* :func:`is_loopback` - whether a ``--host`` keeps the server on this machine.

Imports nothing but the standard library.
"""

from __future__ import annotations

import hmac
import ipaddress
import os
import re
import secrets
from pathlib import Path
from urllib.parse import parse_qs

__all__ = ["new_token", "token_matches", "request_token", "confine", "safe_component", "is_loopback",
           "PathRefused"]

_BEARER = re.compile(r"^\s*Bearer\s+(\S+)\s*$", re.IGNORECASE)
_UNSAFE = re.compile(r"[^A-Za-z0-9_-]+")
_MAX_COMPONENT = 64


class PathRefused(ValueError):
    """A path that would lie outside the data folder; the message is one line."""


def new_token() -> str:
    """A fresh random access token (43 URL-safe characters, 256 bits)."""
    return secrets.token_urlsafe(32)


def request_token(query_string: bytes | str, authorization: str | None) -> str | None:
    """The token a request carries: its ``Authorization: Bearer`` header, else its ``token`` query
    parameter; None when it has neither."""
    if authorization:
        m = _BEARER.match(authorization)
        if m:
            return m.group(1)
    qs = query_string.decode("latin-1") if isinstance(query_string, bytes) else query_string
    values = parse_qs(qs, keep_blank_values=True).get("token")
    return values[0] if values else None


def token_matches(expected: str, given: str | None) -> bool:
    """Whether ``given`` is the token (constant-time comparison; None and empty never match)."""
    if not given or not expected:
        return False
    return hmac.compare_digest(given.encode("utf-8", "surrogatepass"), expected.encode("utf-8"))


def confine(data_dir: str | os.PathLike[str], name: str | os.PathLike[str]) -> Path:
    """``name`` resolved inside ``data_dir``, or :class:`PathRefused`.

    Parameters
    ----------
    data_dir : path
        The data folder (``psmat lab --data``).
    name : path
        A name relative to the folder, or an absolute path; ``..`` and symbolic links are
        resolved before the check, so neither can lead out of it.

    Returns
    -------
    pathlib.Path
        The resolved path, inside the resolved ``data_dir`` (not the folder itself).
    """
    text = os.fspath(name)
    if not isinstance(text, str) or not text or "\x00" in text:
        raise PathRefused(f"not a file name: {text!r}")
    root = Path(data_dir).resolve()
    path = (root / text).resolve()
    if path == root or root not in path.parents:
        raise PathRefused(f"{text!r} is outside the data folder {root}")
    return path


def safe_component(text: str, default: str = "none") -> str:
    """``text`` as one file-name component: runs of characters other than ASCII letters, digits,
    ``_`` and ``-`` become ``-`` (so no ``/``, ``\\``, ``.`` or ``..``), at most 64 characters;
    ``default`` when nothing is left."""
    out = _UNSAFE.sub("-", str(text)).strip("-")[:_MAX_COMPONENT].strip("-")
    return out or default


def is_loopback(host: str) -> bool:
    """Whether ``host`` (an address or ``localhost``) is reachable from this machine only."""
    if host.strip().lower() == "localhost":
        return True
    try:
        return ipaddress.ip_address(host.strip("[]")).is_loopback
    except ValueError:
        return False

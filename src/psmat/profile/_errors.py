"""The one error of device profiles."""

from __future__ import annotations

__all__ = ["ProfileError"]


class ProfileError(ValueError):
    """A profile that cannot be used: one line naming the file (or ``builtin:NAME``) and the key.

    A subclass of ``ValueError``, so a caller that catches bad values catches it too.
    """

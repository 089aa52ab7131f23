"""The lab's state errors (one module, so that every part of the lab can raise them)."""

from __future__ import annotations

__all__ = ["LabConflict"]


class LabConflict(RuntimeError):
    """An action the lab's state does not allow now (a second recording, no recording to stop, ...)."""

"""The condition rows of a study (docs/spec.md §7 "Events, conditions, Romberg"): the fewest samples
a condition needs for its metrics, and which condition a ``metrics.csv`` row is of.

The conditions themselves — markers brought from the host clock to the frame clock and cut to the
analysed window — are :func:`psmat.balance.frame_clock`, :func:`psmat.balance.condition_spans`
and :func:`psmat.balance.inside`, the same the report uses.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

__all__ = ["MIN_SAMPLES", "condition_of"]

#: fewest samples a condition needs for its metrics (as a whole trial)
MIN_SAMPLES = 8


def condition_of(row: Mapping[str, Any]) -> str:
    """The ``condition`` of a metrics row: its label, or "" for a whole-trial row (also when the
    row has no such column or holds no text there, as rows written before conditions existed)."""
    c = row.get("condition", "")
    return c if isinstance(c, str) else ""

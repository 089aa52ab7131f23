"""The unit of a metric a report shows, read from its name's suffix (docs/spec.md §1); the descriptors'
units are :func:`psmat.balance.descriptor_unit`."""

from __future__ import annotations

__all__ = ["metric_unit"]

# a metric's name ends with its unit (docs/spec.md §1); the longer suffixes first
_SUFFIX_UNITS: tuple[tuple[str, str], ...] = (
    ("_cm_s", "cm/s"), ("_cm2", "cm²"), ("_kpa_s", "kPa·s"), ("_n_s", "N·s"), ("_cm", "cm"), ("_hz", "Hz"),
    ("_s", "s"), ("_kpa", "kPa"), ("_n", "N"), ("_deg", "deg"),
)


def metric_unit(name: str) -> str:
    """The unit a metric's name ends with (``velocity_cm_s`` → cm/s); a Romberg quotient is "1"."""
    if name.startswith("romberg_"):
        return "1"
    for suffix, unit in _SUFFIX_UNITS:
        if name.endswith(suffix):
            return unit
    return "1"

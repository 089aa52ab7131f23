"""A device's description from its IDENTIFY reply, with what stayed unknown said so (docs/spec.md §5, §6).

The description is what a session records about its device (docs/spec.md §6: shape, R_o, V_ref,
bits, firmware version). A field the device did not report is absent as a value, listed
under ``"unknown"`` and explained by a ``"note"``, so that a session recorded over a link
that stalled at open, or from a thesis firmware that never answers, says what it lacks
instead of holding an empty description.
"""

from __future__ import annotations

from typing import Any, Mapping

__all__ = ["IDENTIFY_FIELDS", "describe", "learn"]

#: The fields each device's IDENTIFY reply carries (firmware/core/psm_core.c, imu_core.c),
#: in the firmware's order. The material DAQ has no IDENTIFY.
IDENTIFY_FIELDS: dict[str, tuple[str, ...]] = {
    "psm": ("device", "fw", "rows", "cols", "rate", "proto", "serial", "r_o", "v_ref", "bits"),
    "imu": ("device", "fw", "sensors", "rate", "proto", "serial", "units"),
}


def describe(kind: str, reported: Mapping[str, Any], note: str | None = None) -> dict[str, Any]:
    """The description of a ``kind`` device from the fields its IDENTIFY reply reported.

    Parameters
    ----------
    kind : {"psm", "imu"}
        The device.
    reported : mapping
        Parsed IDENTIFY fields (:func:`psmat.protocol.parse_identify`); empty when the
        device did not answer.
    note : str, optional
        Why fields are missing (e.g. ``"no reply to IDENTIFY after 3 attempts of 0.5 s"``);
        by default, that the reply did not report them.

    Returns
    -------
    dict
        ``reported``, plus ``"unknown"`` (the missing fields of :data:`IDENTIFY_FIELDS`, in
        that order) and ``"note"`` when any is missing.
    """
    out = dict(reported)
    unknown = [k for k in IDENTIFY_FIELDS[kind] if k not in out]
    if unknown:
        out["unknown"] = unknown
        out["note"] = note or f"IDENTIFY did not report {', '.join(unknown)}"
    return out


def learn(description: dict[str, Any], key: str, value: Any) -> None:
    """Record a field the device confirmed later (e.g. ``rate`` by a SET_RATE reply), in place.

    Only fields the description holds or lists as unknown are touched; an emptied
    ``"unknown"`` list is removed (the note stays: it tells what happened at open).
    """
    unknown = description.get("unknown")
    listed = isinstance(unknown, list) and key in unknown
    if key not in description and not listed:
        return
    description[key] = value
    if listed:
        unknown.remove(key)
        if not unknown:
            del description["unknown"]

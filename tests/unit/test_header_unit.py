"""psmat.units.header_unit: the name and unit a column header of a lab's file names, as people write
headers (the one reading of subjects.csv's, the events file's and the schedule's headers)."""

from __future__ import annotations

import pytest

from psmat.units import header_unit

WEIGHT = ("weight", "body_weight", "mass")


@pytest.mark.parametrize("header, bases, expected", [
    ("weight_kg", WEIGHT, ("weight", "kg")),
    ("Weight (kg)", WEIGHT, ("weight", "kg")),
    (" Body weight [LB] ", WEIGHT, ("body_weight", "lb")),
    ("body-weight_lbs", WEIGHT, ("body_weight", "lbs")),
    ("Mass", WEIGHT, ("mass", None)),
    ("height_cm", WEIGHT, None),
    ("weightkg", WEIGHT, None),  # no separator: not a name of bases
    ("Time [µs]", ("time",), ("time", "µs")),
    ("time_ms", ("time",), ("time", "ms")),
    ("t", ("time", "t"), ("t", None)),
    ("pressure_atm", ("pressure",), ("pressure", "atm")),  # an unknown unit is the caller's to refuse
])
def test_header_unit_by_hand(header, bases, expected) -> None:
    assert header_unit(header, bases) == expected

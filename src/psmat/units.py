"""Unit conversions: the one place a conversion factor is written (docs/spec.md §1, the units rule).

Inside the sensor model pressure is in psi (the thesis fitted it in psi); at the user API
pressure is in kPa and force in N. Every public quantity names its unit by a suffix
(``_kpa``, ``_psi``, ``_n``, ``_kg``, ``_cm``, ``_s``, ...); these functions convert between them,
and :func:`header_unit` reads the unit a column header of a lab's file names.
"""

from __future__ import annotations

import re
from collections.abc import Collection
from typing import TypeVar

import numpy as np

#: Pa per psi (the international avoirdupois pound-force per square inch).
PSI_PA: float = 6894.757
#: kPa per psi.
PSI_KPA: float = PSI_PA / 1000.0
#: kPa per mmHg (the conventional millimetre of mercury: 13 595.1 kg/m³ × 9.80665 m/s² × 1 mm =
#: 133.322387415 Pa exactly; the torr, 101 325/760 Pa, is 1.4e-7 smaller).
MMHG_KPA: float = 0.133322387415
#: kPa per N/cm² (1 N/cm² = 10⁴ Pa).
N_PER_CM2_KPA: float = 10.0
#: kPa per unit, by the names other mats' software writes (lower case, spaces removed): the pressure
#: units :func:`kpa_per_unit` knows.
PRESSURE_UNITS_KPA: dict[str, float] = {
    "kpa": 1.0, "pa": 1e-3, "mpa": 1e3, "mmhg": MMHG_KPA, "psi": PSI_KPA, "bar": 100.0, "mbar": 0.1,
    "n/cm2": N_PER_CM2_KPA, "n/cm^2": N_PER_CM2_KPA, "n/cm²": N_PER_CM2_KPA, "ncm2": N_PER_CM2_KPA,
}
#: cm per unit of length, by name (lower case): the lengths :func:`cm_per_unit` knows.
LENGTH_UNITS_CM: dict[str, float] = {
    "mm": 0.1, "millimeter": 0.1, "millimeters": 0.1, "millimetre": 0.1, "millimetres": 0.1,
    "cm": 1.0, "centimeter": 1.0, "centimeters": 1.0, "centimetre": 1.0, "centimetres": 1.0,
    "m": 100.0, "meter": 100.0, "meters": 100.0, "metre": 100.0, "metres": 100.0,
    "in": 2.54, "inch": 2.54, "inches": 2.54,
}
#: s per unit of time, by name (lower case): the times :func:`s_per_unit` knows.
TIME_UNITS_S: dict[str, float] = {"s": 1.0, "sec": 1.0, "ms": 1e-3, "msec": 1e-3, "us": 1e-6, "µs": 1e-6,
                                  "μs": 1e-6, "min": 60.0}
#: kg per unit of mass, by name (lower case): the masses :func:`kg_per_unit` knows (the international
#: avoirdupois pound, 0.45359237 kg exactly; the stone, 14 lb).
MASS_UNITS_KG: dict[str, float] = {"kg": 1.0, "kgs": 1.0, "kilogram": 1.0, "kilograms": 1.0,
                                   "lb": 0.45359237, "lbs": 0.45359237, "pound": 0.45359237, "pounds": 0.45359237,
                                   "st": 14 * 0.45359237, "stone": 14 * 0.45359237}
#: Standard gravity, m/s² (CGPM 1901): N per kg of body mass.
STANDARD_GRAVITY_M_S2: float = 9.80665
#: N per unit of force, by name (lower case): the forces :func:`n_per_unit` knows (the kilogram-force,
#: one kg under standard gravity; the pound-force, one pound under it).
FORCE_UNITS_N: dict[str, float] = {"n": 1.0, "newton": 1.0, "newtons": 1.0, "kn": 1e3,
                                   "kgf": STANDARD_GRAVITY_M_S2, "kp": STANDARD_GRAVITY_M_S2,
                                   "lbf": 0.45359237 * STANDARD_GRAVITY_M_S2}

ArrayOrFloat = TypeVar("ArrayOrFloat", float, np.ndarray)


def kpa_from_psi(p_psi: ArrayOrFloat) -> ArrayOrFloat:
    """Pressure in kPa from pressure in psi."""
    return p_psi * PSI_KPA


def psi_from_kpa(p_kpa: ArrayOrFloat) -> ArrayOrFloat:
    """Pressure in psi from pressure in kPa."""
    return p_kpa / PSI_KPA


def n_from_kg(mass_kg: ArrayOrFloat) -> ArrayOrFloat:
    """Weight in N of a body of mass ``mass_kg`` kg under standard gravity."""
    return mass_kg * STANDARD_GRAVITY_M_S2


def force_n(pressure_kpa: ArrayOrFloat, area_cm2: ArrayOrFloat) -> ArrayOrFloat:
    """Force in N of a pressure in kPa on an area in cm² (1 kPa·cm² = 0.1 N)."""
    return pressure_kpa * area_cm2 * 0.1


def _per_unit(table: dict[str, float], key: str, unit: str, quantity: str, known: str) -> float:
    """``table[key]``, else ValueError (one line naming ``unit`` and the ``known`` units)."""
    if key not in table:
        raise ValueError(f"unknown {quantity} unit {unit!r} (known: {known})")
    return table[key]


def kpa_per_unit(unit: str) -> float:
    """kPa per one ``unit`` of pressure (``"kPa"``, ``"mmHg"``, ``"PSI"``, ``"N/cm2"``, ``"Pa"``, ``"MPa"``,
    ``"bar"``, ``"mbar"``).

    Case and spaces are ignored. Raises ValueError (one line naming the known units) for any other.
    """
    return _per_unit(PRESSURE_UNITS_KPA, "".join(str(unit).split()).lower(), unit, "pressure",
                     "kPa, Pa, MPa, bar, mbar, mmHg, PSI, N/cm2")


def cm_per_unit(unit: str) -> float:
    """cm per one ``unit`` of length (``"mm"``, ``"cm"``, ``"m"``, ``"in"`` and their spelled-out names).

    Case is ignored. Raises ValueError (one line) for any other.
    """
    return _per_unit(LENGTH_UNITS_CM, str(unit).strip().lower(), unit, "length", "mm, cm, m, in")


def kg_per_unit(unit: str) -> float:
    """kg per one ``unit`` of mass (``"kg"``, ``"lb"``, ``"st"`` and their spelled-out names).

    Case is ignored. Raises ValueError (one line naming the known units) for any other.
    """
    return _per_unit(MASS_UNITS_KG, str(unit).strip().lower(), unit, "mass", "kg, lb, st")


def n_per_unit(unit: str) -> float:
    """N per one ``unit`` of force (``"N"``, ``"kN"``, ``"kgf"`` or ``"kp"``, ``"lbf"``).

    Case is ignored. Raises ValueError (one line naming the known units) for any other.
    """
    return _per_unit(FORCE_UNITS_N, str(unit).strip().lower(), unit, "force", "N, kN, kgf, lbf")


def s_per_unit(unit: str) -> float:
    """s per one ``unit`` of time (``"s"``, ``"ms"``, ``"us"`` or ``"µs"``, ``"min"``).

    Case is ignored. Raises ValueError (one line naming the known units) for any other.
    """
    return _per_unit(TIME_UNITS_S, str(unit).strip().lower(), unit, "time", "s, ms, us, min")


def header_unit(header: str, bases: Collection[str]) -> tuple[str, str | None] | None:
    """The name and unit of a column ``header`` whose name is one of ``bases`` (lower case, words
    joined by ``_``), as people write headers: ``"Weight (kg)"``, ``"weight_kg"``, ``"Body weight [LB]"``
    → (``"weight"``, ``"kg"``), ..., (``"body_weight"``, ``"lb"``); ``" Time "`` → (``"time"``, None);
    a header whose name is not in ``bases`` → None. Case is ignored; spaces and hyphens are ``_``.
    The unit is returned as written (lower case), for :func:`kg_per_unit`, :func:`s_per_unit`, ...
    """
    n = re.sub(r"[\s\-]+", "_", header.strip().lower())
    m = re.fullmatch(r"(.+?)_?[\[(]_?([^\])]+?)_?[\])]", n)
    if m:
        base, unit = m.group(1), m.group(2)
    elif n in bases:
        return n, None
    else:
        base, _, unit = n.rpartition("_")
    return (base, unit) if base in bases else None

"""Unit conversions: the one place a conversion factor is written (docs/spec.md §1, the units rule).

Inside the sensor model pressure is in psi (the thesis fitted it in psi); at the user API
pressure is in kPa and force in N. Every public quantity names its unit by a suffix
(``_kpa``, ``_psi``, ``_n``, ``_kg``, ``_cm``, ``_s``, ...); these functions convert between them.
"""

from __future__ import annotations

from typing import TypeVar

import numpy as np

#: Pa per psi (the international avoirdupois pound-force per square inch).
PSI_PA: float = 6894.757
#: kPa per psi.
PSI_KPA: float = PSI_PA / 1000.0
#: Standard gravity, m/s² (CGPM 1901): N per kg of body mass.
STANDARD_GRAVITY_M_S2: float = 9.80665

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

"""Unit conversions used across the package (docs/spec.md §1: psi inside the sensor model, SI at the API)."""

#: Pa per psi.
PSI_PA: float = 6894.757
#: kPa per psi.
PSI_KPA: float = PSI_PA / 1000.0

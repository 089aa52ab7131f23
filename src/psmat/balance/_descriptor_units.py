"""The unit of each of the 72 descriptors of :func:`psmat.balance.descriptors` (docs/spec.md §7)."""

from __future__ import annotations

__all__ = ["descriptor_unit", "PHASE_PLANE_UNIT"]

#: the phase-plane parameter adds a variance of positions (cm²) to one of velocities ((cm/s)²) as
#: numbers, as Quijoux et al. (2021) do: its square root has no unit of its own, so it says what it is
PHASE_PLANE_UNIT = "√(cm² + (cm/s)²)"

# (prefix of the descriptor's name, unit), first match wins: the longer prefixes first
_DESCRIPTOR_UNITS: tuple[tuple[str, str], ...] = (
    ("mean_distance_peak_Sway_Density", "cm"),
    ("mean_peak_Sway_Density", "s"),
    ("mean_value_", "cm"), ("mean_distance_", "cm"), ("maximal_distance_", "cm"), ("rms_", "cm"),
    ("range_ratio_", "1"), ("range_", "cm"), ("planar_deviation_", "cm"),
    ("coefficient_sway_direction_", "1"), ("confidence_ellipse_area_", "cm²"),
    ("principal_sway_direction_", "deg"),
    ("mean_velocity_", "cm/s"), ("sway_area_per_second_", "cm²/s"), ("phase_plane_parameter_", PHASE_PLANE_UNIT),
    ("LFS_", "1/cm"), ("fractal_dimension_", "1"), ("zero_crossing_SPD_", "count"), ("peak_velocity_", "cm/s"),
    ("mean_frequency_", "Hz"), ("total_power_", "cm²"), ("energy_content_", "cm²"), ("frequency_quotient_", "1"),
    ("power_frequency_", "Hz"), ("frequency_mode_", "Hz"), ("centroid_frequency_", "Hz"),
    ("frequency_dispersion_", "1"),
    ("short_time_diffusion_", "cm²/s"), ("long_time_diffusion_", "cm²/s"), ("critical_time_", "s"),
    ("critical_displacement_", "cm²"), ("short_time_scaling_", "1"), ("long_time_scaling_", "1"),
)


def descriptor_unit(name: str) -> str:
    """The unit of a descriptor of :func:`psmat.balance.descriptors` by its name (docs/spec.md §7).

    Raises
    ------
    KeyError
        A name that is not one of the 72.
    """
    for prefix, unit in _DESCRIPTOR_UNITS:
        if name.startswith(prefix):
            return unit
    raise KeyError(f"no unit known for the descriptor {name!r}")

"""The units rule of docs/spec.md §1: every public quantity names its unit by a suffix, and a
conversion factor is written only in psmat.units."""

from __future__ import annotations

import ast
import dataclasses
import importlib
import inspect
from pathlib import Path

import numpy as np
import pytest

import psmat
from psmat import units

ROOT = Path(__file__).resolve().parents[2]
PACKAGE = ROOT / "src" / "psmat"

# Words that name a physical quantity: a name made with one needs a unit suffix.
QUANTITY_WORDS = {
    "time", "times", "period", "rate", "fs", "pitch", "pressure", "pressures", "force", "forces",
    "weight", "mass", "angle", "angles", "lag", "duration", "seconds", "length", "area", "distance",
    "height", "width", "radius", "interval", "delay", "timeout", "freq", "frequency", "voltage",
    "resistance", "temperature", "cop", "velocity", "latency",
}
# "speed" is not among them: in psmat it is a playback's multiple of real time, a ratio (docs/spec.md §1);
# a physical speed is a velocity, with its unit (``velocity_cm_s``).
# docs/spec.md §1: the suffixes, and the products of two of them.
SUFFIXES = {"s", "ms", "us", "hz", "fps", "cm", "mm", "m", "cm2", "mm2", "deg", "rad", "kpa", "pa",
            "psi", "n", "kg", "v", "mv", "ohm", "cells", "cm_s", "kpa_s", "n_s", "m_s2"}
# Words that only look like a quantity: an optimiser's weight decay is a unitless coefficient.
UNITLESS = {"weight_decay"}
# docs/spec.md §1: the names the public API contract (§9) fixes, units stated there once.
CONTRACT = {"psmat.balance.cop": {"pressure"}, "psmat.balance.sway": {"cop"},
            "psmat.balance.align": {"cop_ref", "cop", "t_ref"}, "psmat.posture.spine_points": {"angles"}}
# The library's public packages, every one (the applications are checked by their help texts).
APPLICATIONS = {"cli", "__main__", "commands", "live", "workflows", "bench", "experiments", "lab"}


def _library() -> list[str]:
    found = ["psmat"]
    for init in sorted(PACKAGE.rglob("__init__.py")):
        bits = init.parent.relative_to(PACKAGE.parent).parts
        if len(bits) > 1 and bits[1] not in APPLICATIONS and not any(b.startswith("_") for b in bits):
            found.append(".".join(bits))
    return found


LIBRARY = _library()


def needs_suffix(name: str) -> bool:
    """True when ``name`` names a physical quantity and carries no unit suffix."""
    if name in UNITLESS:
        return False
    tokens = name.lower().strip("_").split("_")
    if not any(t in QUANTITY_WORDS for t in tokens):
        return False
    return not any("_".join(tokens[-k:]) in SUFFIXES for k in (1, 2))


def test_the_rule_reads_names_as_the_spec_says() -> None:
    assert needs_suffix("timeout") and needs_suffix("sample_rate") and needs_suffix("weight")
    assert needs_suffix("wall_time") and needs_suffix("pressure_frames")
    assert not needs_suffix("timeout_s") and not needs_suffix("rate_hz") and not needs_suffix("weight_kg")
    assert not needs_suffix("velocity_cm_s") and not needs_suffix("pti_kpa_s")
    assert not needs_suffix("n_frames") and not needs_suffix("path") and not needs_suffix("counts")


def _quantities(obj: object) -> list[tuple[str, str]]:
    """(where, name) of the parameters, fields and properties a public object offers."""
    found: list[tuple[str, str]] = []

    def params(fn: object, where: str) -> None:
        try:
            sig = inspect.signature(fn)
        except (TypeError, ValueError):
            return
        for name, prm in sig.parameters.items():
            # a flag or a text (a column's name, a path) is not a quantity
            flag = isinstance(prm.default, (bool, str)) or str(prm.annotation) in ("bool", "str", "<class 'bool'>")
            if name not in ("self", "cls") and not flag:
                found.append((where, name))

    if inspect.isclass(obj):
        if dataclasses.is_dataclass(obj):
            found.extend(("field", f.name) for f in dataclasses.fields(obj) if not f.name.startswith("_"))
        found.extend(("field", f) for f in getattr(obj, "_fields", ()))
        for name, value in vars(obj).items():
            if name == "__init__" and inspect.isfunction(value):
                params(value, "parameter")
            elif name.startswith("_"):
                continue
            elif isinstance(value, property):
                found.append(("property", name))
            elif inspect.isfunction(value) or isinstance(value, (staticmethod, classmethod)):
                params(getattr(obj, name), f"{name}()")
    elif callable(obj):
        params(obj, "parameter")
    return found


def test_public_quantities_carry_their_units() -> None:
    bad, seen = [], set()
    for pkg_name in LIBRARY:
        pkg = importlib.import_module(pkg_name)
        for attr in getattr(pkg, "__all__", []):
            obj = getattr(pkg, attr)
            if inspect.ismodule(obj) or id(obj) in seen:
                continue
            seen.add(id(obj))
            fixed = CONTRACT.get(f"{pkg_name}.{attr}", set())
            bad += [f"{pkg_name}.{attr}: {where} {name}" for where, name in _quantities(obj)
                    if needs_suffix(name) and name not in fixed]
    assert not bad, "add the unit suffix of docs/spec.md §1:\n" + "\n".join(sorted(set(bad)))


# A literal conversion factor anywhere but psmat/units.py is a second home for it.
FACTORS = {6894.757: "PSI_PA", 6.894757: "PSI_KPA", 9.80665: "STANDARD_GRAVITY_M_S2", 9.81: "STANDARD_GRAVITY_M_S2"}


def test_conversion_factors_are_written_once() -> None:
    bad = []
    for f in PACKAGE.rglob("*.py"):
        if f == PACKAGE / "units.py":
            continue
        for node in ast.walk(ast.parse(f.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Constant) and isinstance(node.value, float) and node.value in FACTORS:
                bad.append(f"{f.relative_to(ROOT)}:{node.lineno} writes {node.value}: use psmat.units.{FACTORS[node.value]}")
    assert not bad, "\n".join(bad)


def test_conversions_match_their_definitions() -> None:
    # 1 psi = 1 lbf/in² = 4.4482216152605 N / (0.0254 m)² (NIST SP 811, B.8)
    psi_pa = 4.4482216152605 / 0.0254 ** 2
    assert units.PSI_PA == pytest.approx(psi_pa, rel=1e-6)
    assert units.kpa_from_psi(32.0) == pytest.approx(32.0 * psi_pa / 1000.0, rel=1e-6)
    p = np.array([0.0, 1.0, 14.5])
    np.testing.assert_allclose(units.psi_from_kpa(units.kpa_from_psi(p)), p, rtol=1e-15)
    assert units.n_from_kg(70.0) == pytest.approx(686.4655)          # 70 kg × 9.80665 m/s²
    assert units.force_n(10.0, 4.0) == pytest.approx(4.0)             # 10 kPa on 4 cm² = 10e3 Pa × 4e-4 m²
    assert psmat.units is units

"""The profile schema (docs/spec.md §5 "Device profiles"): a TOML file's tables, checked key by key.

Every problem is one :class:`ProfileError` line ``WHERE: KEY: what is wrong``; an unknown key is
an error too, so a typo (``pich_cm``) never passes silently as a default.
"""

from __future__ import annotations

import math
import re
from typing import Any

from ._errors import ProfileError
from ._geometry import AXES, Geometry

__all__ = ["KINDS", "PROTOCOLS", "parse"]

#: Device kinds and the protocols each may speak. ``pressure``: another maker's mat whose frames were
#: imported from its software's export (``psmat import``): a geometry, no wire protocol, no circuit.
KINDS = ("psm", "imu", "daq", "pressure")
PROTOCOLS = {"psm": ("v1", "v2", "csv"), "imu": ("v1", "v2"), "daq": ("daq-text",), "pressure": ("import",)}
#: The frame shape of the devices whose shape is fixed by their kind.
FIXED_SHAPES = {"imu": (5, 3), "daq": (10,)}

_TOP = ("name", "description", "kind", "protocol", "rate_hz", "baudrate", "shape", "geometry", "wire", "circuit")
_GEOMETRY = ("shape", "pitch_cm", "origin_cm", "x", "y")
_WIRE = ("row_order", "col_order")
_CIRCUIT = ("r_o_ohm", "v_ref_volt", "bits", "r_mux_ohm", "r_adc_ohm")
_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9._-]*\Z")


class _Checker:
    """Reads one table's keys, each failure one line naming ``where`` and the key."""

    def __init__(self, where: str, table: dict[str, Any], prefix: str, known: tuple[str, ...]) -> None:
        self.where, self.table, self.prefix = where, table, prefix
        unknown = [k for k in table if k not in known]
        if unknown:
            self.fail(unknown[0], f"unknown key (known: {', '.join(known)})")

    def fail(self, key: str, problem: str) -> None:
        raise ProfileError(f"{self.where}: {self.prefix}{key}: {problem}")

    def get(self, key: str, required: bool) -> Any:
        if key not in self.table:
            if required:
                self.fail(key, "missing")
            return None
        return self.table[key]

    def text(self, key: str, required: bool = True, choices: tuple[str, ...] | None = None) -> str | None:
        v = self.get(key, required)
        if v is None:
            return None
        if not isinstance(v, str) or "\n" in v or not v.strip():
            self.fail(key, f"must be one line of text, got {v!r}")
        if choices is not None and v not in choices:
            self.fail(key, f"must be one of {', '.join(choices)}, got {v!r}")
        return v

    def number(self, key: str, required: bool = True, *, minimum: float = 0.0, strict: bool = True,
               allow_inf: bool = False, unit: str = "") -> float | None:
        v = self.get(key, required)
        if v is None:
            return None
        if allow_inf and v == "inf":  # how a JSON-able dict (Profile.to_dict) writes an infinity
            v = math.inf
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            self.fail(key, f"must be a number{unit}, got {v!r}")
        bad = math.isnan(v) or (math.isinf(v) and not allow_inf) or (v <= minimum if strict else v < minimum)
        if bad:
            self.fail(key, f"must be a {'' if allow_inf else 'finite '}number {'>' if strict else '>='} "
                           f"{minimum:g}{unit}, got {v!r}")
        return float(v)

    def integer(self, key: str, required: bool = True, lo: int = 1, hi: int | None = None) -> int | None:
        v = self.get(key, required)
        if v is None:
            return None
        if isinstance(v, bool) or not isinstance(v, int) or v < lo or (hi is not None and v > hi):
            self.fail(key, f"must be an integer in {lo}..{'' if hi is None else hi}, got {v!r}")
        return int(v)

    def ints(self, key: str, length: int | None = None) -> list[int] | None:
        v = self.get(key, False)
        if v is None:
            return None
        if (not isinstance(v, (list, tuple)) or (length is not None and len(v) != length)
                or any(isinstance(n, bool) or not isinstance(n, int) for n in v)):
            want = "a list of integers" if length is None else f"a list of {length} integers"
            self.fail(key, f"must be {want}, got {v!r}")
        return [int(n) for n in v]

    def table_of(self, key: str) -> dict[str, Any] | None:
        v = self.get(key, False)
        if v is not None and not isinstance(v, dict):
            self.fail(key, f"must be a table ([{key}]), got {v!r}")
        return v


def _order(c: _Checker, key: str, n: int, lines: str) -> tuple[int, ...] | None:
    order = c.ints(key)
    if order is None:
        return None
    if sorted(order) != list(range(n)):
        c.fail(key, f"must list each of the {n} {lines} 0..{n - 1} once (a permutation), got {order}")
    return tuple(order)


def _geometry(where: str, table: dict[str, Any]) -> Geometry:
    c = _Checker(where, table, "geometry.", _GEOMETRY)
    shape = c.ints("shape", 2)
    if shape is None:
        c.fail("shape", "missing")
    assert shape is not None
    if min(shape) < 1 or max(shape) > 255:
        c.fail("shape", f"must be [rows, columns], each 1..255, got {shape}")
    pitch = c.number("pitch_cm", unit=" (cm)")
    origin = c.get("origin_cm", False)
    if origin is not None and (not isinstance(origin, (list, tuple)) or len(origin) != 2 or any(
            isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) for v in origin)):
        c.fail("origin_cm", f"must be [x, y], two finite numbers (cm), got {origin!r}")
    x = c.text("x", False, AXES) or "+columns"
    y = c.text("y", False, AXES) or "+rows"
    if x[1:] == y[1:]:
        c.fail("y", f"x and y must run along different lines (one rows, one columns), got x={x!r}, y={y!r}")
    return Geometry((shape[0], shape[1]), float(pitch),  # type: ignore[arg-type]
                    (0.0, 0.0) if origin is None else (float(origin[0]), float(origin[1])), x, y)


def parse(data: dict[str, Any], where: str) -> dict[str, Any]:
    """The arguments of :class:`~psmat.profile.Profile` (all but ``source``) from a profile's tables.

    Parameters
    ----------
    data : dict
        What ``tomllib`` reads from a profile file (or :meth:`Profile.to_dict` without ``source``).
    where : str
        The file (or ``builtin:NAME``) for the messages.

    Raises
    ------
    ProfileError
        One line: ``where``, the key (``geometry.pitch_cm``) and what is wrong.
    """
    if not isinstance(data, dict):
        raise ProfileError(f"{where}: a profile is a table of keys, got {type(data).__name__}")
    c = _Checker(where, data, "", _TOP)
    name = c.text("name")
    assert name is not None
    if not _NAME.match(name):
        c.fail("name", f"must be letters, digits, '.', '_' or '-' (no spaces), got {name!r}")
    kind = c.text("kind", choices=KINDS)
    assert kind is not None
    out: dict[str, Any] = {
        "name": name, "description": c.text("description"), "kind": kind,
        "protocol": c.text("protocol", choices=PROTOCOLS[kind]),
        "rate_hz": c.number("rate_hz", unit=" (Hz)"),
        # an imported mat has no serial line: its baudrate is optional, 0 when absent
        "baudrate": c.integer("baudrate", required=kind != "pressure") or 0,
    }
    geo, wire, circuit = c.table_of("geometry"), c.table_of("wire"), c.table_of("circuit")
    if kind in ("psm", "pressure"):
        if "shape" in data:
            c.fail("shape", f"a {kind} profile gives its shape in [geometry]")
        if geo is None:
            c.fail("geometry", f"missing: a {kind} profile needs [geometry] (shape, pitch_cm)")
        assert geo is not None
        g = _geometry(where, geo)
        out.update(shape=g.shape, pitch_cm=g.pitch_cm, geometry=g)
    else:
        if geo is not None:
            c.fail("geometry", f"a {kind} profile has no [geometry] (its readings are not cells of a mat)")
        shape = c.ints("shape")
        fixed = FIXED_SHAPES[kind]
        if shape is not None and tuple(shape) != fixed:
            c.fail("shape", f"a {kind} frame is {list(fixed)}, got {shape}")
        out.update(shape=fixed, pitch_cm=None, geometry=None)
    if wire is not None:
        if kind != "psm":
            c.fail("wire", f"a {kind} profile has no [wire] (the wire order of a mat psmat reads)")
        w = _Checker(where, wire, "wire.", _WIRE)
        out.update(row_order=_order(w, "row_order", out["shape"][0], "rows"),
                   col_order=_order(w, "col_order", out["shape"][1], "columns"))
    if kind in ("imu", "pressure"):
        if circuit is not None:
            c.fail("circuit", f"a {kind} profile has no [circuit] (it gives "
                              f"{'angles' if kind == 'imu' else 'pressure'}, not ADC counts)")
    else:
        if circuit is None:
            c.fail("circuit", f"missing: a {kind} profile needs [circuit] ({', '.join(_CIRCUIT)})")
        assert circuit is not None
        k = _Checker(where, circuit, "circuit.", _CIRCUIT)
        out.update(r_o_ohm=k.number("r_o_ohm", unit=" (ohm)"), v_ref_volt=k.number("v_ref_volt", unit=" (V)"),
                   bits=k.integer("bits", lo=1, hi=16),
                   r_mux_ohm=k.number("r_mux_ohm", strict=False, unit=" (ohm)"),
                   r_adc_ohm=k.number("r_adc_ohm", allow_inf=True, unit=" (ohm; inf for an ideal ADC)"))
    return out

"""Calibration of a DAQ box as data: R_adc, R_mux and their diagnostics, with JSON I/O (docs/spec.md §2).

The file may also carry the mat's pressure calibration (docs/spec.md §4, :mod:`psmat.pressure`)
under ``"pressure"``: opaque here (a JSON object this layer stores and gives back), so a file may
hold the electronics part, the pressure part or both. Version 2 of the format added it and lets
the electronics keys be absent; version 1 files (always with R_adc and R_mux) still load.

A calibration is data, stored with the box's serial number (JSON, :meth:`Calibration.save` /
:meth:`Calibration.load`) and applied with :meth:`psmat.circuit.Circuit.calibrated`. The
estimates come from recordings through :func:`psmat.circuit.from_recordings` (thesis §2.1.4
end). This module imports neither of them: the constants are checked by the validation the
circuit uses too (``circuit/_checks.py``).
"""

from __future__ import annotations

import datetime as _dt
import json
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ._checks import check_constants

__all__ = ["Calibration", "OpenCircuitStats", "ShortCircuitStats"]

_FORMAT = "psmat-calibration"
_VERSION = 2
#: versions this psmat reads: 1 (electronics only), 2 (optional electronics, optional "pressure")
_READS = (1, 2)
#: keys of the electronics part, absent from a version-2 file without one
_ELECTRONICS = ("r_adc_ohm", "r_mux_ohm", "open_circuit", "short_circuit")


def _reject_constant(name: str) -> Any:
    """``json.loads`` hook: NaN/Infinity are not JSON and never written by :meth:`Calibration.save`."""
    raise ValueError(f"non-standard JSON constant {name}")


def _today() -> str:
    return _dt.date.today().isoformat()


# ---------------------------------------------------------------------- diagnostics
@dataclass(frozen=True)
class OpenCircuitStats:
    """Diagnostics of the open-circuit (mat unplugged) recording.

    Attributes
    ----------
    count_mean : float
        Mean reading over frames and cells (counts), corrected for ADC clipping if any.
    count_sd : float
        Spread (SD) of the reading over frames and cells (counts).
    n_samples : int
        Number of samples (frames × cells).
    clipped_fraction : float
        Fraction of samples at 0 or full scale.
    r_adc_se : float
        Standard error of ``r_adc`` from the count spread, ``|dR_adc/dc| SD/sqrt(n)`` (Ω).
    r_adc_per_count : float
        Change of the ``r_adc`` estimate per count at this reading (Ω/count): the resolution
        of an undithered (noise-free) recording.
    """

    count_mean: float
    count_sd: float
    n_samples: int
    clipped_fraction: float
    r_adc_se: float
    r_adc_per_count: float


@dataclass(frozen=True, eq=False)
class ShortCircuitStats:
    """Diagnostics of the short-circuit recordings (one wire per row-column pair).

    Attributes
    ----------
    r_mux_pairs : ndarray, shape (R, C)
        ``R_mux`` estimated per pair (Ω); NaN where the pair was not recorded.
    summary : float
        Median over recorded pairs (Ω).
    spread : float
        SD over recorded pairs (Ω); 0 for a single pair.
    """

    r_mux_pairs: NDArray[np.float64]
    summary: float
    spread: float

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, ShortCircuitStats):
            return NotImplemented
        return (
            self.summary == other.summary
            and self.spread == other.spread
            and np.array_equal(self.r_mux_pairs, other.r_mux_pairs, equal_nan=True)
        )

    __hash__ = None  # type: ignore[assignment]


# ---------------------------------------------------------------------- calibration
@dataclass(eq=False)
class Calibration:
    """Calibration of one DAQ box (docs/spec.md §2 "Calibration").

    Attributes
    ----------
    serial : str
        Serial number of the DAQ box.
    r_adc : float or None
        ADC input resistance (Ω), > 0; None (with ``r_mux`` None): no electronics part, only
        the pressure part (the box's nominal R_adc and R_mux apply).
    r_mux : float or ndarray, shape (R, C), or None
        Series resistance of the two mux channels (Ω), >= 0: one value, or one per pair.
    r_o, v_ref, bits : float, float, int
        Circuit constants the estimates were made with: divider resistor (Ω), reference
        voltage (V), ADC bits. The estimates are only valid for a circuit with these.
    date : str
        ISO 8601 date (or date-time) of the calibration.
    notes : str
        Free text.
    open_stats : OpenCircuitStats or None
        Diagnostics of the open-circuit recording, if ``r_adc`` came from one.
    short_stats : ShortCircuitStats or None
        Diagnostics of the short-circuit recordings, if ``r_mux`` came from them.
    mat_calibration : dict or None
        The mat's pressure calibration (:meth:`psmat.pressure.PressureCalibration.to_dict`),
        stored as given.
    """

    serial: str
    r_adc: float | None = None
    r_mux: float | NDArray[np.float64] | None = None
    r_o: float = 2200.0
    v_ref: float = 3.3
    bits: int = 12
    date: str = field(default_factory=_today)
    notes: str = ""
    open_stats: OpenCircuitStats | None = None
    short_stats: ShortCircuitStats | None = None
    mat_calibration: dict[str, Any] | None = None

    @property
    def has_electronics(self) -> bool:
        """Whether the file holds R_adc and R_mux (else only a pressure part)."""
        return self.r_adc is not None

    def __post_init__(self) -> None:
        if not isinstance(self.serial, str):
            raise TypeError(f"serial must be a str, got {type(self.serial).__name__}")
        if not isinstance(self.notes, str):
            raise TypeError(f"notes must be a str, got {type(self.notes).__name__}")
        if not isinstance(self.date, str):
            raise TypeError(f"date must be an ISO 8601 str, got {type(self.date).__name__}")
        try:
            _dt.datetime.fromisoformat(self.date)
        except ValueError:
            raise ValueError(f"date must be ISO 8601 (YYYY-MM-DD[THH:MM:SS]), got {self.date!r}") from None
        if self.mat_calibration is not None:
            if not isinstance(self.mat_calibration, Mapping):
                raise TypeError(f"mat_calibration must be a dict, got {type(self.mat_calibration).__name__}")
            self.mat_calibration = dict(self.mat_calibration)
        if (self.r_adc is None) != (self.r_mux is None):
            raise ValueError("r_adc and r_mux come together: give both (the electronics part) or neither")
        if self.r_adc is None:  # no electronics part: the constants are still checked
            self.r_o, _, _, self.v_ref, self.bits = check_constants(self.r_o, 0.0, math.inf, self.v_ref, self.bits)
            return
        # the circuit's own checks (types, ranges, r_mux shape), with the same messages
        self.r_o, self.r_mux, self.r_adc, self.v_ref, self.bits = check_constants(
            self.r_o, self.r_mux, self.r_adc, self.v_ref, self.bits
        )

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Calibration):
            return NotImplemented
        return (
            (self.serial, self.r_adc, self.r_o, self.v_ref, self.bits, self.date, self.notes)
            == (other.serial, other.r_adc, other.r_o, other.v_ref, other.bits, other.date, other.notes)
            and np.shape(self.r_mux) == np.shape(other.r_mux)
            and np.array_equal(self.r_mux, other.r_mux)
            and self.open_stats == other.open_stats
            and self.short_stats == other.short_stats
            and self.mat_calibration == other.mat_calibration
        )

    __hash__ = None  # type: ignore[assignment]

    # ------------------------------------------------------------------ JSON
    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dict; units in the key names, arrays as nested lists, NaN as null."""

        def arr(a: NDArray[np.float64]) -> Any:
            return np.where(np.isnan(a), None, a).tolist()

        d: dict[str, Any] = {
            "format": _FORMAT,
            "version": _VERSION,
            "serial": self.serial,
            "date": self.date,
            "notes": self.notes,
            "r_o_ohm": self.r_o,
            "v_ref_volt": self.v_ref,
            "bits": self.bits,
            "pressure": self.mat_calibration,
        }
        if not self.has_electronics:
            return d
        assert self.r_adc is not None and self.r_mux is not None
        d.update({
            "r_adc_ohm": None if math.isinf(self.r_adc) else self.r_adc,
            "r_mux_ohm": self.r_mux if isinstance(self.r_mux, float) else arr(self.r_mux),
            "open_circuit": None,
            "short_circuit": None,
        })
        if self.open_stats is not None:
            s = self.open_stats
            d["open_circuit"] = {
                "count_mean": s.count_mean,
                "count_sd": s.count_sd,
                "n_samples": s.n_samples,
                "clipped_fraction": s.clipped_fraction,
                "r_adc_se_ohm": s.r_adc_se,
                "r_adc_per_count_ohm": s.r_adc_per_count,
            }
        if self.short_stats is not None:
            t = self.short_stats
            d["short_circuit"] = {
                "r_mux_pairs_ohm": arr(t.r_mux_pairs),
                "r_mux_summary_ohm": t.summary,
                "r_mux_spread_ohm": t.spread,
            }
        return d

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> Calibration:
        """Inverse of :meth:`to_dict`; malformed content → ValueError."""
        try:
            if not isinstance(d, Mapping):
                raise TypeError("top level is not an object")
            if d.get("format") != _FORMAT:
                raise ValueError(f"'format' is {d.get('format')!r}, expected {_FORMAT!r}")
            version = d.get("version")
            if isinstance(version, bool) or version not in _READS:
                raise ValueError(f"unsupported version {version!r} (this psmat reads {', '.join(map(str, _READS))})")
            pressure = d.get("pressure") if version >= 2 else None
            if pressure is not None and not isinstance(pressure, Mapping):
                raise TypeError(f"'pressure' must be an object, got {pressure!r}")

            def num(x: Any, key: str) -> float:
                if isinstance(x, bool) or not isinstance(x, (int, float)):
                    raise TypeError(f"{key!r} must be a number, got {x!r}")
                return float(x)

            def arr(x: Any, key: str) -> NDArray[np.float64]:
                a = np.array([[np.nan if v is None else num(v, key) for v in row] for row in x], dtype=np.float64)
                if a.ndim != 2 or a.size == 0:
                    raise ValueError(f"{key!r} must be a non-empty 2-D nested list")
                return a

            if version >= 2 and "r_adc_ohm" not in d and "r_mux_ohm" not in d:  # the pressure part alone
                if any(k in d for k in _ELECTRONICS):
                    raise ValueError("open_circuit/short_circuit without r_adc_ohm and r_mux_ohm")
                bits = d["bits"]
                if isinstance(bits, bool) or not isinstance(bits, int):
                    raise TypeError(f"'bits' must be an integer, got {bits!r}")
                return cls(serial=d["serial"], r_o=num(d["r_o_ohm"], "r_o_ohm"),
                           v_ref=num(d["v_ref_volt"], "v_ref_volt"), bits=bits, date=d["date"],
                           notes=d.get("notes", ""), mat_calibration=pressure)

            rm = d["r_mux_ohm"]
            r_mux = arr(rm, "r_mux_ohm") if isinstance(rm, list) else num(rm, "r_mux_ohm")
            bits = d["bits"]
            if isinstance(bits, bool) or not isinstance(bits, int):
                raise TypeError(f"'bits' must be an integer, got {bits!r}")
            open_stats = short_stats = None
            if d.get("open_circuit") is not None:
                o = d["open_circuit"]
                open_stats = OpenCircuitStats(
                    count_mean=num(o["count_mean"], "count_mean"),
                    count_sd=num(o["count_sd"], "count_sd"),
                    n_samples=int(num(o["n_samples"], "n_samples")),
                    clipped_fraction=num(o["clipped_fraction"], "clipped_fraction"),
                    r_adc_se=num(o["r_adc_se_ohm"], "r_adc_se_ohm"),
                    r_adc_per_count=num(o["r_adc_per_count_ohm"], "r_adc_per_count_ohm"),
                )
            if d.get("short_circuit") is not None:
                s = d["short_circuit"]
                pairs = arr(s["r_mux_pairs_ohm"], "r_mux_pairs_ohm")
                pairs.setflags(write=False)
                short_stats = ShortCircuitStats(
                    r_mux_pairs=pairs,
                    summary=num(s["r_mux_summary_ohm"], "r_mux_summary_ohm"),
                    spread=num(s["r_mux_spread_ohm"], "r_mux_spread_ohm"),
                )
            return cls(
                serial=d["serial"],
                r_adc=math.inf if d["r_adc_ohm"] is None else num(d["r_adc_ohm"], "r_adc_ohm"),
                r_mux=r_mux,
                r_o=num(d["r_o_ohm"], "r_o_ohm"),
                v_ref=num(d["v_ref_volt"], "v_ref_volt"),
                bits=bits,
                date=d["date"],
                notes=d.get("notes", ""),
                open_stats=open_stats,
                short_stats=short_stats,
                mat_calibration=pressure,
            )
        except (KeyError, TypeError, ValueError, AttributeError) as exc:
            what = f"missing key {exc}" if isinstance(exc, KeyError) else str(exc)
            raise ValueError(f"invalid calibration data: {what}") from exc

    def save(self, path: str | Path, *, overwrite: bool = True) -> None:
        """Write the calibration as JSON (UTF-8) to ``path``, whole or not at all
        (:func:`psmat._atomic.write_text_atomic`); with ``overwrite=False`` an existing ``path`` is
        an error (:class:`psmat._atomic.OutputRefused`)."""
        from .._atomic import write_text_atomic

        text = json.dumps(self.to_dict(), indent=2, allow_nan=False) + "\n"
        write_text_atomic(path, text, overwrite=overwrite)

    @classmethod
    def load(cls, path: str | Path) -> Calibration:
        """Read a calibration written by :meth:`save`.

        Raises
        ------
        FileNotFoundError
            If ``path`` does not exist.
        ValueError
            If the file is not valid JSON or not a valid calibration (message names the problem).
        """
        raw = Path(path).read_bytes()
        try:
            # (a byte-order mark, from an editor on Windows, is no part of the JSON: RFC 8259 §8.1)
            d = json.loads(raw.decode("utf-8-sig"), parse_constant=_reject_constant)
        except ValueError as exc:  # JSONDecodeError and UnicodeDecodeError are ValueErrors
            raise ValueError(f"{path}: not a valid calibration JSON file: {exc}") from exc
        try:
            return cls.from_dict(d)
        except ValueError as exc:
            raise ValueError(f"{path}: {exc}") from exc

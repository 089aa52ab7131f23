"""A mat's pressure calibration as data (docs/spec.md §4 "Pressure calibration").

Three independent parts, each with the date it was made; any may be missing:

* ``sensor`` — a sensor model fitted on pneumatic-platform data (:func:`psmat.sensor.fit`); None
  means the nominal model of the thesis (Table 2.11);
* ``gains`` — per-cell conductance gains from uniform loads (:func:`psmat.pressure.equilibrate`);
* ``scale`` — one factor from a known load (:func:`psmat.pressure.known_load`, eq. 3.3).

The chain (:class:`psmat.process.Processor`) runs the inverse sensor model on
``g · gains · scale`` (:meth:`PressureCalibration.effective`). The calibration file of
``psmat calibrate`` (:class:`psmat.Calibration`) stores :meth:`PressureCalibration.to_dict`
under its key ``"pressure"``.
"""

from __future__ import annotations

import datetime as _dt
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..sensor import MPICreep

__all__ = ["PressureCalibration", "describe", "utc_now"]

_NOMINAL = "nominal sensor model (thesis Table 2.11)"


def utc_now() -> str:
    """The current UTC time as ISO 8601 to the second (``2026-11-27T10:15:00Z``)."""
    return _dt.datetime.now(_dt.timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ")


def _date(stamp: str | None) -> str:
    return (stamp or "undated")[:10]


def _stamp(name: str, value: Any) -> str | None:
    if value is None:
        return None
    if not isinstance(value, str):
        raise TypeError(f"{name} must be an ISO 8601 str, got {type(value).__name__}")
    try:
        _dt.datetime.fromisoformat(value.replace("Z", "+00:00"))
    except ValueError:
        raise ValueError(f"{name} must be ISO 8601 (YYYY-MM-DD[THH:MM:SSZ]), got {value!r}") from None
    return value


@dataclass(eq=False)
class PressureCalibration:
    """How a mat's conductances become absolute pressure.

    Attributes
    ----------
    sensor : MPICreep or None
        Sensor model fitted on pneumatic data; None: the thesis' nominal model (Table 2.11).
    sensor_fitted_utc, sensor_source : str or None
        When the model was fitted (ISO 8601) and on what (a log's file name).
    gains : (R, C) array or None
        Per-cell conductance gains ``k_ij`` (dimensionless, > 0): the inverse model is run on
        ``k_ij · g_ij``.
    gains_utc : str or None
        When the gains were made (ISO 8601).
    gain_levels_kpa : tuple of float
        The uniform loads they were made at (kPa).
    gains_flagged : (R, C) bool array or None
        Cells that never gave a gain (unloaded or out of the model's reach); they hold the
        median gain of the others.
    scale : float or None
        A global conductance factor (dimensionless, > 0) from a known load, on top of the gains.
    scale_utc : str or None
        When it was made (ISO 8601).
    scale_load_n : float or None
        The known load (N).
    """

    sensor: MPICreep | None = None
    sensor_fitted_utc: str | None = None
    sensor_source: str | None = None
    gains: NDArray[np.float64] | None = None
    gains_utc: str | None = None
    gain_levels_kpa: tuple[float, ...] = ()
    gains_flagged: NDArray[np.bool_] | None = None
    scale: float | None = None
    scale_utc: str | None = None
    scale_load_n: float | None = None

    def __post_init__(self) -> None:
        if self.sensor is not None and not isinstance(self.sensor, MPICreep):
            raise TypeError(f"sensor must be an MPICreep or None, got {type(self.sensor).__name__}")
        for name in ("sensor_fitted_utc", "gains_utc", "scale_utc"):
            setattr(self, name, _stamp(name, getattr(self, name)))
        if self.gains is not None:
            k = np.array(self.gains, dtype=np.float64)
            if k.ndim != 2 or k.size == 0 or not np.all(np.isfinite(k) & (k > 0)):
                raise ValueError("gains must be a non-empty (R, C) array of finite gains > 0")
            k.setflags(write=False)
            self.gains = k
            if self.gains_flagged is not None:
                f = np.array(self.gains_flagged, dtype=bool)
                if f.shape != k.shape:
                    raise ValueError(f"gains_flagged must have the gains' shape {k.shape}, got {f.shape}")
                f.setflags(write=False)
                self.gains_flagged = f
        elif self.gains_flagged is not None:
            raise ValueError("gains_flagged needs gains")
        levels = tuple(float(v) for v in self.gain_levels_kpa)
        if not all(np.isfinite(v) and v > 0 for v in levels):
            raise ValueError(f"gain_levels_kpa must be loads > 0 kPa, got {self.gain_levels_kpa!r}")
        self.gain_levels_kpa = levels
        if self.scale is not None:
            s = float(self.scale)
            if not (np.isfinite(s) and s > 0):
                raise ValueError(f"scale must be a finite factor > 0, got {self.scale!r}")
            self.scale = s
        if self.scale_load_n is not None:
            w = float(self.scale_load_n)
            if not (np.isfinite(w) and w > 0):
                raise ValueError(f"scale_load_n must be a load > 0 N, got {self.scale_load_n!r}")
            self.scale_load_n = w

    @property
    def is_empty(self) -> bool:
        """No part at all: the nominal model on the raw conductances."""
        return self.sensor is None and self.gains is None and self.scale is None

    def effective(self, g: ArrayLike) -> NDArray[np.float64]:
        """``g · gains · scale``: the conductances (S, (..., R, C)) the inverse sensor model is run on."""
        out = np.asarray(g, dtype=np.float64)
        if self.gains is not None:
            if out.shape[-2:] != self.gains.shape:
                raise ValueError(f"the pressure calibration is for a {self.gains.shape[0]}x{self.gains.shape[1]} "
                                 f"mat, the frames are {out.shape[-2]}x{out.shape[-1]}")
            out = out * self.gains
        if self.scale is not None:
            out = out * self.scale
        return out

    def describe(self) -> str:
        """One line: what made the kPa (e.g. ``equilibrated 2026-11-27 at 20, 40 kPa; known load 686 N
        on 2026-11-27 (scale 1.02); nominal sensor model (thesis Table 2.11)``)."""
        if self.is_empty:
            return describe(None)
        parts = []
        if self.gains is not None:
            levels = ", ".join(f"{v:g}" for v in self.gain_levels_kpa) or "?"
            part = f"equilibrated {_date(self.gains_utc)} at {levels} kPa"
            n = 0 if self.gains_flagged is None else int(self.gains_flagged.sum())
            parts.append(part + (f" ({n} cell{'s' * (n != 1)} without a gain: the median)" if n else ""))
        if self.scale is not None:
            load = f"{self.scale_load_n:.0f} N" if self.scale_load_n is not None else "a known load"
            parts.append(f"known load {load} on {_date(self.scale_utc)} (scale {self.scale:.3g})")
        if self.sensor is None:
            parts.append(_NOMINAL)
        else:
            src = f" on {self.sensor_source}" if self.sensor_source else ""
            parts.append(f"sensor model fitted {_date(self.sensor_fitted_utc)}{src}")
        if self.gains is None and self.scale is None:
            parts.append("no equilibration or known load: kPa relative")
        return "; ".join(parts)

    # ------------------------------------------------------------------ JSON
    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dict (units in the key names; the sensor model as its parameters)."""
        return {
            "sensor": None if self.sensor is None else {k: (list(v) if isinstance(v, tuple) else v)
                                                        for k, v in self.sensor.params.items()},
            "sensor_fitted_utc": self.sensor_fitted_utc,
            "sensor_source": self.sensor_source,
            "gains": None if self.gains is None else self.gains.tolist(),
            "gains_utc": self.gains_utc,
            "gain_levels_kpa": list(self.gain_levels_kpa),
            "gains_flagged": None if self.gains_flagged is None else self.gains_flagged.tolist(),
            "scale": self.scale,
            "scale_utc": self.scale_utc,
            "scale_load_n": self.scale_load_n,
        }

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> PressureCalibration:
        """Inverse of :meth:`to_dict`; malformed content → one-line ValueError."""
        try:
            if not isinstance(d, Mapping):
                raise TypeError("not an object")
            unknown = set(d) - set(cls().to_dict())
            if unknown:
                raise ValueError(f"unknown key(s) {', '.join(sorted(unknown))}")
            sensor = d.get("sensor")
            levels: Sequence[Any] = d.get("gain_levels_kpa") or ()
            return cls(
                sensor=None if sensor is None else MPICreep(**sensor),
                sensor_fitted_utc=d.get("sensor_fitted_utc"),
                sensor_source=d.get("sensor_source"),
                gains=None if d.get("gains") is None else np.array(d["gains"], dtype=np.float64),
                gains_utc=d.get("gains_utc"),
                gain_levels_kpa=tuple(levels),
                gains_flagged=None if d.get("gains_flagged") is None else np.array(d["gains_flagged"], dtype=bool),
                scale=d.get("scale"),
                scale_utc=d.get("scale_utc"),
                scale_load_n=d.get("scale_load_n"),
            )
        except (KeyError, TypeError, ValueError) as exc:
            raise ValueError(f"invalid pressure calibration: {exc}") from None

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, PressureCalibration):
            return NotImplemented
        a, b = self.to_dict(), other.to_dict()
        return a == b

    __hash__ = None  # type: ignore[assignment]


def describe(cal: PressureCalibration | None) -> str:
    """What made a chain's kPa, in one line; ``"uncalibrated: ..."`` for None (no pressure calibration)."""
    if cal is None or cal.is_empty:
        return (f"uncalibrated: {_NOMINAL}, no equilibration or known load: kPa are the nominal model's, "
                "not absolute")
    return cal.describe()

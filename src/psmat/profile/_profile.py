"""A device described as data (docs/spec.md §5 "Device profiles"): :class:`Profile`."""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ._errors import ProfileError
from ._geometry import Geometry
from ._schema import parse

if TYPE_CHECKING:
    from ..circuit import Circuit

__all__ = ["Profile"]


@dataclass(frozen=True)
class Profile:
    """A device: what it is, how it talks, where its cells are, its measurement chain.

    Built by :func:`psmat.profile.load_profile` from a TOML file; every field carries its unit
    in its name (docs/spec.md §1). Two profiles are equal when every field but ``source`` is.

    Attributes
    ----------
    name, description : str
        Short name (the file's stem for a shipped profile) and one line for people.
    kind : str
        ``"psm"`` (a mat), ``"imu"``, ``"daq"`` or ``"pressure"`` (another maker's mat whose
        frames were imported in kPa: a geometry, no circuit).
    protocol : str
        ``"v1"``, ``"v2"`` or ``"csv"`` (psm), ``"v1"``/``"v2"`` (imu), ``"daq-text"`` (daq),
        ``"import"`` (pressure).
    rate_hz : float
        Nominal frame rate (Hz).
    baudrate : int
        Serial line speed (bit/s; ignored by a USB CDC link); 0 for an imported mat (none).
    shape : tuple of int
        Frame shape: (R, C) for a mat, (5, 3) an IMU box, (10,) the DAQ.
    pitch_cm : float or None
        Cell pitch (cm) of a mat; None otherwise.
    geometry : Geometry or None
        Where a mat's cells are (cm); None for a device that is not a mat.
    row_order, col_order : tuple of int or None
        ``row_order[k]`` is the logical row of the k-th row sent on the wire (same for
        columns); None: the wire order is the logical order.
    r_o_ohm, v_ref_volt, bits, r_mux_ohm, r_adc_ohm : float, int or None
        The measurement chain (docs/spec.md §2): divider resistor (Ω), reference voltage (V), ADC
        bits, multiplexer resistance (Ω), ADC input resistance (Ω; ``inf`` an ideal ADC). None
        for a device without one (IMU).
    source : str
        The file it came from, ``builtin:NAME`` for a shipped profile, or what it was built from.
    """

    name: str
    description: str
    kind: str
    protocol: str
    rate_hz: float
    baudrate: int
    shape: tuple[int, ...]
    pitch_cm: float | None = None
    geometry: Geometry | None = None
    row_order: tuple[int, ...] | None = None
    col_order: tuple[int, ...] | None = None
    r_o_ohm: float | None = None
    v_ref_volt: float | None = None
    bits: int | None = None
    r_mux_ohm: float | None = None
    r_adc_ohm: float | None = None
    source: str = field(default="", compare=False)

    def __post_init__(self) -> None:
        # a Profile built by hand goes through the same checks as a file, and holds the same types
        where = self.source or f"profile {self.name!r}"
        checked = parse(self._tables(), where)
        if self.geometry is not None and (tuple(self.shape) != self.geometry.shape
                                          or self.pitch_cm != self.geometry.pitch_cm):
            raise ProfileError(f"{where}: shape and pitch_cm must be the geometry's ({self.geometry.shape}, "
                               f"{self.geometry.pitch_cm} cm), got {tuple(self.shape)}, {self.pitch_cm}")
        for key, value in checked.items():
            object.__setattr__(self, key, value)

    # ------------------------------------------------------------------ derived
    @property
    def cell_area_cm2(self) -> float | None:
        """Area each cell of a mat stands for (cm²), ``pitch²``; None for a device that is not a mat."""
        return None if self.geometry is None else self.geometry.cell_area_cm2

    def circuit(self) -> Circuit:
        """The measurement chain as a :class:`psmat.Circuit` (nominal values; a box's calibration
        refines R_mux and R_adc, :meth:`psmat.Circuit.calibrated`).

        Raises
        ------
        ProfileError
            A device without a circuit (an IMU box).
        """
        from ..circuit import Circuit

        if self.r_o_ohm is None:
            raise ProfileError(f"{self.source or self.name}: a {self.kind} device has no measurement circuit")
        return Circuit(r_o=self.r_o_ohm, r_mux=self.r_mux_ohm, r_adc=self.r_adc_ohm, v_ref=self.v_ref_volt,
                       bits=self.bits)

    def with_shape(self, shape: tuple[int, int]) -> Profile:
        """This mat's profile for another shape: pitch, origin, axes and circuit kept, the wire order
        dropped (it was for the old shape), the name suffixed with the shape."""
        if self.geometry is None:
            raise ProfileError(f"{self.source or self.name}: a {self.kind} device has a fixed shape")
        geometry = self.geometry.with_shape(shape)
        if geometry.shape == self.shape:
            return self
        R, C = geometry.shape
        return replace(self, name=f"{self.name}-{R}x{C}", shape=geometry.shape, geometry=geometry, row_order=None,
                       col_order=None, source=f"{self.source or self.name}, reshaped to {R}x{C}")

    def wire_to_logical(self, frames: ArrayLike) -> NDArray[Any]:
        """Frames (..., R, C) as sent on the wire, reordered into logical rows and columns.

        Wire row ``k`` is logical row ``row_order[k]`` (columns the same); with no order the
        frames come back as they are (as an array).
        """
        a = np.asarray(frames)
        if a.ndim < 2 or a.shape[-2:] != tuple(self.shape[-2:]) or self.geometry is None:
            raise ValueError(f"frames must be (..., {', '.join(map(str, self.shape))}) of a mat, got shape {a.shape}")
        if self.row_order is not None:
            a = a[..., np.argsort(self.row_order), :]
        if self.col_order is not None:
            a = a[..., np.argsort(self.col_order)]
        return a

    def logical_to_wire(self, frames: ArrayLike) -> NDArray[Any]:
        """The inverse of :meth:`wire_to_logical`: logical frames (..., R, C) in the order the mat
        sends its rows and columns (what a simulated mat with this wiring puts on the wire)."""
        a = np.asarray(frames)
        if a.ndim < 2 or a.shape[-2:] != tuple(self.shape[-2:]) or self.geometry is None:
            raise ValueError(f"frames must be (..., {', '.join(map(str, self.shape))}) of a mat, got shape {a.shape}")
        if self.row_order is not None:
            a = a[..., list(self.row_order), :]
        if self.col_order is not None:
            a = a[..., list(self.col_order)]
        return a

    # ------------------------------------------------------------------ as data
    def _tables(self) -> dict[str, Any]:
        """The TOML layout, without ``source``."""
        d: dict[str, Any] = {"name": self.name, "description": self.description, "kind": self.kind,
                             "protocol": self.protocol, "rate_hz": self.rate_hz, "baudrate": self.baudrate}
        if self.kind == "pressure" and not self.baudrate:
            del d["baudrate"]  # an imported mat has no serial line
        if self.geometry is not None:
            d["geometry"] = self.geometry.to_dict()
        else:
            d["shape"] = list(self.shape)
        if self.row_order is not None or self.col_order is not None:
            d["wire"] = {k: list(v) for k, v in (("row_order", self.row_order), ("col_order", self.col_order))
                         if v is not None}
        if self.r_o_ohm is not None:
            d["circuit"] = {"r_o_ohm": self.r_o_ohm, "v_ref_volt": self.v_ref_volt, "bits": self.bits,
                            "r_mux_ohm": self.r_mux_ohm, "r_adc_ohm": self.r_adc_ohm}
        return d

    def to_dict(self) -> dict[str, Any]:
        """Plain JSON-able values (what a session stores): the TOML layout plus ``source``; an
        ideal ADC's infinite R_adc is the string ``"inf"``."""
        d = self._tables()
        if "circuit" in d and math.isinf(d["circuit"]["r_adc_ohm"]):
            d["circuit"]["r_adc_ohm"] = "inf"
        d["source"] = self.source
        return d

    @classmethod
    def from_dict(cls, d: dict[str, Any], where: str | None = None) -> Profile:
        """The inverse of :meth:`to_dict` (also reads a profile file's tables).

        Parameters
        ----------
        d : dict
            The tables; ``source`` optional.
        where : str, optional
            Names the dict in error messages (default its ``source``).

        Raises
        ------
        ProfileError
            A bad or unknown key.
        """
        if not isinstance(d, dict):
            raise ProfileError(f"{where or 'profile'}: a profile is a dict of keys, got {type(d).__name__}")
        d = dict(d)
        source = d.pop("source", None)
        if source is not None and not isinstance(source, str):
            raise ProfileError(f"{where or 'profile'}: source: must be text, got {source!r}")
        fields = parse(d, where or source or "profile")
        return cls(**fields, source=source or (where or ""))

    def to_toml(self) -> str:
        """The profile as the text of a TOML file (``source`` as a comment line)."""
        lines = [f"# source: {self.source}"] if self.source else []
        tables = self._tables()
        subs = [(k, tables.pop(k)) for k in ("geometry", "wire", "circuit") if k in tables]
        lines += [f"{k} = {_toml_value(v)}" for k, v in tables.items()]
        for k, sub in subs:
            lines += ["", f"[{k}]"] + [f"{kk} = {_toml_value(v)}" for kk, v in sub.items()]
        return "\n".join(lines) + "\n"


def _toml_value(v: Any) -> str:
    """A TOML value for text, a number or a list of numbers."""
    if isinstance(v, str):
        return json.dumps(v, ensure_ascii=False)  # a JSON string is a TOML basic string
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        return ("inf" if v > 0 else "-inf") if math.isinf(v) else repr(v)
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    raise TypeError(f"no TOML value for {type(v).__name__}")

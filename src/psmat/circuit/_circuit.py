"""Measurement chain of the basic reading circuit, both ways (docs/spec.md §2; thesis §2.1.4, Fig. 2.3/2.8).

Row ``i`` goes through the row multiplexer to node X, X is tied to ``V_ref`` through ``R_o``,
column ``p`` goes through the column multiplexer to ground and the ADC (input resistance
``R_adc`` to ground) reads X::

    R_path = 1/G + R_mux            # both mux channels in series with the equivalent resistance
    R_x    = R_path || R_adc
    V_x    = V_ref * R_x / (R_o + R_x)
    count  = round(V_x / V_ref * (2**bits - 1)), clipped to [0, 2**bits - 1]

Internally everything is written with conductances, ``G_x = G/(1 + G R_mux) + 1/R_adc`` and
``V_x = V_ref / (1 + R_o G_x)``, which is the same algebra without an infinity for an open
cell (``G = 0``).

The inverse (:meth:`Circuit.conductance`) undoes each step and flags, instead of returning
infinities or negative conductances, the readings that the circuit cannot produce from a
positive finite cell conductance: :data:`SHORT` at or beyond the reading of a zero-resistance
cell, :data:`OPEN` at or beyond the open-circuit reading.

``sensor_side="high"`` mirrors the divider (the material DAQ's option, thesis §2.4.1): the
cell path from ``V_ref`` to X, ``R_o`` (with ``R_adc`` in parallel) from X to ground::

    V_x = V_ref * R_b / (R_path + R_b),   R_b = R_o || R_adc

so an open cell reads 0 V and a zero-resistance cell the highest voltage. This module is the
one home of this algebra: the noise models (:mod:`psmat.noise`), the calibration estimators
and the DAQ divider all call :class:`Circuit`.
"""

from __future__ import annotations

import math
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._checks import conductances, first_bad, real_dtype
from ._calibration import Calibration
from ._checks import check_constants

__all__ = [
    "Circuit",
    "OK",
    "SHORT",
    "OPEN",
    "FIRST_PROTOTYPE_R_ADC",
    "IMPROVED_PROTOTYPE_R_ADC",
]

#: Flag values returned by :meth:`Circuit.conductance` with ``return_flags=True`` (uint8).
OK: int = 0
#: Reading at or beyond a zero-resistance cell (low side: count 0 or ``v <= 0``; inverted ``R_path <= R_mux``).
SHORT: int = 1
#: Reading at or beyond the open-circuit reading (low side: full scale or ``v >= V_ref``; inverted ``G_path <= 0``).
OPEN: int = 2

#: ADC input resistance of the first prototype (thesis §2.2.1: "typical values R_ADC = 123 kΩ").
FIRST_PROTOTYPE_R_ADC: float = 123e3
#: ADC input resistance of the improved prototype (thesis §2.2.2: "about 6.9 MΩ").
IMPROVED_PROTOTYPE_R_ADC: float = 6.9e6


class Circuit:
    """Basic voltage-divider reading circuit of a resistive sensor array (docs/spec.md §2).

    Parameters
    ----------
    r_o : float
        Divider resistor between node X and ``V_ref`` (Ω), > 0 (X and ground on the high
        side). Thesis: 2.2 kΩ.
    r_mux : float or array_like, shape (R, C)
        Series resistance of the row and column multiplexer channels together (Ω), >= 0.
        A scalar, or one value per row-column pair from a calibration; it broadcasts against
        the trailing ``(R, C)`` axes of the conductances. Thesis: 145 Ω.
    r_adc : float
        ADC input resistance to ground (Ω), > 0; ``numpy.inf`` means an ideal ADC.
        Default 6.9 MΩ (improved prototype); see :meth:`first_prototype` for 123 kΩ.
    v_ref : float
        Reference voltage of the divider and full scale of the ADC (V), > 0. Thesis: 3.3 V.
    bits : int
        ADC resolution, 1..16 (counts are returned as uint16). Thesis: 12.
    sensor_side : {"low", "high"}
        ``"low"`` (the mat, docs/spec.md §2): the cell path from X to ground. ``"high"``: the cell
        path from ``V_ref`` to X and ``R_o || R_adc`` from X to ground; an open cell reads 0
        and a zero-resistance cell the top of the range, so the flags swap ends.
    """

    OK = OK
    SHORT = SHORT
    OPEN = OPEN

    def __init__(
        self,
        r_o: float = 2200.0,
        r_mux: float | ArrayLike = 145.0,
        r_adc: float = IMPROVED_PROTOTYPE_R_ADC,
        v_ref: float = 3.3,
        bits: int = 12,
        sensor_side: Literal["low", "high"] = "low",
    ) -> None:
        self._r_o, self._r_mux, self._r_adc, self._v_ref, self._bits = check_constants(r_o, r_mux, r_adc, v_ref, bits)
        if sensor_side not in ("low", "high"):
            raise ValueError(f"sensor_side must be 'low' or 'high', got {sensor_side!r}")
        self._high = sensor_side == "high"
        # high side: X to ground besides the cell path, R_b = R_o || R_adc (Ω)
        self._r_b = self._r_o if math.isinf(self._r_adc) else self._r_o * self._r_adc / (self._r_o + self._r_adc)

    # ------------------------------------------------------------------ constructors
    @classmethod
    def first_prototype(cls, **kwargs: Any) -> Circuit:
        """Circuit of the first prototype (``r_adc = 123 kΩ``, thesis §2.2.1); other defaults unchanged."""
        kwargs.setdefault("r_adc", FIRST_PROTOTYPE_R_ADC)
        return cls(**kwargs)

    def calibrated(self, cal: Calibration) -> Circuit:
        """This circuit with ``r_adc`` and ``r_mux`` replaced by the calibration's: the one way a
        calibration is applied (docs/spec.md §2). ``Circuit(r_o=cal.r_o, v_ref=cal.v_ref,
        bits=cal.bits).calibrated(cal)`` is the circuit of a calibration alone.

        Parameters
        ----------
        cal : Calibration
            A box's calibration (:meth:`Calibration.load`).

        Returns
        -------
        Circuit
            ``r_o``, ``v_ref``, ``bits`` and ``sensor_side`` of this circuit, ``r_adc`` (Ω) and
            ``r_mux`` (Ω, scalar or per pair) of ``cal``.

        Raises
        ------
        TypeError
            ``cal`` is not a :class:`Calibration`.
        ValueError
            If the calibration was made with different ``r_o``, ``v_ref`` or ``bits``: its
            estimates depend on them and would not apply to this circuit.
        """
        if not isinstance(cal, Calibration):
            raise TypeError(f"expected a Calibration, got {type(cal).__name__}")
        if not cal.has_electronics:
            raise ValueError(f"calibration {cal.serial!r} holds no R_adc and R_mux (only a pressure part)")
        for name, mine, theirs in (("r_o", self.r_o, cal.r_o), ("v_ref", self.v_ref, cal.v_ref)):
            if not math.isclose(mine, theirs, rel_tol=1e-9):
                raise ValueError(f"calibration {cal.serial!r} was made with {name}={theirs}, circuit has {mine}")
        if cal.bits != self.bits:
            raise ValueError(f"calibration {cal.serial!r} was made with bits={cal.bits}, circuit has {self.bits}")
        return Circuit(r_o=self.r_o, r_mux=cal.r_mux, r_adc=cal.r_adc, v_ref=self.v_ref, bits=self.bits,
                       sensor_side=self.sensor_side)

    # ------------------------------------------------------------------ properties
    @property
    def r_o(self) -> float:
        """Divider resistor (Ω)."""
        return self._r_o

    @property
    def r_mux(self) -> float | NDArray[np.float64]:
        """Mux series resistance (Ω), scalar or read-only (R, C) array."""
        return self._r_mux

    @property
    def r_adc(self) -> float:
        """ADC input resistance (Ω)."""
        return self._r_adc

    @property
    def v_ref(self) -> float:
        """Reference voltage (V)."""
        return self._v_ref

    @property
    def bits(self) -> int:
        """ADC resolution (bits)."""
        return self._bits

    @property
    def sensor_side(self) -> Literal["low", "high"]:
        """Where the cell path sits in the divider: ``"low"`` (X to ground) or ``"high"`` (V_ref to X)."""
        return "high" if self._high else "low"

    @property
    def full_scale(self) -> int:
        """Largest count, ``2**bits - 1``."""
        return (1 << self._bits) - 1

    @property
    def lsb(self) -> float:
        """Voltage of one count, ``V_ref / (2**bits - 1)`` (V)."""
        return self._v_ref / self.full_scale

    @property
    def v_open(self) -> float:
        """Node voltage with every cell open (V): ``V_ref R_adc / (R_o + R_adc)``, 0 on the high side."""
        return 0.0 if self._high else self._v_ref / (1.0 + self._r_o / self._r_adc)

    def as_dict(self) -> dict[str, Any]:
        """Constants as a plain dict (``r_mux`` as a nested list when per pair), keys in SI units."""
        rm = self._r_mux if isinstance(self._r_mux, float) else self._r_mux.tolist()
        return {"r_o_ohm": self._r_o, "r_mux_ohm": rm, "r_adc_ohm": self._r_adc, "v_ref_volt": self._v_ref,
                "bits": self._bits, "sensor_side": self.sensor_side}

    def __repr__(self) -> str:
        rm = f"{self._r_mux!r}" if isinstance(self._r_mux, float) else f"<array {self._r_mux.shape}>"
        side = ", sensor_side='high'" if self._high else ""
        return (f"Circuit(r_o={self._r_o!r}, r_mux={rm}, r_adc={self._r_adc!r}, v_ref={self._v_ref!r}, "
                f"bits={self._bits}{side})")

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Circuit):
            return NotImplemented
        return (
            (self._r_o, self._r_adc, self._v_ref, self._bits, self._high)
            == (other._r_o, other._r_adc, other._v_ref, other._bits, other._high)
            and np.shape(self._r_mux) == np.shape(other._r_mux)
            and bool(np.all(np.asarray(self._r_mux) == np.asarray(other._r_mux)))
        )

    __hash__ = None  # type: ignore[assignment]

    # ------------------------------------------------------------------ forward
    def _broadcast(self, arr: NDArray[Any], what: str) -> None:
        if isinstance(self._r_mux, np.ndarray):
            try:
                np.broadcast_shapes(arr.shape, self._r_mux.shape)
            except ValueError:
                raise ValueError(
                    f"{what} of shape {arr.shape} does not broadcast against the per-pair r_mux of shape {self._r_mux.shape}"
                ) from None

    def _path_conductance(self, G: NDArray[np.float64]) -> NDArray[np.float64]:
        """``G_path = 1/R_path = G/(1 + G R_mux)`` (S): 1/(1/G + R_mux) without dividing by G."""
        return G / (1.0 + G * self._r_mux)

    def voltage(self, G: ArrayLike) -> NDArray[np.float64]:
        """Node voltage ``V_x`` for equivalent conductances ``G`` (docs/spec.md §2).

        Parameters
        ----------
        G : array_like
            Equivalent conductances (S), finite and >= 0, any shape (broadcast against a
            per-pair ``r_mux``). ``G = 0`` is an open cell: ``R_x = R_adc``.

        Returns
        -------
        ndarray of float64
            ``V_x = V_ref R_x / (R_o + R_x)`` (V); high side ``V_ref R_b / (R_path + R_b)``.
        """
        g = conductances(G)
        self._broadcast(g, "G")
        gp = self._path_conductance(g)
        if self._high:  # V_x = V_ref R_b G_path/(1 + R_b G_path)
            return self._v_ref * (self._r_b * gp) / (1.0 + self._r_b * gp)
        return self._v_ref / (1.0 + self._r_o * (gp + 1.0 / self._r_adc))  # G_x = G_path + 1/R_adc

    def quantise(self, v: ArrayLike) -> NDArray[np.uint16]:
        """ADC counts of node voltages: ``round(v/V_ref (2**bits-1))`` clipped to [0, full scale].

        Parameters
        ----------
        v : array_like
            Node voltages (V), real; NaN is rejected.
        """
        x = real_dtype("v", v).astype(np.float64, copy=False)
        if np.isnan(x).any():
            raise ValueError(f"v contains NaN at index {first_bad(np.isnan(x))}")
        return np.clip(np.rint(x / self._v_ref * self.full_scale), 0, self.full_scale).astype(np.uint16)

    def counts(
        self,
        G: ArrayLike,
        noise_v: float | ArrayLike = 0.0,
        rng: np.random.Generator | int | None = None,
    ) -> NDArray[np.uint16]:
        """ADC counts read for equivalent conductances ``G`` (docs/spec.md §2, with the §2 noise model).

        Parameters
        ----------
        G : array_like
            Equivalent conductances (S), finite and >= 0.
        noise_v : float or array_like
            Standard deviation (V) of Gaussian noise added to ``V_x`` before quantisation
            (thesis Table 2.4: about 1e-3 V). 0 gives the noise-free reading.
        rng : numpy.random.Generator, int or None
            Random generator or seed (``numpy.random.default_rng``) for the noise.

        Returns
        -------
        ndarray of uint16
            Counts in ``[0, 2**bits - 1]``, shape of ``G`` (broadcast with ``r_mux``).
        """
        v = self.voltage(G)
        sv = real_dtype("noise_v", noise_v).astype(np.float64, copy=False)
        if not np.all(np.isfinite(sv)) or np.any(sv < 0):
            raise ValueError("noise_v must be finite and >= 0 (V)")
        if np.any(sv > 0):
            v = v + np.random.default_rng(rng).standard_normal(v.shape) * sv
        return self.quantise(v)

    def sensitivity(self, G: ArrayLike) -> NDArray[np.float64]:
        """Magnitude of the derivative ``|dV_x/dG|`` (V/S), finite everywhere including ``G = 0``.

        Low side: ``V_x`` falls as ``G`` rises; ``-dV_x/dG = V_ref R_o / ((1 + R_o G_x)^2 (1 + G R_mux)^2)``
        by the chain rule through ``V_x = V_ref/(1 + R_o G_x)`` and ``G_x = G/(1 + G R_mux) + 1/R_adc``.
        High side: ``dV_x/dG = V_ref R_b / ((1 + R_b G_path)^2 (1 + G R_mux)^2)``, through
        ``V_x = V_ref R_b G_path/(1 + R_b G_path)``.

        Parameters
        ----------
        G : array_like
            Equivalent conductances (S), finite and >= 0.
        """
        g = conductances(G)
        self._broadcast(g, "G")
        gp = self._path_conductance(g)
        r, gn = (self._r_b, gp) if self._high else (self._r_o, gp + 1.0 / self._r_adc)
        return self._v_ref * r / ((1.0 + r * gn) ** 2 * (1.0 + g * self._r_mux) ** 2)

    # ------------------------------------------------------------------ inverse
    def _invert(self, v: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Raw algebraic inverse: returns (G, G_path) with no flagging; may hold inf/negatives/NaN."""
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            if self._high:  # V_x = V_ref R_b G_path/(1 + R_b G_path) solved for G_path
                gpath = v / (self._r_b * (self._v_ref - v))
            else:
                gx = (self._v_ref / v - 1.0) / self._r_o  # 1/R_x from the divider
                gpath = gx - 1.0 / self._r_adc  # remove R_adc in parallel
            g = gpath / (1.0 - gpath * self._r_mux)  # subtract R_mux: 1/(1/G_path - R_mux)
        return g, gpath

    def _range_ends(
        self, at_zero: NDArray[np.bool_], at_top: NDArray[np.bool_]
    ) -> tuple[NDArray[np.bool_], NDArray[np.bool_]]:
        """(short, open) masks of the readings at or beyond the ends of the range: a
        zero-resistance cell reads the bottom on the low side, the top on the high side."""
        return (at_top, at_zero) if self._high else (at_zero, at_top)

    def _flag_and_clean(
        self,
        g: NDArray[np.float64],
        gpath: NDArray[np.float64],
        short: NDArray[np.bool_],
        open_: NDArray[np.bool_],
        keep_open: bool = False,
    ) -> tuple[NDArray[np.float64], NDArray[np.uint8]]:
        # inside the range: open  <=>  G_path <= 0 (R_x >= R_adc) ; short  <=>  G_path R_mux >= 1 (R_path <= R_mux)
        inside = ~(short | open_)
        with np.errstate(invalid="ignore"):  # inf * 0 at count 0 with R_mux = 0: already SHORT
            open_ = open_ | (inside & (gpath <= 0))
            short = short | (inside & ~open_ & ((gpath * self._r_mux >= 1.0) | ~np.isfinite(g)))
        flags = np.where(short, SHORT, np.where(open_, OPEN, OK)).astype(np.uint8)
        keep = (flags == OK) | (open_ if keep_open else False)
        return np.where(keep, g, np.nan), flags

    def conductance_from_voltage(
        self, v: ArrayLike, return_flags: bool = False, *, extrapolate_open: bool = False
    ) -> NDArray[np.float64] | tuple[NDArray[np.float64], NDArray[np.uint8]]:
        """Exact inverse of :meth:`voltage` (no quantisation).

        Parameters
        ----------
        v : array_like
            Node voltages (V), real, not NaN.
        return_flags : bool
            Also return the uint8 flags (:data:`OK`, :data:`SHORT`, :data:`OPEN`).
        extrapolate_open : bool
            At or beyond the open-circuit reading (flag :data:`OPEN`), return the algebraic
            continuation ``G = G_path/(1 - G_path R_mux)`` instead of NaN: it passes smoothly
            through ``G = 0`` to negative values and has no pole on that side (the noise
            model, docs/spec.md §2). The short side stays NaN: no finite conductance reads there.

        Returns
        -------
        G : ndarray of float64
            Equivalent conductances (S); NaN where flagged: at or beyond the reading of a
            zero-resistance cell (SHORT; low side ``v <= 0``), at or beyond the open-circuit
            reading (OPEN; low side ``v >= V_ref``) unless ``extrapolate_open``.
        flags : ndarray of uint8, only if ``return_flags``
        """
        x = real_dtype("v", v).astype(np.float64, copy=False)
        if np.isnan(x).any():
            raise ValueError(f"v contains NaN at index {first_bad(np.isnan(x))}")
        self._broadcast(x, "v")
        g, gpath = self._invert(x)
        short, open_ = self._range_ends(x <= 0, x >= self._v_ref)
        g, flags = self._flag_and_clean(g, gpath, short, open_, keep_open=extrapolate_open)
        return (g, flags) if return_flags else g

    def _check_counts(self, counts: ArrayLike) -> NDArray[np.float64]:
        c = real_dtype("counts", counts)
        if c.dtype.kind == "f":
            bad = np.isnan(c)
            if bad.any():
                raise ValueError(f"counts contain NaN at index {first_bad(bad)}")
            bad = c != np.round(c)
            if bad.any():
                raise ValueError(f"counts must be integer-valued; {c[first_bad(bad)]!r} at index {first_bad(bad)}")
        bad = c < 0
        if bad.any():
            raise ValueError(f"counts must be >= 0; {c[first_bad(bad)]!r} at index {first_bad(bad)}")
        bad = c > self.full_scale
        if bad.any():
            raise ValueError(
                f"counts must be <= full scale {self.full_scale} ({self._bits} bits); "
                f"{c[first_bad(bad)]!r} at index {first_bad(bad)}"
            )
        return c.astype(np.float64)

    def conductance(
        self, counts: ArrayLike, return_flags: bool = False
    ) -> NDArray[np.float64] | tuple[NDArray[np.float64], NDArray[np.uint8]]:
        """Equivalent conductances from ADC counts: the exact inverse of each step of docs/spec.md §2.

        The count is taken at its code centre ``v = count/(2**bits-1) V_ref``; then the
        divider is undone (``R_x = R_o v/(V_ref - v)``), ``R_adc`` removed in parallel
        (``R_path = 1/(1/R_x - 1/R_adc)``) and ``R_mux`` subtracted (``G = 1/(R_path - R_mux)``).
        On the high side the divider gives ``R_path = R_b (V_ref - v)/v`` directly.

        Parameters
        ----------
        counts : array_like
            ADC counts, any integer dtype or integer-valued floats in ``[0, 2**bits - 1]``.
        return_flags : bool
            Also return the uint8 flags array.

        Returns
        -------
        G : ndarray of float64
            Equivalent conductances (S), finite and > 0 where the flag is :data:`OK`, NaN
            elsewhere (never inf or negative).
        flags : ndarray of uint8, only if ``return_flags``
            :data:`OK` (0); :data:`SHORT` (1): count 0 (full scale on the high side) or
            ``R_path <= R_mux`` (reads as a zero or negative cell resistance); :data:`OPEN`
            (2): full scale (0 on the high side) or ``G_path <= 0`` (at or beyond the
            open-circuit reading).

        Raises
        ------
        TypeError
            For non-real dtypes (complex, object, str, bool).
        ValueError
            For NaN, negative, non-integer or above-full-scale counts, or a shape that does
            not broadcast against a per-pair ``r_mux``.
        """
        c = self._check_counts(counts)
        self._broadcast(c, "counts")
        g, gpath = self._invert(c / self.full_scale * self._v_ref)
        g, flags = self._flag_and_clean(g, gpath, *self._range_ends(c == 0, c == self.full_scale))
        return (g, flags) if return_flags else g


"""Noise model of the measurement (thesis Table 2.4 and Fig. 2.12; docs/spec.md §2 "Noise model").

Two models of the noise on an equivalent conductance ``G`` (S):

* ``"table"`` — Gaussian on ``G`` with the relative standard deviation of Fig. 2.12: the
  Table 2.4 points expressed in relative terms, ``σ_G/G = σ_g R`` (``R = 1/G``),
  interpolated linearly in ``log R`` between the points and held constant outside them
  (thesis §2.3.2: "For intermediate values, linear interpolation has been used").
* ``"voltage"`` — Gaussian on the ADC node voltage ``V_x`` (σ_v ≈ 1 mV, Table 2.4) pushed
  through the circuit of :class:`psmat.circuit.Circuit` and inverted without quantisation.

Each model has its standard deviation of ``G``: :func:`table_sigma_G` and
:func:`voltage_sigma_G` (first order, ``σ_v / |dV_x/dG|``); :func:`add_noise` draws from either.
"""

from __future__ import annotations

from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ._checks import conductances, real_dtype
from .circuit import Circuit

__all__ = [
    "TABLE_2_4_R_OHM",
    "TABLE_2_4_SIGMA_V_MV",
    "TABLE_2_4_SIGMA_G_S",
    "TABLE_2_4_RELATIVE",
    "relative_sigma",
    "table_sigma_G",
    "voltage_sigma_G",
    "add_noise",
]


def _const(values: list[float]) -> NDArray[np.float64]:
    a = np.array(values, dtype=np.float64)
    a.setflags(write=False)
    return a


#: Test resistors of Table 2.4 (Ω).
TABLE_2_4_R_OHM: NDArray[np.float64] = _const([100.0, 1e3, 10e3, 100e3, 220e3])
#: Measured voltage noise, standard deviation (mV), Table 2.4.
TABLE_2_4_SIGMA_V_MV: NDArray[np.float64] = _const([1.0, 0.9, 1.1, 1.1, 1.1])
#: Associated conductance uncertainty, standard deviation (S), Table 2.4.
TABLE_2_4_SIGMA_G_S: NDArray[np.float64] = _const([7.7e-5, 1.3e-6, 2.4e-7, 1.6e-7, 1.6e-7])
#: Relative standard deviation σ_g/g = σ_g·R at the table points (dimensionless), Fig. 2.12.
TABLE_2_4_RELATIVE: NDArray[np.float64] = _const(list(TABLE_2_4_SIGMA_G_S * TABLE_2_4_R_OHM))

_LOG_R = np.log(TABLE_2_4_R_OHM)


def relative_sigma(G: ArrayLike) -> NDArray[np.float64]:
    """Relative standard deviation ``σ_G/G`` of the Table 2.4 / Fig. 2.12 model.

    Parameters
    ----------
    G : array_like
        Equivalent conductances (S), finite and >= 0, any shape.

    Returns
    -------
    ndarray of float64
        ``σ_G/G`` (dimensionless), linear in ``log(1/G)`` between the table resistances,
        constant below 100 Ω and above 220 kΩ (``G = 0`` takes the 220 kΩ value).
    """
    g = conductances(G)
    with np.errstate(divide="ignore"):
        log_r = -np.log(g)  # log R; +inf for an open cell, which np.interp holds at the end value
    return np.interp(log_r, _LOG_R, TABLE_2_4_RELATIVE)


def table_sigma_G(G: ArrayLike) -> NDArray[np.float64]:
    """Standard deviation of ``G`` (S) in the ``"table"`` model: ``relative_sigma(G) * G``.

    Parameters
    ----------
    G : array_like
        Equivalent conductances (S), finite and >= 0, any shape.

    Returns
    -------
    ndarray of float64
        σ_G (S); zero for an open cell (``G = 0``): the model is relative.
    """
    g = conductances(G)
    return relative_sigma(g) * g


def voltage_sigma_G(G: ArrayLike, sigma_v: float | ArrayLike = 1e-3, circuit: Circuit | None = None
                    ) -> NDArray[np.float64]:
    """First-order standard deviation of ``G`` (S) in the ``"voltage"`` model (thesis Table 2.4).

    Parameters
    ----------
    G : array_like
        Equivalent conductances (S), finite and >= 0.
    sigma_v : float or array_like
        Standard deviation of the noise on ``V_x`` (V), >= 0; broadcasts with ``G``.
    circuit : Circuit, optional
        The reading circuit (default :class:`~psmat.circuit.Circuit` ()).

    Returns
    -------
    ndarray of float64
        ``|dG/dV_x| sigma_v = sigma_v / circuit.sensitivity(G)`` (S); finite at ``G = 0``.
    """
    sv = real_dtype("sigma_v", sigma_v).astype(np.float64, copy=False)
    if not np.all(np.isfinite(sv)) or np.any(sv < 0):
        raise ValueError("sigma_v must be finite and >= 0 (V)")
    return sv / _circuit(circuit).sensitivity(G)


def _circuit(circuit: Circuit | None) -> Circuit:
    if circuit is None:
        return Circuit()
    if not isinstance(circuit, Circuit):
        raise TypeError(f"circuit must be a Circuit, got {type(circuit).__name__}")
    return circuit


def add_noise(
    G: ArrayLike,
    rng: np.random.Generator | int | None = None,
    model: Literal["table", "voltage"] = "table",
    sigma_v: float = 1e-3,
    circuit: Circuit | None = None,
    clip_min: float | None = None,
) -> NDArray[np.float64]:
    """Noisy copy of equivalent conductances ``G`` (Gaussian, thesis §2.3.2 / Table 2.4).

    Parameters
    ----------
    G : array_like
        Noise-free equivalent conductances (S), finite and >= 0, any shape.
    rng : numpy.random.Generator, int or None
        Random generator or seed.
    model : {"table", "voltage"}
        ``"table"``: ``G + N(0, table_sigma_G(G))``. ``"voltage"``: ``V = circuit.voltage(G) +
        N(0, sigma_v)``, then the exact inverse of the circuit (no quantisation), continued
        past the open reading (:meth:`Circuit.conductance_from_voltage` with
        ``extrapolate_open=True``).
    sigma_v : float
        Voltage noise standard deviation (V), ``"voltage"`` model only.
    circuit : Circuit, optional
        Circuit for the ``"voltage"`` model (default :class:`~psmat.circuit.Circuit` ()).
    clip_min : float, optional
        If given, results are raised to at least this value (S), e.g. 0 or a tiny positive
        conductance before a logarithm. NaN stays NaN.

    Returns
    -------
    ndarray of float64
        Noisy ``G`` (S), shape of ``G`` (broadcast with a per-pair ``r_mux``).

    Notes
    -----
    Nothing is clipped unless ``clip_min`` is given: the Gaussian can give negative values
    (for ``"table"`` when ``σ_G/G`` is large, e.g. about 3.5 % at 220 kΩ, so rarely; for
    ``"voltage"`` near an open cell, where the noisy voltage lies beyond the open-circuit
    reading and the algebraic inverse continues smoothly to ``G < 0``). In the
    ``"voltage"`` model a draw whose voltage reaches the reading of a zero-resistance cell
    (or 0 V) has no finite conductance and is returned as NaN.
    """
    g = conductances(G)
    gen = np.random.default_rng(rng)
    if model == "table":
        out = g + gen.standard_normal(g.shape) * table_sigma_G(g)
    elif model == "voltage":
        if not np.isfinite(sigma_v) or sigma_v < 0:
            raise ValueError(f"sigma_v must be finite and >= 0 (V), got {sigma_v!r}")
        cir = _circuit(circuit)
        v = cir.voltage(g)
        v = v + gen.standard_normal(v.shape) * sigma_v
        out = cir.conductance_from_voltage(v, extrapolate_open=True)
    else:
        raise ValueError(f"model must be 'table' or 'voltage', got {model!r}")
    if clip_min is not None:
        with np.errstate(invalid="ignore"):
            out = np.where(np.isnan(out), np.nan, np.maximum(out, float(clip_min)))
    return out


"""Equivalent conductance from the output voltage of the QZPM front end (thesis eq. C.1-C.3).

The connecting node "in" is driven through r_d by an ideal operational amplifier with feedback
resistor r_f and reference V_ref (thesis Fig. C.1b):

    I_in = (V_o - V_ref) / r_f           (C.1)
    V_in = V_ref - I_in r_d              (C.2)
    G    = I_in / V_in                   (C.3)

so, for a network of equivalent conductance G, V_o = V_ref + r_f G V_ref / (1 + G r_d).
"""

from __future__ import annotations

import numpy as np

from .._checks import positive

__all__ = ["from_output_voltage", "output_voltage"]


def _check_circuit(r_d: float, r_f: float, v_ref: float) -> None:
    positive("r_d", r_d)  # Ohm
    positive("r_f", r_f)
    if not (np.isfinite(v_ref) and v_ref != 0):
        raise ValueError(f"v_ref must be a finite non-zero voltage in V, got {v_ref!r}")


def from_output_voltage(v_o, r_d: float = 100.0, r_f: float = 400.0, v_ref: float = 1.0) -> np.ndarray:
    """Equivalent conductance of the network from the amplifier output (eq. C.1-C.3).

    Parameters
    ----------
    v_o : array_like
        Output voltage(s) V_o in V, any shape.
    r_d, r_f : float
        Resistances of the front end in Ohm (defaults: the thesis' 100 Ohm and 400 Ohm).
    v_ref : float
        Reference voltage in V (default 1 V).

    Returns
    -------
    numpy.ndarray
        G = I_in / V_in in S, the shape of ``v_o``.

    Raises
    ------
    ValueError
        Non-finite ``v_o``, or a voltage for which V_in would be 0 (G infinite).
    """
    _check_circuit(r_d, r_f, v_ref)
    v = np.asarray(v_o, dtype=np.float64)
    if not np.all(np.isfinite(v)):
        raise ValueError("v_o has non-finite values (NaN/inf)")
    i_in = (v - v_ref) / r_f  # C.1
    v_in = v_ref - i_in * r_d  # C.2
    if np.any(v_in == 0):
        raise ValueError("v_o gives V_in = 0 (infinite conductance): out of the front end's range")
    return i_in / v_in  # C.3


def output_voltage(G, r_d: float = 100.0, r_f: float = 400.0, v_ref: float = 1.0) -> np.ndarray:
    """Amplifier output voltage for a network of equivalent conductance G (inverse of C.1-C.3).

    Parameters
    ----------
    G : array_like
        Equivalent conductance(s) in S (>= 0), any shape.
    r_d, r_f, v_ref : float
        Front end, as in :func:`from_output_voltage` (Ohm, Ohm, V).

    Returns
    -------
    numpy.ndarray
        V_o = V_ref + r_f G V_ref / (1 + G r_d) in V, the shape of ``G``.
    """
    _check_circuit(r_d, r_f, v_ref)
    g = np.asarray(G, dtype=np.float64)
    if not np.all(np.isfinite(g)) or np.any(g < 0):
        raise ValueError("G must be finite and >= 0 (conductances in S)")
    return v_ref + r_f * g * v_ref / (1.0 + g * r_d)

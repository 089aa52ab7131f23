"""IECM adapted to the QZPM readout (thesis App. C, docs/spec.md §3 "Adaptation to QZPM").

In a quasi-zero-potential readout every row and column line has its own switch that ties it
either to the connecting node "in" (selected) or to ground. The readings are equivalent
conductances between "in" and ground (eq. C.7) for three kinds of configuration: a row and a
column together (R*C pairs), a single row (R) and a single column (C). From them
:func:`solve` recovers the cell conductances **and** the unknown switch conductances (one
shared value or R + C separate ones; eq. C.8-C.9), while :func:`closed_form` is the analytical
"QZPM" method that assumes a known switch resistance (derived in docs/qzpm.md; it stands in
for Hidalgo et al., thesis ref. [138]). :func:`from_output_voltage` / :func:`output_voltage`
are eq. C.1-C.3 (ideal operational amplifier).

All conductances in S, resistances in Ohm, voltages in V.
"""

from ._opamp import from_output_voltage, output_voltage
from ._readout import (
    SWITCH_MODES,
    QzpmSolution,
    Readings,
    closed_form,
    forward,
    jacobian,
    solve,
)

__all__ = [
    "Readings",
    "QzpmSolution",
    "SWITCH_MODES",
    "forward",
    "jacobian",
    "solve",
    "closed_form",
    "from_output_voltage",
    "output_voltage",
]

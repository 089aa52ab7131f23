"""One line for a mat session whose counts fit a narrower ADC than its circuit's (psmat.circuit.narrower_adc),
said by ``psmat record`` after a recording and by ``psmat info``."""

from __future__ import annotations

from typing import Any


def adc_line(session: Any) -> str | None:
    """``no count above 1023 in N valid frames, where an empty cell reads 4094 of 4095 (12 bits): is the
    board's ADC 10-bit? ...``, or None (counts that fit, no valid frame, not a mat)."""
    import numpy as np

    from ..circuit import narrower_adc
    from ..process import session_circuit

    if session.kind != "psm" or not np.any(session.valid):
        return None
    try:
        circuit = session_circuit(session)
    except ValueError:  # (a circuit the session cannot give is said where it is used)
        return None
    top = int(np.max(session.counts[session.valid]))
    bits = narrower_adc(top, circuit)
    if bits is None:
        return None
    empty = int(np.asarray(circuit.counts(np.zeros((1, 1))))[0, 0])
    return (f"no count above {top} in {int(np.sum(session.valid))} valid frames, where an empty cell reads {empty} of "
            f"{circuit.full_scale} ({circuit.bits} bits): is the board's ADC {bits}-bit? Every cell then reads as "
            f"loaded: record with --bits {bits} (or a profile with bits = {bits})")

"""One line for a mat session whose counts fit a narrower ADC than its circuit's (psmat.circuit.narrower_adc):
said by ``psmat record`` after a recording and by ``psmat info``, and a study's error for the session
(processed, every empty cell would read as a loaded one)."""

from __future__ import annotations

import os
from typing import TYPE_CHECKING, Any

from ._session import session_circuit

if TYPE_CHECKING:  # pragma: no cover
    from ..circuit import Circuit


def adc_line(session: Any, calibration: str | os.PathLike[str] | None = None) -> str | None:
    """``no count above 1023 in N valid frames, where an empty cell reads 4094 of 4095 (12 bits): is the
    board's ADC 10-bit? ...``, or None (counts that fit, no valid frame, not a mat).

    Parameters
    ----------
    session : psmat.io.Session
        A loaded session (its frames read).
    calibration : path, optional
        The box's calibration file, as :func:`session_circuit` takes it.
    """
    import numpy as np

    if session.kind != "psm" or not np.any(session.valid):
        return None
    try:
        circuit = session_circuit(session, calibration=calibration)
    except ValueError:  # (a circuit the session cannot give is said where it is used)
        return None
    counts = session.counts[session.valid]
    return adc_hint(int(np.max(counts)), int(np.min(counts)), int(np.sum(session.valid)), circuit)


def adc_hint(max_count: int, min_count: int, n_frames: int, circuit: Circuit) -> str | None:
    """The line of :func:`adc_line` for counts between ``min_count`` and ``max_count`` over ``n_frames`` valid
    frames read with ``circuit`` (the lab app keeps the running extremes of a live device); None when they fit."""
    import numpy as np

    from ..circuit import narrower_adc

    bits = narrower_adc(max_count, circuit, min_count)
    if bits is None:
        return None
    empty = int(np.asarray(circuit.counts(np.zeros((1, 1))))[0, 0])
    return (f"no count above {max_count} in {n_frames} valid frames, where an empty cell reads {empty} of "
            f"{circuit.full_scale} ({circuit.bits} bits): is the board's ADC {bits}-bit? Every cell then reads as "
            f"loaded: record with --bits {bits} (or a profile with bits = {bits})")

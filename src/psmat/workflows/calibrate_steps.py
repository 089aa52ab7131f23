"""The calibration procedure of docs/spec.md §2 (thesis §2.1.4, end), step by step.

1. **Open circuit** — the mat unplugged from the box: every row–column pair reads the ADC's
   own input resistance, so the recording gives ``R_adc``.
2. **Short circuits** — one row wired to one column, for a few pairs (or all of them): the
   pair reads ``R_mux`` (both multiplexer channels in series). With a v2 device the box is
   put in CAL_HOLD mode so every reading of the frame samples the wired pair.
3. The :class:`psmat.Calibration` (``r_adc``, ``r_mux`` with their spread) is written as JSON
   with the box's serial number; :class:`psmat.Circuit` loads it.

``prompt(text)`` is how the person is asked to change the set-up (Enter to go on);
``set_fixture(mode)`` lets the digital twin change it instead (``"open"``,
``("short", i, p)``, ``"mat"``).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from ..circuit import Calibration, Circuit, from_recordings

__all__ = ["run_calibration"]


def _record(dev: Any, seconds: float) -> np.ndarray:
    dev.read()  # drop what was measured before the set-up changed
    batch = dev.read(n=max(2, int(seconds * float((dev.description or {}).get("rate", 100)))), timeout_s=seconds + 2)
    frames = batch.frames[batch.valid]
    if len(frames) == 0:
        raise RuntimeError("no valid frames arrived during this step; is the box streaming?")
    return frames


def run_calibration(dev: Any, pairs: Sequence[tuple[int, int]], *, seconds: float = 1.0,
                    prompt: Callable[[str], Any] = input, set_fixture: Callable[[Any], None] | None = None,
                    circuit: Circuit | None = None, per_pair: bool = False, log=print) -> Calibration:
    """Walk through the steps on an open, started :class:`psmat.acquire.Device`."""
    circuit = circuit or Circuit()
    R, C = dev.shape
    for i, p in pairs:
        if not (0 <= i < R and 0 <= p < C):
            raise ValueError(f"pair ({i}, {p}) is outside the {R}x{C} array")
    hold = dev.protocol == 2

    prompt("Step 1/2: unplug the mat from the box (all cells open), then press Enter. ")
    if set_fixture:
        set_fixture("open")
    open_counts = _record(dev, seconds)
    log(f"  open circuit: {len(open_counts)} frames, mean count {open_counts.mean():.1f} of {circuit.full_scale}")

    shorts: dict[tuple[int, int], np.ndarray] = {}
    for k, (i, p) in enumerate(pairs):
        prompt(f"Step 2/2 ({k + 1}/{len(pairs)}): connect row {i} to column {p} with a wire, then press Enter. ")
        if set_fixture:
            set_fixture(("short", i, p))
        if hold:
            dev.cal_hold(i, p)
        frames = _record(dev, seconds)
        if hold:
            dev.cal_resume()
        shorts[(i, p)] = frames.reshape(len(frames), -1) if hold else frames[:, i, p]
        log(f"  short ({i}, {p}): mean count {shorts[(i, p)].mean():.2f}")
    if set_fixture:
        set_fixture("mat")
    # with CAL_HOLD every reading of the frame is the pair: all samples go in
    samples = {key: np.asarray(v, dtype=np.float64).ravel() for key, v in shorts.items()}
    serial = str((dev.description or {}).get("serial", ""))
    notes = f"psmat calibrate: {len(pairs)} shorted pair(s), {seconds:g} s per step"
    cal = from_recordings(serial, open_counts, samples, circuit, per_pair=per_pair,
                                               shape=(R, C), notes=notes)
    return cal

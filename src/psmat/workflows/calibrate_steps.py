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

import time
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from ..circuit import Calibration, Circuit, from_recordings, from_short_circuit

__all__ = ["run_calibration"]


def _record(dev: Any, seconds: float, rate_hz: float) -> np.ndarray:
    """``seconds`` of valid frames from ``dev``, whose rate is the one it reports, else ``rate_hz`` (Hz)."""
    rate = float((dev.description or {}).get("rate") or rate_hz)
    dev.read()  # drop what was measured before the set-up changed,
    time.sleep(1.5 / rate)  # and the frame being scanned (or on its way) when it changed
    dev.read()
    batch = dev.read(n=max(2, int(seconds * rate)), timeout_s=seconds + 2)
    frames = batch.frames[batch.valid]
    if len(frames) == 0:
        raise RuntimeError("no valid frames arrived during this step; is the box streaming?")
    return frames


def run_calibration(dev: Any, pairs: Sequence[tuple[int, int]], *, seconds: float = 1.0,
                    prompt: Callable[[str], Any] = input, set_fixture: Callable[[Any], None] | None = None,
                    circuit: Circuit | None = None, per_pair: bool = False, log=print,
                    rate_hz: float = 100.0) -> Calibration:
    """Walk through the steps on an open, started :class:`psmat.acquire.Device`.

    ``circuit`` is the box's nominal measurement chain (default :class:`psmat.Circuit`, the thesis'
    12-bit 3.3 V box; pass the profile's, :meth:`psmat.Profile.circuit`): the counts are read
    through it, and the calibration records its ``r_o``, ``v_ref`` and ``bits``. ``rate_hz`` is
    the frame rate (Hz) of a box that does not report one (a csv mat), to size each step.
    """
    circuit = circuit or Circuit()
    R, C = dev.shape
    for i, p in pairs:
        if not (0 <= i < R and 0 <= p < C):
            raise ValueError(f"pair ({i}, {p}) is outside the {R}x{C} array")
    hold = dev.protocol == 2

    prompt("Step 1/2: unplug the mat from the box (all cells open), then press Enter. ")
    if set_fixture:
        set_fixture("open")
    open_counts = _record(dev, seconds, rate_hz)
    log(f"  open circuit: {len(open_counts)} frames, mean count {open_counts.mean():.1f} of {circuit.full_scale}")

    shorts: dict[tuple[int, int], np.ndarray] = {}
    for k, (i, p) in enumerate(pairs):
        prompt(f"Step 2/2 ({k + 1}/{len(pairs)}): connect row {i} to column {p} with a wire, then press Enter. ")
        if set_fixture:
            set_fixture(("short", i, p))
        if hold:
            dev.cal_hold(i, p)
        frames = _record(dev, seconds, rate_hz)
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
    try:
        return from_recordings(serial, open_counts, samples, circuit, per_pair=per_pair, shape=(R, C), notes=notes)
    except ValueError:
        if open_counts.mean() < circuit.full_scale - 1:  # not a reading pinned at full scale: a real problem
            raise
    # every open cell reads full scale: R_adc is too large for the ADC to resolve (R_adc >> R_o * 2**bits,
    # an Arduino's ~100 MOhm at 10 bits), so its effect is below one count and the nominal value stands
    log(f"  R_adc is beyond the ADC's resolution (the open circuit reads full scale): the nominal "
        f"{circuit.r_adc / 1e6:.3g} MOhm is kept")
    return from_short_circuit(samples, circuit, serial=serial, per_pair=per_pair, shape=(R, C),
                              notes=f"{notes}; R_adc nominal (the open circuit read full scale)")

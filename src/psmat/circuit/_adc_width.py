"""Counts that fit a narrower ADC than the circuit's (docs/spec.md §2, §5).

An empty cell reads the circuit's open count, at the top of the range for the thesis' divider
(4094 of 4095 at 12 bits): every recording of a mat holds such readings, since no body covers
every cell. A board whose ADC has k bits fewer than the profile says (a 10-bit Arduino Uno under a
12-bit profile) never sends more than 2^(bits − k) − 1, and every empty cell then reads as a loaded
one: the whole mat looks pressed and nothing downstream says why. Counts that never reach half of
the range, where the circuit puts the open reading above three quarters of it, and whose largest
lies where a narrower ADC reads its empty cells, are that slip.
"""

from __future__ import annotations

import math

import numpy as np

from ._circuit import Circuit

__all__ = ["narrower_adc", "MIN_ADC_BITS"]


#: the narrowest ADC a mat's board has (an 8-bit converter; the Arduino Uno's is 10 bits, STM32's and ESP32's 12)
MIN_ADC_BITS = 8


def narrower_adc(max_count: int, circuit: Circuit, min_count: int | None = None) -> int | None:
    """The ADC width (bits) that a recording whose counts never exceed ``max_count`` was made with, when
    it is narrower than ``circuit.bits``; None when the counts fit the circuit.

    Parameters
    ----------
    max_count : int
        The largest count of a recording (every cell, every valid frame).
    circuit : Circuit
        The circuit the recording is read with (its ``bits`` and its open count, g = 0).
    min_count : int, optional
        The smallest count of the recording: a mat under a body has loaded cells far below its empty
        ones, and counts that stay above half of ``max_count`` (an empty mat, or made-up uniform
        counts) say nothing of the width.

    Returns
    -------
    int or None
        b = ``circuit.bits - k``, 2^k the ratio of the open count to ``max_count`` rounded to a power of
        two, when the open count lies above three quarters of the range, ``max_count`` below half of it
        and within 3 % below where the open count of a b-bit ADC would lie (its empty cells), and
        b >= :data:`MIN_ADC_BITS`; else None. A mat loaded everywhere (a bladder over every cell) reads
        below half the range too, but not at a narrower ADC's top; a circuit whose empty cell reads low
        says nothing of the width.
    """
    full = circuit.full_scale
    open_count = int(np.asarray(circuit.counts(np.zeros((1, 1))))[0, 0])
    if open_count < 0.75 * full or not 0 <= max_count < full / 2:
        return None
    if min_count is not None and min_count > max_count / 2:
        return None
    b = circuit.bits - max(1, round(math.log2((open_count + 1) / (max_count + 1))))
    narrow_open = open_count / full * ((1 << b) - 1) if b >= 1 else 0.0
    return b if b >= MIN_ADC_BITS and 0.97 * narrow_open <= max_count <= (1 << b) - 1 else None

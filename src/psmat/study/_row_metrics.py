"""What a study row holds about one trace (docs/spec.md §9): its sway metrics after the study's one
preprocessing, and its optional 72 descriptors (the ISPGR check of each row is :func:`psmat.balance.ispgr`).

* :func:`sway_metrics` — :func:`psmat.balance.sway` of the trace after ``params["preprocess"]``
  (:func:`psmat.balance.preprocess`: preset ``quijoux2021`` = SWARII to 25 Hz, 4th-order 10 Hz
  Butterworth forward-backward), the same for the platform and every mat variant; ``None``: the
  raw trace at its own rate.
* :func:`descriptor_values` — :func:`psmat.balance.descriptors` with ``params["descriptors"]`` as
  the preset; every value NaN when the trace is too short for them.
* :func:`columns` — the columns of a study's rows for a parameter dict;
* :func:`preprocessing_sentence` — the study report's sentence on it (the preset in
  :func:`psmat.balance.describe_preset`'s words).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Mapping
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..balance import describe_preset, descriptors, preprocess, sway

__all__ = ["sway_metrics", "descriptor_values", "descriptor_columns", "columns", "preprocessing_sentence"]


def sway_metrics(t_s: NDArray[np.float64], cop_cm: NDArray[np.float64], fs_hz: float,
                 preset: str | None) -> dict[str, float]:
    """:func:`psmat.balance.sway` of ``cop_cm`` (N, 2) cm at times ``t_s`` (s): after
    :func:`psmat.balance.preprocess` with ``preset``, or raw at ``fs_hz`` (Hz) when it is None."""
    if preset is None:
        return sway(cop_cm, fs_hz).as_dict()
    t, ml, ap = preprocess(t_s, cop_cm[:, 0], cop_cm[:, 1], preset)
    return sway(np.column_stack((ml, ap)), 1.0 / float(np.median(np.diff(t)))).as_dict()


@functools.cache
def descriptor_columns(preset: str = "quijoux2021") -> tuple[str, ...]:
    """The names of the descriptors (the paper's, in :func:`psmat.balance.descriptors`' order)."""
    rng = np.random.default_rng(0)
    t = np.arange(0.0, 60.0, 0.04)
    walk = np.cumsum(rng.standard_normal((t.size, 2)), axis=0) * 0.02
    return tuple(descriptors(t, walk[:, 0], walk[:, 1], preset=preset))


def descriptor_values(t_s: NDArray[np.float64], cop_cm: NDArray[np.float64], preset: str) -> dict[str, float]:
    """The descriptors of ``cop_cm`` (N, 2) cm at ``t_s`` (s); all NaN when the trace is too short
    or too still for them (documented in docs/spec.md §9, not an error of the row)."""
    try:
        return {k: float(v) for k, v in descriptors(t_s, cop_cm[:, 0], cop_cm[:, 1], preset=preset).items()}
    except ValueError:
        return dict.fromkeys(descriptor_columns(preset), math.nan)


def columns(base: tuple[str, ...], params: Mapping[str, Any]) -> tuple[str, ...]:
    """``base`` (:data:`psmat.study.COLUMNS`) plus the descriptor columns when ``params`` asks for them."""
    preset = params.get("descriptors")
    return base if preset is None else base + descriptor_columns(preset)


def preprocessing_sentence(preset: str | None) -> str:
    """One sentence for the report: the preprocessing the sway metrics were computed after."""
    if preset is None:
        return (f"Sway metrics are computed with {describe_preset(None)}, each trace at its own sample rate; "
                "Eu on the aligned traces at the mat's frame times.")
    return (f"Sway metrics of the platform and of every mat variant are computed after the same preprocessing "
            f"({describe_preset(preset)}); Eu (thesis eq. 3.1) is computed on the aligned, "
            "unfiltered traces at the mat's frame times, as the thesis defines it.")

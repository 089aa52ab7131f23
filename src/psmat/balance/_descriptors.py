"""The posturography descriptors of a CoP trace, preset ``quijoux2021`` (docs/spec.md §7)."""

from __future__ import annotations

from numpy.typing import ArrayLike

from . import _desc_diffusion, _desc_dynamic, _desc_frequency, _desc_positional
from ._preprocess import prepare

__all__ = ["descriptors"]


def descriptors(t_s: ArrayLike, ml_cm: ArrayLike, ap_cm: ArrayLike,
                preset: str | None = "quijoux2021") -> dict[str, float]:
    """The 72 posturography descriptors of Quijoux et al. (2021) of one trace.

    Parameters
    ----------
    t_s : array, (N,)
        Sample times (s), strictly increasing; irregular steps are allowed with the preset.
    ml_cm, ap_cm : array, (N,)
        Centre of pressure, M-L and A-P (cm), finite.
    preset : {"quijoux2021", None}
        ``"quijoux2021"`` (default): the trace is centred, resampled to 25 Hz by SWARII
        (window 1/25 s), low-passed by a 4th-order Butterworth at 10 Hz forward and backward,
        and centred again. ``None``: the trace is only centred; ``t_s`` must then be uniform
        (each step within 1 % of the mean) and gives the rate.

    Returns
    -------
    dict[str, float]
        The descriptors keyed by the paper's names, in four families: positional, dynamic,
        frequency, stochastic (docs/spec.md §7 lists them with their units: cm, cm/s, cm²,
        s, Hz). ``mean_value_{ML,AP}`` is the mean of the raw trace; every other descriptor is
        computed on the prepared (centred) one. A descriptor a trace leaves undefined (no
        complete velocity lobe, no A-P extent for a ratio) is NaN.

    Raises
    ------
    ValueError
        Arrays of different lengths or not one-dimensional, non-finite values, times that do
        not increase strictly, a trace too short for the low-pass (under 16 samples at
        25 Hz, about 0.64 s) or for the stabilogram diffusion's lags (a few seconds, see
        docs/spec.md §7), non-uniform times without a preset, an unknown preset.
    """
    prep = prepare(t_s, ml_cm, ap_cm, preset)
    ml, ap, fs = prep.ml_cm, prep.ap_cm, prep.fs_hz
    if ml.size < 5:
        raise ValueError(f"the prepared trace has {ml.size} samples; the descriptors need at least 5")
    out = _desc_positional.compute(ml, ap, fs, mean_ml_cm=prep.mean_ml_cm, mean_ap_cm=prep.mean_ap_cm)
    for family in (_desc_dynamic, _desc_frequency, _desc_diffusion):
        out.update(family.compute(ml, ap, fs))
    return out

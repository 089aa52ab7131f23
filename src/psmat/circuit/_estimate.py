"""Calibration estimators: R_adc and R_mux of a DAQ box from recordings (docs/spec.md §2; thesis §2.1.4 end).

Thesis procedure: with the mat unplugged every cell is open, so node X sees ``R_o`` to
``V_ref`` and only ``R_adc`` to ground → ``R_adc``; with a wire shorting one row-column pair
(cell resistance 0) the path is the two mux channels alone, ``R_path = R_mux`` → ``R_mux``,
pair by pair ("all the channels have the same value for practical purposes").

The divider is undone by :class:`psmat.circuit.Circuit` (the one home of that algebra) and the
result is a :class:`psmat.circuit.Calibration` (plain data). Example::

    from psmat.circuit import Circuit, from_recordings
    cal = from_recordings("PSM-0042", open_counts, short_counts, Circuit())
    circuit = Circuit().calibrated(cal)
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ._calibration import Calibration, OpenCircuitStats, ShortCircuitStats
from ._circuit import OPEN, SHORT, Circuit

__all__ = ["estimate_r_adc", "estimate_r_mux", "from_open_circuit", "from_short_circuit", "from_recordings"]

_SQRT_2PI = math.sqrt(2.0 * math.pi)


# ---------------------------------------------------------------------- statistics
def _latent_mean(c: NDArray[np.float64], full_scale: int) -> tuple[float, float, float]:
    """Mean and SD (counts) of the reading *before* quantisation and clipping, and the clipped fraction.

    Without clipped samples this is the plain mean and sample SD over all frames and cells.
    When some samples sit at 0 or full scale, the plain mean is biased (the ADC clipped
    the noise), so the interval-censored Gaussian maximum-likelihood estimate is used:
    count ``k`` means the latent value lay in ``[k-1/2, k+1/2]``, with the end codes open
    towards ±inf. It is computed by EM on the histogram (a loop over distinct codes only).

    Notes
    -----
    ``scipy.stats.norm.fit`` of ``scipy.stats.CensoredData`` gives the same estimate (to
    1e-8 counts with a tight optimiser; tests/unit/test_calibration.py checks it) but works
    sample by sample with a generic optimiser: about 2 s for a 12 800-sample recording and
    10 s for 100 000 at that precision (1e-5 counts off with its default one), where this EM
    on the histogram takes milliseconds to a tenth of a second.
    """
    n = c.size
    clipped = (c <= 0) | (c >= full_scale)
    frac = float(clipped.mean())
    mean, sd = float(c.mean()), float(c.std(ddof=1)) if n > 1 else 0.0
    if frac == 0.0:
        return mean, sd, frac
    if frac == 1.0 and np.all(c == c.flat[0]):
        raise ValueError(
            f"every sample reads {int(c.flat[0])} (the end of the ADC range): the latent reading is not identifiable"
        )
    codes, weights = np.unique(c, return_counts=True)
    lo = np.where(codes <= 0, -np.inf, codes - 0.5)
    hi = np.where(codes >= full_scale, np.inf, codes + 0.5)
    w = weights / n
    mu, s = mean, max(sd, 0.3)
    for _ in range(2000):
        a, b = (lo - mu) / s, (hi - mu) / s
        from scipy.special import ndtr  # here: scipy is slow to import (docs/architecture.md)

        z = np.maximum(ndtr(b) - ndtr(a), 1e-300)  # P(interval), standard normal CDF
        pa, pb = np.exp(-0.5 * a * a) / _SQRT_2PI, np.exp(-0.5 * b * b) / _SQRT_2PI  # density, 0 at ±inf
        apa = np.where(np.isfinite(a), a, 0.0) * pa  # a·phi(a) -> 0 at a = -inf
        bpb = np.where(np.isfinite(b), b, 0.0) * pb
        m1 = mu + s * (pa - pb) / z  # E[X | interval]
        var = s * s * (1.0 + (apa - bpb) / z - ((pa - pb) / z) ** 2)
        m2 = var + m1 * m1  # E[X^2 | interval]
        mu_new = float(np.sum(w * m1))
        s_new = math.sqrt(max(float(np.sum(w * m2)) - mu_new * mu_new, 1e-6))
        done = abs(mu_new - mu) < 1e-10 and abs(s_new - s) < 1e-10
        mu, s = mu_new, s_new
        if done:
            break
    return mu, s, frac


def _check_counts(counts: ArrayLike, full_scale: int, what: str) -> NDArray[np.float64]:
    c = np.asarray(counts)
    if c.dtype.kind not in "iuf":
        raise TypeError(f"{what} must be a real numeric array of counts, got dtype {c.dtype}")
    c = c.astype(np.float64)
    if c.size == 0:
        raise ValueError(f"{what} is empty")
    if not np.all(np.isfinite(c)) or np.any(c != np.round(c)) or np.any(c < 0) or np.any(c > full_scale):
        raise ValueError(f"{what} must hold integer counts in [0, {full_scale}] (no NaN)")
    return c


def _circuit(circuit: Circuit | None) -> Circuit:
    """The circuit to calibrate: default :class:`Circuit` (); the mat's low-side divider only."""
    if circuit is None:
        return Circuit()
    if not isinstance(circuit, Circuit):
        raise TypeError(f"circuit must be a Circuit, got {type(circuit).__name__}")
    if circuit.sensor_side != "low":
        raise ValueError("calibration needs sensor_side='low', the mat's circuit (open cells read 0 V on the high side)")
    return circuit


def _with_mux_and_adc(cir: Circuit, r_adc: float) -> Circuit:
    """``cir``'s divider with ``R_mux = 0`` and the given ``R_adc``: its inverse gives ``G_path``."""
    return Circuit(r_o=cir.r_o, r_mux=0.0, r_adc=r_adc, v_ref=cir.v_ref, bits=cir.bits)


def _calibration(cir: Circuit, date: str | None, **fields: Any) -> Calibration:
    """A :class:`Calibration` with the circuit's constants; ``date`` None (or "") means today."""
    return Calibration(r_o=cir.r_o, v_ref=cir.v_ref, bits=cir.bits, **({"date": date} if date else {}), **fields)


# ---------------------------------------------------------------------- estimators
def estimate_r_adc(counts_open: ArrayLike, circuit: Circuit | None = None) -> tuple[float, OpenCircuitStats]:
    """``R_adc`` (Ω) from an open-circuit recording, and its diagnostics.

    Parameters
    ----------
    counts_open : array_like, shape (R, C) or (T, R, C)
        Counts with the mat unplugged (every cell open).
    circuit : Circuit, optional
        Supplies ``r_o``, ``v_ref``, ``bits`` (default :class:`Circuit` ()).

    Notes
    -----
    With every cell open X sees ``R_adc`` alone to ground, so the circuit with no mux and an
    ideal ADC, inverted at the mean count ``m`` (over frames and cells), gives
    ``1/R_adc``: ``R_adc = R_o m/(FS - m)``, ``FS = 2**bits - 1``. Near full scale one count
    is worth ``R_o FS/(FS - m)^2`` Ω — about 5 MΩ for the improved prototype's 6.9 MΩ — so a
    large ``R_adc`` needs noise (dither) and many samples to be estimated well; see
    ``OpenCircuitStats.r_adc_per_count``.
    """
    cir = _circuit(circuit)
    fs = cir.full_scale
    c = _check_counts(counts_open, fs, "counts_open")
    if c.ndim not in (2, 3):
        raise ValueError(f"counts_open must be (R, C) or (T, R, C), got shape {c.shape}")
    m, sd, frac = _latent_mean(c, fs)
    if not 0.0 < m < fs:
        raise ValueError(
            f"open-circuit mean reading {m:.3f} is at the end of the ADC range [0, {fs}]: "
            "R_adc cannot be estimated (mat really unplugged? R_adc beyond the ADC's resolution?)"
        )
    ideal = _with_mux_and_adc(cir, math.inf)
    g_adc = float(ideal.conductance_from_voltage(m / fs * cir.v_ref))  # 1/R_adc (S)
    # chain rule: dR_adc/dm = (dR/dG)(dG/dV)(dV/dm) = lsb / (G^2 |dV/dG|)
    per_count = ideal.lsb / (g_adc**2 * float(ideal.sensitivity(g_adc)))
    stats_ = OpenCircuitStats(
        count_mean=m,
        count_sd=sd,
        n_samples=int(c.size),
        clipped_fraction=frac,
        r_adc_se=per_count * sd / math.sqrt(c.size),
        r_adc_per_count=per_count,
    )
    return 1.0 / g_adc, stats_


def _pair_mean(key: Any, rec: ArrayLike, fs: int) -> tuple[tuple[int, int], float, tuple[int, int] | None]:
    """One short-circuit recording: its pair, the latent mean count and its frame shape (if frames)."""
    if (
        not isinstance(key, tuple)
        or len(key) != 2
        or not all(isinstance(k, (int, np.integer)) and not isinstance(k, bool) for k in key)
        or min(key) < 0
    ):
        raise ValueError(f"keys must be (row, col) pairs of non-negative ints, got {key!r}")
    i, p = int(key[0]), int(key[1])
    c = _check_counts(rec, fs, f"short-circuit recording for pair {key}")
    frame: tuple[int, int] | None = None
    if c.ndim >= 2:
        if c.ndim > 3:
            raise ValueError(f"recording for pair {key} must be (T,), (R, C) or (T, R, C), got {c.shape}")
        frame = (int(c.shape[-2]), int(c.shape[-1]))
        if i >= frame[0] or p >= frame[1]:
            raise ValueError(f"pair {key} is outside the frames of shape {frame}")
        c = c[..., i, p]
    try:
        return (i, p), _latent_mean(c.ravel(), fs)[0], frame
    except ValueError as exc:
        raise ValueError(f"short-circuit recording for pair {key}: {exc}") from None


def estimate_r_mux(
    counts_by_cell: Mapping[tuple[int, int], ArrayLike],
    circuit: Circuit | None = None,
    shape: tuple[int, int] | None = None,
) -> ShortCircuitStats:
    """``R_mux`` (Ω) per shorted pair from short-circuit recordings.

    Parameters
    ----------
    counts_by_cell : mapping {(i, p): array_like}
        For each shorted row ``i`` / column ``p``: either that cell's samples, shape
        ``()`` or ``(T,)``, or whole frames ``(R, C)`` / ``(T, R, C)`` from which
        ``[..., i, p]`` is taken.
    circuit : Circuit, optional
        Supplies ``r_o``, ``v_ref``, ``bits`` and ``r_adc`` (use the calibrated ``r_adc``).
    shape : (R, C), optional
        Array shape; default from the frames given, else the largest index + 1.

    Notes
    -----
    A shorted cell has ``R_path = R_mux``: the circuit with ``R_mux = 0`` inverted at the
    mean count gives ``G_path`` (divider undone, ``R_adc`` removed in parallel) and
    ``R_mux = 1/G_path``; a mean count of 0 is ``R_mux = 0``.
    """
    cir = _circuit(circuit)
    fs = cir.full_scale
    if not isinstance(counts_by_cell, Mapping) or len(counts_by_cell) == 0:
        raise ValueError("counts_by_cell must be a non-empty mapping {(row, col): counts}")
    keys, means = [], []
    frame_shape: tuple[int, int] | None = None
    for key, rec in counts_by_cell.items():  # one entry per shorted pair, not per cell
        pair, mean, frame = _pair_mean(key, rec, fs)
        if frame is not None:
            if frame_shape is not None and frame != frame_shape:
                raise ValueError(f"recordings have different frame shapes {frame_shape} and {frame}")
            frame_shape = frame
        keys.append(pair)
        means.append(mean)
    if shape is None:
        shape = frame_shape or (max(k[0] for k in keys) + 1, max(k[1] for k in keys) + 1)
    shape = (int(shape[0]), int(shape[1]))
    if frame_shape is not None and frame_shape != shape:
        raise ValueError(f"shape {shape} disagrees with the recorded frames {frame_shape}")
    if any(i >= shape[0] or p >= shape[1] for i, p in keys):
        raise ValueError(f"a pair lies outside shape {shape}")
    g_path, flags = _with_mux_and_adc(cir, cir.r_adc).conductance_from_voltage(
        np.asarray(means) / fs * cir.v_ref, return_flags=True
    )
    if np.any(flags == OPEN):
        bad = keys[int(np.flatnonzero(flags == OPEN)[0])]
        raise ValueError(f"short-circuit recording for pair {bad} reads as open (wire not connected?)")
    r_mux = np.where(flags == SHORT, 0.0, 1.0 / g_path)  # SHORT: mean count 0, R_path = 0
    pairs = np.full(shape, np.nan)
    idx = np.asarray(keys)
    pairs[idx[:, 0], idx[:, 1]] = r_mux
    pairs.setflags(write=False)
    spread = float(np.std(r_mux, ddof=1)) if r_mux.size > 1 else 0.0
    return ShortCircuitStats(r_mux_pairs=pairs, summary=float(np.median(r_mux)), spread=spread)


# ---------------------------------------------------------------------- calibrations
def from_open_circuit(
    counts_open: ArrayLike,
    circuit: Circuit | None = None,
    *,
    serial: str = "",
    date: str | None = None,
    notes: str = "",
) -> Calibration:
    """Calibration with ``r_adc`` from an open-circuit recording (see :func:`estimate_r_adc`);
    ``r_mux`` and the constants are the circuit's."""
    cir = _circuit(circuit)
    r_adc, st = estimate_r_adc(counts_open, cir)
    return _calibration(cir, date, serial=serial, r_adc=r_adc, r_mux=cir.r_mux, notes=notes, open_stats=st)


def from_short_circuit(
    counts_by_cell: Mapping[tuple[int, int], ArrayLike],
    circuit: Circuit | None = None,
    *,
    serial: str = "",
    per_pair: bool = False,
    shape: tuple[int, int] | None = None,
    date: str | None = None,
    notes: str = "",
) -> Calibration:
    """Calibration with ``r_mux`` from short-circuit recordings (see :func:`estimate_r_mux`).

    ``r_mux`` is the median over pairs (the thesis found all channels equal), or with
    ``per_pair=True`` the (R, C) array, which then needs a recording for every pair.
    ``r_adc`` and the constants are the circuit's.
    """
    cir = _circuit(circuit)
    st = estimate_r_mux(counts_by_cell, cir, shape)
    if per_pair:
        missing = np.argwhere(np.isnan(st.r_mux_pairs))
        if missing.size:
            raise ValueError(f"per_pair=True needs a recording for every pair; missing e.g. {tuple(missing[0])}")
        r_mux: float | NDArray[np.float64] = st.r_mux_pairs
    else:
        r_mux = st.summary
    return _calibration(cir, date, serial=serial, r_adc=cir.r_adc, r_mux=r_mux, notes=notes, short_stats=st)


def from_recordings(
    serial: str,
    open_counts: ArrayLike,
    short_counts: Mapping[tuple[int, int], ArrayLike],
    circuit: Circuit | None = None,
    *,
    per_pair: bool = False,
    shape: tuple[int, int] | None = None,
    date: str | None = None,
    notes: str = "",
) -> Calibration:
    """Full thesis procedure: ``r_adc`` from the open recording, then ``r_mux`` from the
    short recordings using that ``r_adc``. ``circuit`` supplies ``r_o``, ``v_ref``, ``bits``."""
    cir = _circuit(circuit)
    op = from_open_circuit(open_counts, cir)
    sh = from_short_circuit(short_counts, cir.calibrated(op), per_pair=per_pair, shape=shape)
    return _calibration(cir, date, serial=serial, r_adc=op.r_adc, r_mux=sh.r_mux, notes=notes,
                        open_stats=op.open_stats, short_stats=sh.short_stats)

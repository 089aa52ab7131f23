"""Calibration of a DAQ box: R_adc and R_mux from recordings (SPEC §2; thesis §2.1.4 end).

Thesis procedure: with the mat unplugged every cell is open, so node X sees ``R_o`` to
``V_ref`` and only ``R_adc`` to ground, ``V = V_ref R_adc/(R_o + R_adc)`` → ``R_adc``; with a
wire shorting one row-column pair (cell resistance 0) the path is the two mux channels
alone, ``R_path = R_mux`` → ``R_mux``, pair by pair ("all the channels have the same value
for practical purposes"). A calibration is data, stored with the box's serial number
(JSON, :meth:`Calibration.save` / :meth:`Calibration.load`) and applied with
:meth:`psmat.circuit.Circuit.calibrated`.
"""

from __future__ import annotations

import datetime as _dt
import json
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

if TYPE_CHECKING:  # circuit.py imports this module; import Circuit lazily at run time
    from .circuit import Circuit

__all__ = ["Calibration", "OpenCircuitStats", "ShortCircuitStats"]

_FORMAT = "psmat-calibration"
_VERSION = 1


# ---------------------------------------------------------------------- statistics helpers
def _phi(z: NDArray[np.float64]) -> NDArray[np.float64]:
    """Standard normal density (0 at ±inf)."""
    return np.exp(-0.5 * z * z) / math.sqrt(2.0 * math.pi)


_erf = np.frompyfunc(math.erf, 1, 1)


def _Phi(z: NDArray[np.float64]) -> NDArray[np.float64]:
    """Standard normal CDF (z may be ±inf)."""
    return 0.5 * (1.0 + _erf(z / math.sqrt(2.0)).astype(np.float64))


def _latent_mean(c: NDArray[np.float64], full_scale: int) -> tuple[float, float, float]:
    """Mean and SD (counts) of the reading *before* quantisation and clipping, and the clipped fraction.

    Without clipped samples this is the plain mean and sample SD over all frames and cells.
    When some samples sit at 0 or full scale, the plain mean is biased (the ADC clipped
    the noise), so the interval-censored Gaussian maximum-likelihood estimate is used:
    count ``k`` means the latent value lay in ``[k-1/2, k+1/2]``, with the end codes open
    towards ±inf. It is computed by EM on the histogram (a loop over distinct codes only).
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
        z = np.maximum(_Phi(b) - _Phi(a), 1e-300)
        pa, pb = _phi(a), _phi(b)
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


def _reject_constant(name: str) -> Any:
    """``json.loads`` hook: NaN/Infinity are not JSON and never written by :meth:`Calibration.save`."""
    raise ValueError(f"non-standard JSON constant {name}")


def _today() -> str:
    return _dt.date.today().isoformat()


# ---------------------------------------------------------------------- diagnostics
@dataclass(frozen=True)
class OpenCircuitStats:
    """Diagnostics of the open-circuit (mat unplugged) recording.

    Attributes
    ----------
    count_mean : float
        Mean reading over frames and cells (counts), corrected for ADC clipping if any.
    count_sd : float
        Spread (SD) of the reading over frames and cells (counts).
    n_samples : int
        Number of samples (frames × cells).
    clipped_fraction : float
        Fraction of samples at 0 or full scale.
    r_adc_se : float
        Standard error of ``r_adc`` from the count spread, ``|dR_adc/dc| SD/sqrt(n)`` (Ω).
    r_adc_per_count : float
        Change of the ``r_adc`` estimate per count at this reading (Ω/count): the resolution
        of an undithered (noise-free) recording.
    """

    count_mean: float
    count_sd: float
    n_samples: int
    clipped_fraction: float
    r_adc_se: float
    r_adc_per_count: float


@dataclass(frozen=True, eq=False)
class ShortCircuitStats:
    """Diagnostics of the short-circuit recordings (one wire per row-column pair).

    Attributes
    ----------
    r_mux_pairs : ndarray, shape (R, C)
        ``R_mux`` estimated per pair (Ω); NaN where the pair was not recorded.
    summary : float
        Median over recorded pairs (Ω).
    spread : float
        SD over recorded pairs (Ω); 0 for a single pair.
    """

    r_mux_pairs: NDArray[np.float64]
    summary: float
    spread: float

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, ShortCircuitStats):
            return NotImplemented
        return (
            self.summary == other.summary
            and self.spread == other.spread
            and np.array_equal(self.r_mux_pairs, other.r_mux_pairs, equal_nan=True)
        )

    __hash__ = None  # type: ignore[assignment]


# ---------------------------------------------------------------------- calibration
@dataclass(eq=False)
class Calibration:
    """Calibration of one DAQ box (SPEC §2 "Calibration").

    Attributes
    ----------
    serial : str
        Serial number of the DAQ box.
    r_adc : float
        ADC input resistance (Ω), > 0.
    r_mux : float or ndarray, shape (R, C)
        Series resistance of the two mux channels (Ω), >= 0: one value, or one per pair.
    r_o, v_ref, bits : float, float, int
        Circuit constants the estimates were made with: divider resistor (Ω), reference
        voltage (V), ADC bits. The estimates are only valid for a circuit with these.
    date : str
        ISO 8601 date (or date-time) of the calibration.
    notes : str
        Free text.
    open_stats : OpenCircuitStats or None
        Diagnostics of the open-circuit recording, if ``r_adc`` came from one.
    short_stats : ShortCircuitStats or None
        Diagnostics of the short-circuit recordings, if ``r_mux`` came from them.
    """

    serial: str
    r_adc: float
    r_mux: float | NDArray[np.float64]
    r_o: float = 2200.0
    v_ref: float = 3.3
    bits: int = 12
    date: str = field(default_factory=_today)
    notes: str = ""
    open_stats: OpenCircuitStats | None = None
    short_stats: ShortCircuitStats | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.serial, str):
            raise TypeError(f"serial must be a str, got {type(self.serial).__name__}")
        if not isinstance(self.notes, str):
            raise TypeError(f"notes must be a str, got {type(self.notes).__name__}")
        if not isinstance(self.date, str):
            raise TypeError(f"date must be an ISO 8601 str, got {type(self.date).__name__}")
        try:
            _dt.datetime.fromisoformat(self.date)
        except ValueError:
            raise ValueError(f"date must be ISO 8601 (YYYY-MM-DD[THH:MM:SS]), got {self.date!r}") from None
        # Circuit validates every constant (types, ranges, r_mux shape) with clear messages.
        from .circuit import Circuit

        c = Circuit(r_o=self.r_o, r_mux=self.r_mux, r_adc=self.r_adc, v_ref=self.v_ref, bits=self.bits)
        self.r_o, self.r_adc, self.v_ref, self.bits, self.r_mux = c.r_o, c.r_adc, c.v_ref, c.bits, c.r_mux

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Calibration):
            return NotImplemented
        return (
            (self.serial, self.r_adc, self.r_o, self.v_ref, self.bits, self.date, self.notes)
            == (other.serial, other.r_adc, other.r_o, other.v_ref, other.bits, other.date, other.notes)
            and np.shape(self.r_mux) == np.shape(other.r_mux)
            and np.array_equal(self.r_mux, other.r_mux)
            and self.open_stats == other.open_stats
            and self.short_stats == other.short_stats
        )

    __hash__ = None  # type: ignore[assignment]

    # ------------------------------------------------------------------ estimation
    @staticmethod
    def _circuit(circuit: Circuit | None) -> Circuit:
        from .circuit import Circuit

        if circuit is None:
            return Circuit()
        if not isinstance(circuit, Circuit):
            raise TypeError(f"circuit must be a Circuit, got {type(circuit).__name__}")
        return circuit

    @staticmethod
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
        With every cell open ``V = V_ref R_adc/(R_o + R_adc)``; at the mean count ``m``
        (over frames and cells) ``R_adc = R_o m/(FS - m)``, ``FS = 2**bits - 1``.
        Near full scale one count is worth ``R_o FS/(FS - m)^2`` Ω — about 5 MΩ for the
        improved prototype's 6.9 MΩ — so a large ``R_adc`` needs noise (dither) and many
        samples to be estimated well; see ``OpenCircuitStats.r_adc_per_count``.
        """
        cir = Calibration._circuit(circuit)
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
        r_adc = cir.r_o * m / (fs - m)
        per_count = cir.r_o * fs / (fs - m) ** 2  # dR_adc/dm
        stats = OpenCircuitStats(
            count_mean=m,
            count_sd=sd,
            n_samples=int(c.size),
            clipped_fraction=frac,
            r_adc_se=per_count * sd / math.sqrt(c.size),
            r_adc_per_count=per_count,
        )
        return r_adc, stats

    @staticmethod
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
        A shorted cell has ``R_path = R_mux``: ``R_x = R_o m/(FS - m)`` at the mean count
        ``m``, then ``R_mux = 1/(1/R_x - 1/R_adc)``.
        """
        cir = Calibration._circuit(circuit)
        fs = cir.full_scale
        if not isinstance(counts_by_cell, Mapping) or len(counts_by_cell) == 0:
            raise ValueError("counts_by_cell must be a non-empty mapping {(row, col): counts}")
        keys, means = [], []
        frame_shape: tuple[int, int] | None = None
        for key, rec in counts_by_cell.items():  # one entry per shorted pair, not per cell
            if (
                not isinstance(key, tuple)
                or len(key) != 2
                or not all(isinstance(k, (int, np.integer)) and not isinstance(k, bool) for k in key)
                or min(key) < 0
            ):
                raise ValueError(f"keys must be (row, col) pairs of non-negative ints, got {key!r}")
            i, p = int(key[0]), int(key[1])
            c = _check_counts(rec, fs, f"short-circuit recording for pair {key}")
            if c.ndim >= 2:
                if c.ndim > 3:
                    raise ValueError(f"recording for pair {key} must be (T,), (R, C) or (T, R, C), got {c.shape}")
                fr = (int(c.shape[-2]), int(c.shape[-1]))
                if frame_shape is not None and fr != frame_shape:
                    raise ValueError(f"recordings have different frame shapes {frame_shape} and {fr}")
                frame_shape = fr
                if i >= fr[0] or p >= fr[1]:
                    raise ValueError(f"pair {key} is outside the frames of shape {fr}")
                c = c[..., i, p]
            keys.append((i, p))
            try:
                means.append(_latent_mean(c.ravel(), fs)[0])
            except ValueError as exc:
                raise ValueError(f"short-circuit recording for pair {key}: {exc}") from None
        if shape is None:
            shape = frame_shape or (max(k[0] for k in keys) + 1, max(k[1] for k in keys) + 1)
        shape = (int(shape[0]), int(shape[1]))
        if frame_shape is not None and frame_shape != shape:
            raise ValueError(f"shape {shape} disagrees with the recorded frames {frame_shape}")
        if any(i >= shape[0] or p >= shape[1] for i, p in keys):
            raise ValueError(f"a pair lies outside shape {shape}")
        m = np.asarray(means)
        r_x = cir.r_o * m / (fs - m)  # divider undone
        g_path = 1.0 / np.maximum(r_x, 1e-300) - 1.0 / cir.r_adc  # R_adc removed in parallel
        if np.any(m >= fs) or np.any(g_path <= 0):
            bad = keys[int(np.flatnonzero((m >= fs) | (g_path <= 0))[0])]
            raise ValueError(f"short-circuit recording for pair {bad} reads as open (wire not connected?)")
        r_mux = np.where(m <= 0, 0.0, 1.0 / g_path)
        pairs = np.full(shape, np.nan)
        idx = np.asarray(keys)
        pairs[idx[:, 0], idx[:, 1]] = r_mux
        pairs.setflags(write=False)
        spread = float(np.std(r_mux, ddof=1)) if r_mux.size > 1 else 0.0
        return ShortCircuitStats(r_mux_pairs=pairs, summary=float(np.median(r_mux)), spread=spread)

    @classmethod
    def from_open_circuit(
        cls,
        counts_open: ArrayLike,
        circuit: Circuit | None = None,
        *,
        serial: str = "",
        date: str | None = None,
        notes: str = "",
    ) -> Calibration:
        """Calibration with ``r_adc`` from an open-circuit recording (see :meth:`estimate_r_adc`);
        ``r_mux`` and the constants are the circuit's."""
        cir = cls._circuit(circuit)
        r_adc, stats = cls.estimate_r_adc(counts_open, cir)
        return cls(
            serial=serial, r_adc=r_adc, r_mux=cir.r_mux, r_o=cir.r_o, v_ref=cir.v_ref, bits=cir.bits,
            date=date or _today(), notes=notes, open_stats=stats,
        )  # fmt: skip

    @classmethod
    def from_short_circuit(
        cls,
        counts_by_cell: Mapping[tuple[int, int], ArrayLike],
        circuit: Circuit | None = None,
        *,
        serial: str = "",
        per_pair: bool = False,
        shape: tuple[int, int] | None = None,
        date: str | None = None,
        notes: str = "",
    ) -> Calibration:
        """Calibration with ``r_mux`` from short-circuit recordings (see :meth:`estimate_r_mux`).

        ``r_mux`` is the median over pairs (the thesis found all channels equal), or with
        ``per_pair=True`` the (R, C) array, which then needs a recording for every pair.
        ``r_adc`` and the constants are the circuit's.
        """
        cir = cls._circuit(circuit)
        stats = cls.estimate_r_mux(counts_by_cell, cir, shape)
        if per_pair:
            missing = np.argwhere(np.isnan(stats.r_mux_pairs))
            if missing.size:
                raise ValueError(f"per_pair=True needs a recording for every pair; missing e.g. {tuple(missing[0])}")
            r_mux: float | NDArray[np.float64] = stats.r_mux_pairs
        else:
            r_mux = stats.summary
        return cls(
            serial=serial, r_adc=cir.r_adc, r_mux=r_mux, r_o=cir.r_o, v_ref=cir.v_ref, bits=cir.bits,
            date=date or _today(), notes=notes, short_stats=stats,
        )  # fmt: skip

    @classmethod
    def from_recordings(
        cls,
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
        from .circuit import Circuit

        cir = cls._circuit(circuit)
        op = cls.from_open_circuit(open_counts, cir)
        cir2 = Circuit(r_o=cir.r_o, r_mux=cir.r_mux, r_adc=op.r_adc, v_ref=cir.v_ref, bits=cir.bits)
        sh = cls.from_short_circuit(short_counts, cir2, per_pair=per_pair, shape=shape)
        return cls(
            serial=serial, r_adc=op.r_adc, r_mux=sh.r_mux, r_o=cir.r_o, v_ref=cir.v_ref, bits=cir.bits,
            date=date or _today(), notes=notes, open_stats=op.open_stats, short_stats=sh.short_stats,
        )  # fmt: skip

    def circuit(self) -> Circuit:
        """The :class:`~psmat.circuit.Circuit` this calibration describes."""
        from .circuit import Circuit

        return Circuit.from_calibration(self)

    # ------------------------------------------------------------------ JSON
    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dict; units in the key names, arrays as nested lists, NaN as null."""

        def arr(a: NDArray[np.float64]) -> Any:
            return np.where(np.isnan(a), None, a).tolist()

        d: dict[str, Any] = {
            "format": _FORMAT,
            "version": _VERSION,
            "serial": self.serial,
            "date": self.date,
            "notes": self.notes,
            "r_o_ohm": self.r_o,
            "v_ref_volt": self.v_ref,
            "bits": self.bits,
            "r_adc_ohm": None if math.isinf(self.r_adc) else self.r_adc,
            "r_mux_ohm": self.r_mux if isinstance(self.r_mux, float) else arr(self.r_mux),
            "open_circuit": None,
            "short_circuit": None,
        }
        if self.open_stats is not None:
            s = self.open_stats
            d["open_circuit"] = {
                "count_mean": s.count_mean,
                "count_sd": s.count_sd,
                "n_samples": s.n_samples,
                "clipped_fraction": s.clipped_fraction,
                "r_adc_se_ohm": s.r_adc_se,
                "r_adc_per_count_ohm": s.r_adc_per_count,
            }
        if self.short_stats is not None:
            t = self.short_stats
            d["short_circuit"] = {
                "r_mux_pairs_ohm": arr(t.r_mux_pairs),
                "r_mux_summary_ohm": t.summary,
                "r_mux_spread_ohm": t.spread,
            }
        return d

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> Calibration:
        """Inverse of :meth:`to_dict`; malformed content → ValueError."""
        try:
            if not isinstance(d, Mapping):
                raise TypeError("top level is not an object")
            if d.get("format") != _FORMAT:
                raise ValueError(f"'format' is {d.get('format')!r}, expected {_FORMAT!r}")
            if d.get("version") != _VERSION:
                raise ValueError(f"unsupported version {d.get('version')!r} (this psmat reads {_VERSION})")

            def num(x: Any, key: str) -> float:
                if isinstance(x, bool) or not isinstance(x, (int, float)):
                    raise TypeError(f"{key!r} must be a number, got {x!r}")
                return float(x)

            def arr(x: Any, key: str) -> NDArray[np.float64]:
                a = np.array([[np.nan if v is None else num(v, key) for v in row] for row in x], dtype=np.float64)
                if a.ndim != 2 or a.size == 0:
                    raise ValueError(f"{key!r} must be a non-empty 2-D nested list")
                return a

            rm = d["r_mux_ohm"]
            r_mux = arr(rm, "r_mux_ohm") if isinstance(rm, list) else num(rm, "r_mux_ohm")
            bits = d["bits"]
            if isinstance(bits, bool) or not isinstance(bits, int):
                raise TypeError(f"'bits' must be an integer, got {bits!r}")
            open_stats = short_stats = None
            if d.get("open_circuit") is not None:
                o = d["open_circuit"]
                open_stats = OpenCircuitStats(
                    count_mean=num(o["count_mean"], "count_mean"),
                    count_sd=num(o["count_sd"], "count_sd"),
                    n_samples=int(num(o["n_samples"], "n_samples")),
                    clipped_fraction=num(o["clipped_fraction"], "clipped_fraction"),
                    r_adc_se=num(o["r_adc_se_ohm"], "r_adc_se_ohm"),
                    r_adc_per_count=num(o["r_adc_per_count_ohm"], "r_adc_per_count_ohm"),
                )
            if d.get("short_circuit") is not None:
                s = d["short_circuit"]
                pairs = arr(s["r_mux_pairs_ohm"], "r_mux_pairs_ohm")
                pairs.setflags(write=False)
                short_stats = ShortCircuitStats(
                    r_mux_pairs=pairs,
                    summary=num(s["r_mux_summary_ohm"], "r_mux_summary_ohm"),
                    spread=num(s["r_mux_spread_ohm"], "r_mux_spread_ohm"),
                )
            return cls(
                serial=d["serial"],
                r_adc=math.inf if d["r_adc_ohm"] is None else num(d["r_adc_ohm"], "r_adc_ohm"),
                r_mux=r_mux,
                r_o=num(d["r_o_ohm"], "r_o_ohm"),
                v_ref=num(d["v_ref_volt"], "v_ref_volt"),
                bits=bits,
                date=d["date"],
                notes=d.get("notes", ""),
                open_stats=open_stats,
                short_stats=short_stats,
            )
        except (KeyError, TypeError, ValueError, AttributeError) as exc:
            what = f"missing key {exc}" if isinstance(exc, KeyError) else str(exc)
            raise ValueError(f"invalid calibration data: {what}") from exc

    def save(self, path: str | Path) -> None:
        """Write the calibration as JSON (UTF-8) to ``path``."""
        Path(path).write_text(json.dumps(self.to_dict(), indent=2, allow_nan=False) + "\n", encoding="utf-8")

    @classmethod
    def load(cls, path: str | Path) -> Calibration:
        """Read a calibration written by :meth:`save`.

        Raises
        ------
        FileNotFoundError
            If ``path`` does not exist.
        ValueError
            If the file is not valid JSON or not a valid calibration (message names the problem).
        """
        raw = Path(path).read_bytes()
        try:
            d = json.loads(raw.decode("utf-8"), parse_constant=_reject_constant)
        except ValueError as exc:  # JSONDecodeError and UnicodeDecodeError are ValueErrors
            raise ValueError(f"{path}: not a valid calibration JSON file: {exc}") from exc
        try:
            return cls.from_dict(d)
        except ValueError as exc:
            raise ValueError(f"{path}: {exc}") from exc

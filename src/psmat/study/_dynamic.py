"""A dynamic correction of the mat's smaller sway, fitted on some volunteers and applied to others
(beyond the thesis).

The thesis (§3.3, Tables 3.5/3.6, Fig. 3.2) and the studies it reviews (§3.1) find that a mat's
CoP spreads less than the force platform's; for one commercial mat (a Nitta C-scan against an
AMTI platform, thesis reference [166], reviewed in §3.1) a transfer function found numerically in
the frequency domain brought the mat's trajectories close to the platform's, and it was nearly
the same for every subject, so one filter served all. Here that idea is a per-axis linear map
from a base variant's CoP (default SCHC) to the platform's, on the aligned, mean-removed traces
resampled to one rate, with three candidate models of fixed size:

``gain``  one least-squares gain per axis;
``fir``   a non-causal FIR, taps at lags −L..L (L = ``fir_half_s`` · rate), ridge-regularised
          least squares, solved from the normal equations ``(WᵀW + λ²I) h = Wᵀy``: ``WᵀW`` and
          ``Wᵀy`` add up over sessions, so each session's are formed once and every
          leave-one-out fold sums them (the stacked least squares of every fold cost time
          quadratic in the volunteers: 44 s of a 42-volunteer study);
``tf``    a first-order transfer function ``(b0 + b1 z⁻¹) / (1 + a1 z⁻¹)`` fitted by output
          error (``scipy.optimize.least_squares``), kept stable (|a1| ≤ 0.99): three
          parameters need no other regularisation.

Volunteers are split in folds (default leave-one-volunteer-out); each fold's traces are
corrected by a model fitted on the other folds' volunteers only, so no volunteer's own platform
trace ever enters its own correction. One model is fitted per trial type by default
(``by_trial=False`` pools the trial types).

The defaults — FIR of ±0.1 s, ridge 1e-3, one model per trial type, leave one volunteer out —
are the best or level-best of the schemes compared on held-out volunteers of the study's own
simulation by ``python -m psmat.experiments dynamic_correction`` (which prints the comparison):
the FIR lowers Eu where a gain does not, and a model per trial type brings σ closer to the
platform's than a pooled one (single-leg and rotation trials need different gains). The
correction is linear and the same for every volunteer: it cannot undo a volunteer's own scale
error.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view
from numpy.typing import NDArray
from scipy import linalg, optimize, signal

from ..balance import eu
from ._conditions import condition_of
from ._row_metrics import descriptor_values, sway_metrics
from ._trial import COLUMNS

__all__ = ["MODELS", "Correction", "DynamicPlan", "fit_correction", "dynamic_rows", "plan_dynamic", "correct_session",
           "session_stats"]

MODELS = ("gain", "fir", "tf")
Key = tuple[str, str]  # (subject, trial)


@dataclass(frozen=True)
class Correction:
    """A fitted per-axis correction: ``coef[k]`` are axis k's parameters (M-L, A-P).

    ``gain``: ``(a,)``; ``fir``: the taps ``h`` (2L + 1), ``y[n] = Σ_j h[j]·x[n − L + j]``;
    ``tf``: ``(b0, b1, a1)``. ``rate_hz`` is the rate the model was fitted at.
    """

    model: str
    coef: tuple[NDArray[np.float64], NDArray[np.float64]]
    rate_hz: float

    def apply(self, x: NDArray[np.float64]) -> NDArray[np.float64]:
        """The correction of a mean-removed (n, 2) trace sampled at ``rate_hz``, cm."""
        return np.column_stack([_apply(self.model, c, x[:, k]) for k, c in enumerate(self.coef)])


def _windows(x: NDArray[np.float64], half: int) -> NDArray[np.float64]:
    """(n, 2·half + 1): row n holds x[n − half], ..., x[n + half] (the ends edge-padded)."""
    return sliding_window_view(np.pad(x, half, mode="edge"), 2 * half + 1)


def _tf_out(p: NDArray[np.float64], x: NDArray[np.float64]) -> NDArray[np.float64]:
    b, a = p[:2], np.array([1.0, p[2]])
    return signal.lfilter(b, a, x, zi=signal.lfilter_zi(b, a) * x[0])[0]


def _apply(model: str, c: NDArray[np.float64], x: NDArray[np.float64]) -> NDArray[np.float64]:
    if model == "gain":
        return c[0] * x
    if model == "fir":
        return _windows(x, (c.size - 1) // 2) @ c
    return _tf_out(c, x)


def _fit_axis(model: str, xs: Sequence[NDArray[np.float64]], ys: Sequence[NDArray[np.float64]], half: int,
              ridge: float) -> NDArray[np.float64]:
    x, y = np.concatenate(xs), np.concatenate(ys)
    gain = np.array([float(x @ y / (x @ x))]) if x @ x > 0 else np.zeros(1)
    if model == "gain":
        return gain
    if model == "fir":
        gram, rhs = (sum(parts) for parts in zip(*(_fir_stats(xi, yi, half) for xi, yi in zip(xs, ys))))
        return _fir_taps(gram, rhs, ridge)

    def residual(p: NDArray[np.float64]) -> NDArray[np.float64]:
        return np.concatenate([_tf_out(p, xi) - yi for xi, yi in zip(xs, ys)])

    fit = optimize.least_squares(residual, np.array([gain[0], 0.0, 0.0]),
                                 bounds=([-np.inf, -np.inf, -0.99], [np.inf, np.inf, 0.99]))
    return fit.x


def _fir_half(fir_half_s: float, rate_hz: float) -> int:
    """The FIR's half-length in samples (at least 1) for ``fir_half_s`` seconds at ``rate_hz``."""
    return max(1, int(round(fir_half_s * rate_hz)))


def _fir_stats(x: NDArray[np.float64], y: NDArray[np.float64], half: int) -> tuple[NDArray[np.float64],
                                                                                 NDArray[np.float64]]:
    """``(WᵀW, Wᵀy)`` of one series, W its lag windows (:func:`_windows`): the FIR's sufficient statistics."""
    W = np.ascontiguousarray(_windows(x, half))
    return W.T @ W, W.T @ y


def _fir_taps(gram: NDArray[np.float64], rhs: NDArray[np.float64], ridge: float) -> NDArray[np.float64]:
    """Ridge least-squares taps from summed statistics; λ² = ``ridge`` · the mean column energy."""
    lam2 = ridge * np.trace(gram) / gram.shape[0]
    return linalg.solve(gram + lam2 * np.eye(gram.shape[0]), rhs, assume_a="pos")


def fit_correction(xs: Sequence[NDArray[np.float64]], ys: Sequence[NDArray[np.float64]], rate_hz: float, *,
                   model: str = "fir", fir_half_s: float = 0.1, ridge: float = 1e-3) -> Correction:
    """Fit the map from mat traces ``xs`` to platform traces ``ys``, both (n_i, 2) cm, mean-removed,
    sampled at ``rate_hz`` (Hz); ``fir_half_s`` the FIR's half-length (s), ``ridge`` its
    regularisation relative to the mean tap energy."""
    if model not in MODELS:
        raise ValueError(f"unknown model {model!r}; choose one of {MODELS}")
    half = _fir_half(fir_half_s, rate_hz)
    ml, ap = (_fit_axis(model, [x[:, k] for x in xs], [y[:, k] for y in ys], half, ridge) for k in range(2))
    return Correction(model, (ml, ap), float(rate_hz))


@dataclass
class _Series:
    """One usable session: its trace as stored (gaps in the mat filled) and resampled to the fitting rate."""

    t: NDArray[np.float64]  # (N,) the trace's times, s
    fp: NDArray[np.float64]  # (N, 2) platform CoP, cm
    mat: NDArray[np.float64]  # (N, 2) base variant's CoP, cm
    grid: NDArray[np.float64] = field(init=False)  # uniform times at the fitting rate, s
    x: NDArray[np.float64] = field(init=False)  # mat on the grid, mean-removed, cm
    y: NDArray[np.float64] = field(init=False)  # platform on the grid, mean-removed, cm
    rate_hz: float | None = field(default=None, init=False)  # the grid's rate, Hz (None: not resampled yet)

    def resample(self, rate_hz: float) -> None:
        """Fill ``grid``, ``x`` and ``y`` at ``rate_hz`` (linear interpolation)."""
        self.rate_hz = rate_hz
        self.grid = self.t[0] + np.arange(int(np.floor((self.t[-1] - self.t[0]) * rate_hz)) + 1) / rate_hz
        self.x, self.y = (_at(self.grid, self.t, c) for c in (self.mat, self.fp))
        self.x -= self.x.mean(axis=0)
        self.y -= self.y.mean(axis=0)


def _at(t_new: NDArray[np.float64], t: NDArray[np.float64], c: NDArray[np.float64]) -> NDArray[np.float64]:
    """A (n, 2) trace linearly interpolated at ``t_new`` from its finite samples."""
    ok = np.all(np.isfinite(c), axis=1)
    return np.column_stack([np.interp(t_new, t[ok], c[ok, k]) for k in range(2)])


def _series(trace: Mapping[str, Any] | None, base: str) -> _Series | str:
    """The usable series of one session's trace, or why it is not usable."""
    if trace is None or "t_s" not in trace or "FP" not in trace or base not in trace:
        return f"no aligned {base} and platform traces"
    t = np.asarray(trace["t_s"], np.float64)
    fp, mat = (np.asarray(trace[k], np.float64) for k in ("FP", base))
    if t.ndim != 1 or fp.shape != (t.size, 2) or mat.shape != (t.size, 2):
        return f"malformed trace: t_s {t.shape}, FP {fp.shape}, {base} {mat.shape}"
    if not (np.all(np.isfinite(t)) and np.all(np.isfinite(fp)) and np.all(np.diff(t) > 0)):
        return "the platform trace or its times are not finite and increasing"
    if np.all(np.isfinite(mat), axis=1).sum() < 16:
        return f"fewer than 16 finite {base} samples"
    return _Series(t, fp, _at(t, t, mat))


def _rate(t: NDArray[np.float64]) -> float:
    """A trace's rate (Hz): the inverse of its median sampling interval."""
    return 1.0 / np.median(np.diff(t))


def session_stats(trace: Mapping[str, Any] | None, *, base: str = "SCHC", fir_half_s: float = 0.1
                  ) -> dict[str, NDArray[np.float64]]:
    """What the FIR fit of :func:`dynamic_rows` needs from one session alone, formed where the
    session is processed (its task) so that only the sums and solves remain after the sessions.

    The session's trace resampled at its own rate (``rate_hz``), mean-removed, and per axis
    ``(WᵀW, Wᵀy)`` (:func:`_fir_stats`): ``{"rate_hz": () Hz, "gram": (2, 2L+1, 2L+1) cm²,
    "rhs": (2, 2L+1) cm²}``, or ``{}`` when the trace is not usable (:func:`_series`).
    :func:`dynamic_rows` uses them only where the study's fitting rate is exactly this rate (the
    same numbers as forming them there), and forms them itself otherwise.
    """
    s = _series(trace, base)
    if isinstance(s, str):
        return {}
    fs = float(_rate(s.t))
    s.resample(fs)
    half = _fir_half(fir_half_s, fs)
    st = [_fir_stats(s.x[:, a], s.y[:, a], half) for a in range(2)]
    return {"rate_hz": np.array(fs), "gram": np.stack([g for g, _ in st]), "rhs": np.stack([r for _, r in st])}


def _given_stats(given: Mapping[str, Any] | None, fs: float, half: int
                 ) -> list[tuple[NDArray[np.float64], NDArray[np.float64]]] | None:
    """:func:`session_stats`'s output as :func:`_fir_stats` pairs if formed at rate ``fs`` with
    ``half``, else None."""
    if not given or "rate_hz" not in given or float(given["rate_hz"]) != fs:
        return None
    gram, rhs = np.asarray(given["gram"], np.float64), np.asarray(given["rhs"], np.float64)
    k = 2 * half + 1
    if gram.shape != (2, k, k) or rhs.shape != (2, k):
        return None
    return [(gram[a], rhs[a]) for a in range(2)]


def _row(base_row: Mapping[str, Any], variant: str, status: str, **values: Any) -> dict[str, Any]:
    row = {c: np.nan for c in (*COLUMNS, *base_row)}
    row.update({c: base_row[c] for c in ("subject", "trial", "lag_s", "r_align", "factor", "frames",
                                         "frames_missing", "frames_unconverged", "duration_s", "rate_hz", "ispgr")
                if c in base_row})
    row.update(variant=variant, condition="", status=status, **values)
    return row


def _fold_of(subjects: Sequence[str], folds: int | None) -> dict[str, int]:
    """Volunteers (sorted) dealt round-robin into ``folds`` folds; None: one fold each."""
    order = sorted(subjects)
    k = len(order) if folds is None else int(folds)
    return {s: i % k for i, s in enumerate(order)}


def dynamic_rows(rows: Sequence[Mapping[str, Any]], traces: Mapping[Key, Mapping[str, Any]], *, base: str = "SCHC",
                 folds: int | None = None, model: str = "fir", by_trial: bool = True, rate_hz: float | None = None,
                 fir_half_s: float = 0.1, ridge: float = 1e-3, preprocess: str | None = None,
                 descriptors: str | None = None, stats: Mapping[Key, Mapping[str, Any]] | None = None
                 ) -> tuple[list[dict[str, Any]], dict[Key, dict[str, NDArray[np.float64]]]]:
    """Rows and traces of the variant ``<base>-DYN``: each session's base trace corrected by a
    model fitted on the other folds' volunteers.

    Parameters
    ----------
    rows : sequence of dict
        A study's metrics rows (:data:`psmat.study.COLUMNS`); a session is used when its
        ``FP`` and ``base`` rows have status ``"ok"`` and ``traces`` holds it.
    traces : mapping
        ``{(subject, trial): {"t_s": (N,) s, "FP": (N, 2) cm, base: (N, 2) cm, ...}}``, the
        aligned window on a common time base, absolute (the study contract).
    base : str
        The variant corrected.
    folds : int or None
        Number of folds of volunteers (>= 2; the ids sorted and dealt in turn); None: leave one
        volunteer out.
    model : {"gain", "fir", "tf"}
        See the module docstring; ``fir_half_s`` (s) and ``ridge`` size and regularise it.
    by_trial : bool
        One model per trial type (default), or one pooled over the trial types.
    rate_hz : float, optional
        Fitting rate (Hz); default the median of the sessions' rates.
    preprocess, descriptors : str or None
        As the study's parameters of these names (:data:`psmat.study.DEFAULT_PARAMS`): the sway
        metrics after that preprocessing, the descriptors of that preset as extra values.
    stats : mapping, optional
        ``{(subject, trial): session_stats(trace)}`` formed beforehand (in the session tasks);
        a session's are used where they were formed at the fitting rate with this
        ``fir_half_s`` (the same numbers), and formed here otherwise.

    Returns
    -------
    new_rows : list of dict
        One row per session that has a ``base`` row, variant ``<base>-DYN``: the sway metrics of
        the corrected trace and its Eu against FP (both mean-removed, on the trace's window);
        ``lag_s``, ``r_align``, ``factor``, ``frames``, ``frames_missing`` and
        ``frames_unconverged`` as the base's row;
        ``status`` ``"ok"`` or why the session was not corrected.
    new_traces : dict
        ``{(subject, trial): {"t_s", "FP", "<base>-DYN"}}`` for the corrected sessions; the
        corrected trace is absolute (the base trace's mean added back).
    """
    plan = plan_dynamic(rows, traces, base=base, folds=folds, model=model, by_trial=by_trial, rate_hz=rate_hz,
                        fir_half_s=fir_half_s, ridge=ridge, stats=stats)
    new_traces: dict[Key, dict[str, NDArray[np.float64]]] = {}
    for key, (r, corr) in plan.jobs.items():  # each usable session's series was read by the plan
        s = plan.series[key]
        plan.rows[key], c = correct_session(s, r, corr, plan.rate_hz, base=base, preprocess=preprocess,
                                            descriptors=descriptors)
        if c is not None:
            new_traces[key] = {"t_s": s.t, "FP": s.fp, plan.name: c}
    return [plan.rows[k] for k in plan.order if k in plan.rows], new_traces


@dataclass
class DynamicPlan:
    """What :func:`dynamic_rows` decides before any session is corrected: the fitting rate, the
    rows already final (a session not usable or without a model to fit on) and, for every other
    session, its base row and the correction fitted without its volunteer. Each of those is then
    corrected alone (:func:`correct_session`), in any process."""

    name: str  # the variant, "<base>-DYN"
    rate_hz: float  # the fitting rate, Hz
    order: list[Key]  # the sessions with a base row, in the rows' order
    rows: dict[Key, dict[str, Any]]  # final rows
    jobs: dict[Key, tuple[Mapping[str, Any], Correction]]  # base row and correction of each session to correct
    series: dict[Key, _Series]  # the series read while planning (resampled at rate_hz), reused by the corrections


def plan_dynamic(rows: Sequence[Mapping[str, Any]], traces: Mapping[Key, Mapping[str, Any]], *, base: str = "SCHC",
                 folds: int | None = None, model: str = "fir", by_trial: bool = True, rate_hz: float | None = None,
                 fir_half_s: float = 0.1, ridge: float = 1e-3, stats: Mapping[Key, Mapping[str, Any]] | None = None,
                 trust_stats: bool = False) -> DynamicPlan:
    """The fits of :func:`dynamic_rows` (same parameters) and what is left to do per session.

    With ``trust_stats`` (the FIR model only), a session whose ``stats`` hold a rate is taken as
    usable without reading its trace: the statistics were formed from that very trace by
    :func:`session_stats`, which forms none for a trace that is not usable (a study's own
    sessions, :func:`psmat.study.run_study`). Traces are then read only for the sessions without
    statistics and for those formed at another rate than the fitting rate. Otherwise every
    candidate's trace is read, as :func:`dynamic_rows` documents.
    """
    if model not in MODELS:
        raise ValueError(f"unknown model {model!r}; choose one of {MODELS}")
    if folds is not None and (isinstance(folds, bool) or not isinstance(folds, (int, np.integer)) or folds < 2):
        raise ValueError(f"folds must be an integer >= 2 or None (leave one volunteer out), got {folds!r}")
    if rate_hz is not None and not (np.isfinite(rate_hz) and rate_hz > 0):
        raise ValueError(f"rate_hz must be a positive number of Hz or None, got {rate_hz!r}")
    name = f"{base}-DYN"
    by_key: dict[Key, dict[str, Mapping[str, Any]]] = {}
    for r in rows:
        if condition_of(r):  # a condition's rows (docs/spec.md §7): the whole trial's only
            continue
        by_key.setdefault((str(r["subject"]), str(r["trial"])), {})[str(r["variant"])] = r
    out: dict[Key, dict[str, Any]] = {}
    given = stats or {}
    trusted = trust_stats and model == "fir"
    rates: dict[Key, float] = {}  # the usable sessions' own rates, Hz
    series: dict[Key, _Series] = {}
    for key, vs in by_key.items():
        if base not in vs:
            continue
        why = (f"{base}: {vs[base]['status']}" if vs[base]["status"] != "ok" else "no FP row" if "FP" not in vs
               else f"FP: {vs['FP']['status']}" if vs["FP"]["status"] != "ok" else None)
        if why is not None:
            out[key] = _row(vs[base], name, f"not corrected: {why}")
            continue
        own = given.get(key)
        if trusted and own and "rate_hz" in own:
            rates[key] = float(own["rate_hz"])
            continue
        s = _series(traces.get(key), base)
        if isinstance(s, str):
            out[key] = _row(vs[base], name, f"not corrected: {s}")
        else:
            series[key] = s
            rates[key] = float(_rate(s.t))
    fs = (float(rate_hz) if rate_hz is not None else float(np.median(list(rates.values())))) if rates else 1.0
    for s in series.values():
        s.resample(fs)
    half = _fir_half(fir_half_s, fs)
    fir: dict[Key, list[tuple[NDArray[np.float64], NDArray[np.float64]]]] = {}
    if model == "fir":  # formed once, summed by every fold
        for k in rates:
            formed = _given_stats(given.get(k), fs, half)
            if formed is None:
                if k not in series:  # statistics at another rate: the trace after all
                    s = _series(traces.get(k), base)
                    assert not isinstance(s, str)  # its statistics say it is usable
                    s.resample(fs)
                    series[k] = s
                formed = [_fir_stats(series[k].x[:, a], series[k].y[:, a], half) for a in range(2)]
            fir[k] = formed
    fold = _fold_of({k[0] for k in rates}, folds)
    fits: dict[tuple[int, str | None], Correction | None] = {}  # one fit per held-out fold (and trial type)
    jobs: dict[Key, tuple[Mapping[str, Any], Correction]] = {}
    for key in rates:
        subject, trial = key
        scope = (fold[subject], trial if by_trial else None)
        if scope not in fits:
            train = [k for k in rates if fold[k[0]] != scope[0] and scope[1] in (None, k[1])]
            if not train:
                fits[scope] = None
            elif model == "fir":
                fits[scope] = Correction("fir", tuple(_fir_taps(sum(fir[k][a][0] for k in train),
                                                                sum(fir[k][a][1] for k in train), ridge)
                                                      for a in range(2)), fs)
            else:
                fits[scope] = fit_correction([series[k].x for k in train], [series[k].y for k in train], fs,
                                             model=model, fir_half_s=fir_half_s, ridge=ridge)
        corr, r = fits[scope], by_key[key][base]
        if corr is None:
            where = f" with a {trial!r} trial" if by_trial else ""
            out[key] = _row(r, name, f"not corrected: no other volunteer{where} to fit on (fewer than 2 volunteers)")
        else:
            jobs[key] = (r, corr)
    return DynamicPlan(name, fs, list(by_key), out, jobs, series)


def correct_session(trace: Mapping[str, Any] | _Series | None, base_row: Mapping[str, Any], corr: Correction,
                    rate_hz: float, *, base: str = "SCHC", preprocess: str | None = None,
                    descriptors: str | None = None
                    ) -> tuple[dict[str, Any], NDArray[np.float64] | None]:
    """One session's ``<base>-DYN`` row and corrected trace (absolute, (N, 2) cm; None when the
    trace is not usable, the row then says why): its base trace (a :func:`dynamic_rows` trace, or
    the series the plan read) resampled at ``rate_hz`` (Hz), corrected by ``corr``, back on the trace's
    own times; its sway metrics (``preprocess``), Eu against FP and the ``descriptors`` preset's."""
    name = f"{base}-DYN"
    s = trace if isinstance(trace, _Series) else _series(trace, base)
    if isinstance(s, str):
        return _row(base_row, name, f"not corrected: {s}"), None
    if s.rate_hz != rate_hz:
        s.resample(rate_hz)
    c = _at(s.t, s.grid, corr.apply(s.x)) + s.mat.mean(axis=0)
    a, b = c - c.mean(axis=0), s.fp - s.fp.mean(axis=0)
    metrics = {**sway_metrics(s.t, c, 1.0 / float(np.median(np.diff(s.t))), preprocess), "eu_cm": eu(a, b),
               "eu_ml_cm": eu(a[:, 0], b[:, 0]), "eu_ap_cm": eu(a[:, 1], b[:, 1])}
    if descriptors is not None:
        metrics.update(descriptor_values(s.t, c, descriptors))
    return _row(base_row, name, "ok", **metrics), c

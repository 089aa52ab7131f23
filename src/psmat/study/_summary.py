"""The numbers of a balance study (thesis §3.2.1, docs/spec.md §7): per trial × variant the spread
σ_ML, σ_AP across volunteers, their Pearson r against the platform, the % of volunteers whose
mat trace spreads less than the platform's (Tables 3.5, 3.6), mean Eu (eq. 3.1-3.2),
Bland–Altman of σ against FP; and per pair of variants the % of volunteers for whom one is
closer to the platform than the other (the text around Tables 3.5, 3.6).

Only rows whose ``status`` is ``"ok"`` enter the numbers; the others are counted. Rows may
come straight from :func:`psmat.study.process_trial` or from ``metrics.csv`` read as
text. Variants and trials keep the order in which the rows name them (FP first).
"""

from __future__ import annotations

import csv
import io
import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy import stats

__all__ = ["REFERENCE", "OK", "SIGMAS", "PAIRWISE_METRICS", "SUMMARY_COLUMNS", "PAIRWISE_COLUMNS", "StudyRows",
           "index_rows", "pearson", "bland_altman", "summary_rows", "pairwise_rows", "table_text", "format_value"]

REFERENCE = "FP"
OK = "ok"
SIGMAS = ("sd_ml_cm", "sd_ap_cm")
PAIRWISE_METRICS = SIGMAS + ("eu_cm", "eu_ml_cm", "eu_ap_cm")
LOA_Z = 1.96  # Bland–Altman 95 % limits of agreement: bias ± 1.96 SD of the differences

SUMMARY_COLUMNS = (
    "trial", "variant", "n", "n_ok", "n_failed",
    "sd_ml_mean_cm", "sd_ml_sd_cm", "sd_ap_mean_cm", "sd_ap_sd_cm",
    "r_sd_ml", "r_sd_ap", "pct_smaller_sd_ml", "pct_smaller_sd_ap",
    "eu_mean_cm", "eu_sd_cm", "eu_ml_mean_cm", "eu_ap_mean_cm",
    "ba_sd_ml_bias_cm", "ba_sd_ml_loa_low_cm", "ba_sd_ml_loa_high_cm",
    "ba_sd_ap_bias_cm", "ba_sd_ap_loa_low_cm", "ba_sd_ap_loa_high_cm",
)
PAIRWISE_COLUMNS = ("trial", "variant", "other", "metric", "n", "pct_closer")


def _number(value: Any) -> float:
    """A metric as float: NaN for None or an empty CSV field."""
    if value is None or (isinstance(value, str) and not value.strip()):
        return math.nan
    return float(value)


@dataclass
class StudyRows:
    """The rows of ``metrics.csv`` indexed by trial, variant and subject.

    Attributes
    ----------
    trials, variants, subjects : tuple of str
        In order of appearance (the reference ``FP`` first among the variants).
    present : set of (trial, variant)
        The pairs that have rows, ok or not.
    ok : dict
        ``(trial, variant) -> {subject: row}`` for the rows whose status is ``"ok"``.
    failed : list of dict
        The other rows, unchanged.
    """

    trials: tuple[str, ...]
    variants: tuple[str, ...]
    subjects: tuple[str, ...]
    present: set[tuple[str, str]] = field(default_factory=set)
    ok: dict[tuple[str, str], dict[str, dict[str, Any]]] = field(default_factory=dict)
    failed: list[dict[str, Any]] = field(default_factory=list)

    @property
    def compared(self) -> tuple[str, ...]:
        """The variants other than the reference."""
        return tuple(v for v in self.variants if v != REFERENCE)

    def ok_subjects(self, trial: str, *variants: str) -> list[str]:
        """Subjects, in order, whose rows are ok for every one of ``variants`` in ``trial``."""
        sets = [self.ok.get((trial, v), {}) for v in variants]
        return [s for s in self.subjects if all(s in d for d in sets)]

    def values(self, trial: str, variant: str, metric: str, subjects: Sequence[str]) -> NDArray[np.float64]:
        """``metric`` of ``variant`` for each of ``subjects`` (which must be ok)."""
        rows = self.ok.get((trial, variant), {})
        return np.array([_number(rows[s][metric]) for s in subjects], dtype=np.float64)

    def paired(self, trial: str, variant: str, metric: str
               ) -> tuple[list[str], NDArray[np.float64], NDArray[np.float64]]:
        """Subjects ok for ``variant`` and FP with both values finite; the variant's and FP's values."""
        subjects = self.ok_subjects(trial, variant, REFERENCE)
        v = self.values(trial, variant, metric, subjects)
        fp = self.values(trial, REFERENCE, metric, subjects)
        keep = np.isfinite(v) & np.isfinite(fp)
        return [s for s, k in zip(subjects, keep) if k], v[keep], fp[keep]

    def n_failed(self, trial: str, variant: str) -> int:
        """Rows of ``trial`` × ``variant`` whose status is not ok."""
        return sum(1 for r in self.failed if r["trial"] == trial and r["variant"] == variant)


def index_rows(rows: Iterable[Mapping[str, Any]]) -> StudyRows:
    """Index ``metrics.csv`` rows (see :class:`StudyRows`).

    Raises
    ------
    ValueError
        A row without subject, trial, variant or status, or two rows for one subject × trial × variant.
    """
    trials: dict[str, None] = {}
    variants: dict[str, None] = {}
    subjects: dict[str, None] = {}
    out = StudyRows((), (), ())
    seen: set[tuple[str, str, str]] = set()
    for row in rows:
        missing = [c for c in ("subject", "trial", "variant", "status") if c not in row]
        if missing:
            raise ValueError(f"a metrics row lacks column(s) {', '.join(missing)}: {dict(row)!r}")
        key = (str(row["subject"]), str(row["trial"]), str(row["variant"]))
        if key in seen:
            raise ValueError(f"two metrics rows for subject {key[0]}, trial {key[1]}, variant {key[2]}")
        seen.add(key)
        subject, trial, variant = key
        trials.setdefault(trial)
        variants.setdefault(variant)
        subjects.setdefault(subject)
        out.present.add((trial, variant))
        if row["status"] == OK:
            out.ok.setdefault((trial, variant), {})[subject] = dict(row)
        else:
            out.failed.append(dict(row))
    order = ([REFERENCE] if REFERENCE in variants else []) + [v for v in variants if v != REFERENCE]
    out.trials, out.variants, out.subjects = tuple(trials), tuple(order), tuple(subjects)
    return out


def pearson(x: NDArray[np.float64], y: NDArray[np.float64]) -> float:
    """Pearson r (:func:`scipy.stats.pearsonr`); NaN with fewer than 3 pairs or a constant side."""
    if len(x) < 3 or np.ptp(x) == 0 or np.ptp(y) == 0:
        return math.nan
    return float(stats.pearsonr(x, y).statistic)


def bland_altman(a: NDArray[np.float64], b: NDArray[np.float64]) -> tuple[float, float, float]:
    """Bias and 95 % limits of agreement of ``a − b``: mean ± 1.96 SD (ddof 1) of the differences.

    Returns NaN for the bias without pairs, and for the limits with fewer than 2.
    """
    d = np.asarray(a, np.float64) - np.asarray(b, np.float64)
    if d.size == 0:
        return math.nan, math.nan, math.nan
    bias = float(np.mean(d))
    if d.size < 2:
        return bias, math.nan, math.nan
    sd = float(np.std(d, ddof=1))
    return bias, bias - LOA_Z * sd, bias + LOA_Z * sd


def _mean_sd(x: NDArray[np.float64]) -> tuple[float, float]:
    """Mean and SD (ddof 1) across volunteers of the finite values; NaN where undefined."""
    x = x[np.isfinite(x)]
    mean = float(np.mean(x)) if x.size else math.nan
    sd = float(np.std(x, ddof=1)) if x.size >= 2 else math.nan
    return mean, sd


def _pct(hits: NDArray[np.bool_]) -> float:
    return 100.0 * float(np.count_nonzero(hits)) / hits.size if hits.size else math.nan


def summary_rows(study: StudyRows) -> list[dict[str, Any]]:
    """One row per trial × variant that has rows, with :data:`SUMMARY_COLUMNS`.

    ``n``: volunteers ok for both the variant and FP (the comparisons use them); ``n_ok``:
    volunteers ok for the variant (the means and SDs use them); ``n_failed``: rows of the
    trial × variant whose status is not ok. For FP itself the comparisons are NaN.
    """
    out = []
    for trial in study.trials:
        for variant in study.variants:
            if (trial, variant) not in study.present:
                continue
            own = study.ok_subjects(trial, variant)
            row: dict[str, Any] = {"trial": trial, "variant": variant,
                                   "n": len(study.ok_subjects(trial, variant, REFERENCE)),
                                   "n_ok": len(own), "n_failed": study.n_failed(trial, variant)}
            for metric, key in (("sd_ml_cm", "sd_ml"), ("sd_ap_cm", "sd_ap")):
                row[f"{key}_mean_cm"], row[f"{key}_sd_cm"] = _mean_sd(study.values(trial, variant, metric, own))
            row["eu_mean_cm"], row["eu_sd_cm"] = _mean_sd(study.values(trial, variant, "eu_cm", own))
            row["eu_ml_mean_cm"] = _mean_sd(study.values(trial, variant, "eu_ml_cm", own))[0]
            row["eu_ap_mean_cm"] = _mean_sd(study.values(trial, variant, "eu_ap_cm", own))[0]
            for metric, key in (("sd_ml_cm", "sd_ml"), ("sd_ap_cm", "sd_ap")):
                if variant == REFERENCE:
                    v = fp = np.empty(0)
                else:
                    _, v, fp = study.paired(trial, variant, metric)
                row[f"r_{key}"] = pearson(v, fp)
                row[f"pct_smaller_{key}"] = _pct(v < fp)  # Tables 3.5, 3.6
                (row[f"ba_{key}_bias_cm"], row[f"ba_{key}_loa_low_cm"],
                 row[f"ba_{key}_loa_high_cm"]) = bland_altman(v, fp)
            out.append({c: row[c] for c in SUMMARY_COLUMNS})
    return out


def pairwise_rows(study: StudyRows) -> list[dict[str, Any]]:
    """% of volunteers for whom ``variant`` is closer to FP than ``other``, per trial and metric.

    For σ (``sd_ml_cm``, ``sd_ap_cm``): ``|σ_variant − σ_FP| < |σ_other − σ_FP|`` over the
    volunteers ok for the variant, the other and FP; for Eu (``eu_cm``, ``eu_ml_cm``,
    ``eu_ap_cm``, already against FP): ``Eu_variant < Eu_other`` over those ok for both. Ties
    count as not closer. Columns :data:`PAIRWISE_COLUMNS`; NaN % without volunteers.
    """
    out = []
    for trial in study.trials:
        for variant in study.compared:
            for other in study.compared:
                if other == variant or not {(trial, variant), (trial, other)} <= study.present:
                    continue
                for metric in PAIRWISE_METRICS:
                    sigma = metric in SIGMAS
                    needed = (variant, other, REFERENCE) if sigma else (variant, other)
                    subjects = study.ok_subjects(trial, *needed)
                    v = study.values(trial, variant, metric, subjects)
                    w = study.values(trial, other, metric, subjects)
                    if sigma:
                        fp = study.values(trial, REFERENCE, metric, subjects)
                        keep = np.isfinite(v) & np.isfinite(w) & np.isfinite(fp)
                        closer = np.abs(v - fp)[keep] < np.abs(w - fp)[keep]
                    else:
                        keep = np.isfinite(v) & np.isfinite(w)
                        closer = v[keep] < w[keep]
                    out.append({"trial": trial, "variant": variant, "other": other, "metric": metric,
                                "n": int(closer.size), "pct_closer": _pct(closer)})
    return out


def format_value(value: Any) -> str:
    """A CSV field: ints as written, floats by ``repr`` (exact round trip, ``nan`` for NaN)."""
    if isinstance(value, (bool, np.bool_)):
        return str(bool(value))
    if isinstance(value, (int, np.integer)):
        return str(int(value))
    if isinstance(value, (float, np.floating)):
        return repr(float(value))
    return str(value)


def table_text(rows: Sequence[Mapping[str, Any]], columns: Sequence[str]) -> str:
    """``rows`` as CSV text with a header of ``columns`` (identical text for identical rows)."""
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(columns)
    for row in rows:
        w.writerow([format_value(row[c]) for c in columns])
    return buf.getvalue()

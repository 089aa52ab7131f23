"""``report.md`` of a balance study: its size, the failed sessions, the summary table, and the
thesis' Tables 3.5-3.8, percentages and correlations (:mod:`.thesis_tables`) beside ours.

Plain text from the rows with fixed number formats: the same rows give the same bytes.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from ..balance import describe
from ..process import IECM_RTOL
from . import thesis_tables as thesis
from ._romberg import romberg_section
from ._summary import StudyRows

__all__ = ["render_report"]

_AXIS = {"sd_ml_cm": "σ_ML", "sd_ap_cm": "σ_AP", "eu_cm": "Eu", "eu_ml_cm": "Eu_ML", "eu_ap_cm": "Eu_AP"}

#: The report's other abbreviations and what each stands for (thesis §3.2), in the order they are
#: listed; a meaning uses only the terms before it.
TERMS = (
    ("CoP", "centre of pressure"),
    ("M-L", "medial-lateral direction"),
    ("A-P", "anterior-posterior direction"),
    ("SD", "standard deviation"),
    ("σ_ML", "standard deviation of the CoP along M-L over a trial (cm)"),
    ("σ_AP", "standard deviation of the CoP along A-P over a trial (cm)"),
    ("Eu", "Euclidean trajectory distance to the force platform, √(Σd²)/N over the N samples of a trial, "
           "d the distance between the two CoPs at a sample (eq. 3.1; cm)"),
    ("Eu_ML", "Eu along M-L alone (eq. 3.2; cm)"),
    ("Eu_AP", "Eu along A-P alone (eq. 3.2; cm)"),
    ("r", "Pearson correlation coefficient"),
    ("BA", "Bland–Altman analysis: the bias and 95 % limits of agreement of the differences"),
)
_RTOL = f"{IECM_RTOL:g}".replace("e-0", "e-")  # 1e-6 rather than 1e-06
IECM = ("IECM, the Inverse of Equivalent Conductance Method (thesis §2.1.4), removes the crosstalk between the "
        f"mat's cells, each frame solved to a relative residual of {_RTOL}.")


def _f(x: Any, fmt: str = ".3g") -> str:
    """A number for a table; an em dash for NaN or a missing value."""
    if x is None:
        return "—"
    x = float(x)
    return "—" if not math.isfinite(x) else format(x, fmt)


def _pct(x: Any) -> str:
    return _f(x, ".1f")


def _cell(text: str) -> str:
    return str(text).replace("|", "\\|").replace("\n", " ")


def _table(header: Sequence[str], rows: Sequence[Sequence[str]]) -> list[str]:
    out = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    out += ["| " + " | ".join(_cell(c) for c in row) + " |" for row in rows]
    return out + [""]


def _lookup(rows: Sequence[Mapping[str, Any]], **key: str) -> Mapping[str, Any] | None:
    return next((r for r in rows if all(r[k] == v for k, v in key.items())), None)


def _used(term: str, text: str) -> bool:
    """Whether ``term`` appears in ``text`` as a name of its own (not inside SCHC-8x8 for SCHC)."""
    return re.search(rf"(?<![\w-]){re.escape(term)}(?![\w-])", text) is not None


def _key(study: StudyRows, body: str) -> list[str]:
    """Every abbreviation of the report spelled out before its first use: IECM, the study's
    variants, the other variants the thesis' tables name, then the :data:`TERMS` that ``body``
    (or a meaning listed) uses."""
    own = [d for d in map(describe, study.variants) if d]
    others = [d for d in map(describe, dict.fromkeys(re.findall(r"[A-Z][\w-]*", body)))
              if d and d.name not in study.variants]
    variants = own + others
    text = body + "".join(d.recipe for d in variants)
    used: set[str] = set()
    for term, meaning in reversed(TERMS):  # a meaning names only earlier terms
        if _used(term, text):
            used.add(term)
            text += meaning
    out = ["### Abbreviations", ""]
    if any(_used("IECM", d.recipe) for d in variants):
        out += [IECM, ""]
    if own:
        out += ["Variants of this study (thesis Tables 3.2, 3.4):", ""]
        out += [f"- **{d.name}** ({d.expansion}): {d.recipe}." for d in own] + [""]
    if others:
        out += ["Other variants in the thesis' tables below:", ""]
        out += [f"- **{d.name}** ({d.expansion}): {d.recipe}." for d in others] + [""]
    if used:
        out += ["Other terms:", ""] + [f"- **{t}**: {meaning}" for t, meaning in TERMS if t in used] + [""]
    return out if len(out) > 2 else []


def _size(study: StudyRows, problems: Sequence[str], body: str = "") -> list[str]:
    sessions = {(r["subject"], r["trial"]) for r in study.failed}
    for (trial, _), rows in study.ok.items():
        sessions |= {(s, trial) for s in rows}
    failed: dict[tuple[str, str, str], list[str]] = {}
    for r in study.failed:
        failed.setdefault((str(r["subject"]), str(r["trial"]), str(r["status"])), []).append(str(r["variant"]))
    out = ["## Study", "",
           f"{len(study.subjects)} volunteers, {len(study.trials)} trials ({', '.join(study.trials)}), "
           f"{len(sessions)} sessions; the variants are listed below. {len(study.failed)} rows (subject × trial × "
           "variant) are not ok and are left out of every number below.", ""]
    out += _key(study, body)
    if failed:
        out += ["### Failed rows", ""]
        out += _table(("subject", "trial", "variants", "status"),
                      [(s, t, ", ".join(v), status) for (s, t, status), v in failed.items()])
    if problems:
        out += ["### Problems found in the study folder", ""] + [f"- {_cell(p)}" for p in problems] + [""]
    return out


def _summary(summary: Sequence[Mapping[str, Any]]) -> list[str]:
    def ms(r: Mapping[str, Any], key: str) -> str:
        return f"{_f(r[f'{key}_mean_cm'])} ± {_f(r[f'{key}_sd_cm'])}"

    def ba(r: Mapping[str, Any], key: str) -> str:
        return f"{_f(r[f'ba_{key}_bias_cm'])} [{_f(r[f'ba_{key}_loa_low_cm'])}, {_f(r[f'ba_{key}_loa_high_cm'])}]"

    header = ("trial", "variant", "n", "failed", "σ_ML (cm)", "σ_AP (cm)", "r σ_ML", "r σ_AP", "% σ_ML < FP",
              "% σ_AP < FP", "Eu (cm)", "Eu_ML (cm)", "Eu_AP (cm)", "BA σ_ML (cm)", "BA σ_AP (cm)")
    rows = [(r["trial"], r["variant"], str(r["n"]), str(r["n_failed"]), ms(r, "sd_ml"), ms(r, "sd_ap"),
             _f(r["r_sd_ml"], ".2f"), _f(r["r_sd_ap"], ".2f"), _pct(r["pct_smaller_sd_ml"]),
             _pct(r["pct_smaller_sd_ap"]), _f(r["eu_mean_cm"]), _f(r["eu_ml_mean_cm"]), _f(r["eu_ap_mean_cm"]),
             ba(r, "sd_ml"), ba(r, "sd_ap")) for r in summary]
    return (["## Summary", "",
             "Mean ± SD across volunteers; n: volunteers ok for the variant and FP; r: Pearson r of σ across "
             "volunteers against FP; % σ < FP: volunteers whose mat trace spreads less than the platform's; "
             "Eu: mean trajectory distance to FP (eq. 3.1-3.2); BA: Bland–Altman of σ against FP, bias "
             "[95 % limits of agreement]. All numbers in `summary.csv` and `pairwise.csv`.", ""]
            + _table(header, rows))


def _percent_table(table: thesis.PercentTable, summary: Sequence[Mapping[str, Any]]) -> list[str]:
    header = [""] + [f"{v} {who}" for v in table.variants for who in ("thesis", "ours")]
    rows = []
    for (metric, trial), values in table.rows.items():
        cells = [f"{_AXIS[metric]} ({trial})"]
        for variant, value in zip(table.variants, values):
            ours = _lookup(summary, trial=trial, variant=variant)
            cells += [_pct(value), _pct(ours[f"pct_smaller_{metric[:-3]}"]) if ours else "—"]
        rows.append(cells)
    return ([f"### Thesis {table.name} ({table.section}): {table.experiment}", "",
             "% of volunteers whose mat trace spreads less than the platform's (σ_variant < σ_FP).", ""]
            + _table(header, rows))


def _eu_table(table: thesis.EuTable, study: StudyRows) -> list[str]:
    trials = list(table.by_volunteer)
    header = ["ID"] + [f"{t} {v}" for t in trials for v in table.variants]
    n = len(next(iter(table.by_volunteer.values())))
    rows = [[str(i + 1)] + [_f(table.by_volunteer[t][i][k], ".4g") for t in trials
                            for k in range(len(table.variants))] for i in range(n)]
    rows.append(["mean (thesis)"] + [_f(table.mean(t, v), ".4g") for t in trials for v in table.variants])
    ours, counts = ["mean (ours)"], ["n (ours)"]
    for t in trials:
        for v in table.variants:
            values = study.values(t, v, table.metric, study.ok_subjects(t, v))
            ours.append(_f(float(np.mean(values)), ".4g") if len(values) else "—")
            counts.append(str(len(values)))
    rows += [ours, counts]
    return ([f"### Thesis {table.name} ({table.section}): {thesis.SECOND}", "",
             f"{_AXIS[table.metric]} (cm) by volunteer, SCHC against SCHC-8x8; the thesis' means beside ours.", ""]
            + _table(header, rows))


def _headlines(pairwise: Sequence[Mapping[str, Any]]) -> list[str]:
    rows = []
    for h in thesis.HEADLINES:
        for trial, value in h.values.items():
            ours = _lookup(pairwise, trial=trial, variant=h.variant, other=h.other, metric=h.metric)
            rows.append((f"{h.variant} vs {h.other}", _AXIS[h.metric], trial, _pct(value),
                         f"{_pct(ours['pct_closer'])} (n={ours['n']})" if ours else "—", h.section))
    return (["### Percentages in the thesis' text", "",
             "% of volunteers for whom the first variant is closer to FP than the second: for σ, "
             "|σ_v − σ_FP| < |σ_w − σ_FP|; for Eu, Eu_v < Eu_w. Thesis §3.3.1: first prototype; §3.3.2: "
             "second. Every pair of our variants is in `pairwise.csv`.", ""]
            + _table(("comparison", "metric", "trial", "thesis %", "ours %", "thesis §"), rows))


def _correlations(summary: Sequence[Mapping[str, Any]]) -> list[str]:
    rows = []
    for c in thesis.CORRELATIONS:
        ours = []
        for trial in c.trials:
            r = _lookup(summary, trial=trial, variant=c.variant)
            ours.append(f"{trial} {_f(r[f'r_{c.metric[:-3]}'], '.2f')}" if r else f"{trial} —")
        rows.append((c.variant, _AXIS[c.metric], ", ".join(c.trials), f"{'> ' if c.bound else ''}{c.value:.2f}",
                     "; ".join(ours), c.section))
    return (["### Correlations in the thesis' text", "",
             "Pearson r of σ across volunteers against FP.", ""]
            + _table(("variant", "metric", "trials", "thesis r", "ours r", "thesis §"), rows))


def _eu_gain(summary: Sequence[Mapping[str, Any]], trials: Sequence[str]) -> list[str]:
    lo, hi = thesis.EU_GAIN_SCHC_VS_PROP
    ours = []
    for trial in trials:
        schc, prop = _lookup(summary, trial=trial, variant="SCHC"), _lookup(summary, trial=trial, variant="PROP")
        gain = 100.0 * (1.0 - float(schc["eu_mean_cm"]) / float(prop["eu_mean_cm"])) if schc and prop else math.nan
        ours.append(f"{trial} {_pct(gain)} %")
    return [f"Mean Eu of SCHC below PROP's (relative): thesis {lo:.0f} % to {hi:.0f} % depending on the trial "
            f"(thesis {thesis.EU_GAIN_SECTION}); ours: {', '.join(ours) or '—'}.", ""]


def _subject_reports(reports: Mapping[str, str]) -> list[str]:
    """The section linking each subject's HTML page (none without pages)."""
    if not reports:
        return []
    return (["## Per-subject reports", "",
             "One self-contained HTML page per subject (`psmat study run --reports`): its sessions' pressure "
             "images, CoP, sway metrics and descriptors, regions, conditions and the platform comparison.", ""]
            + [f"- [{_cell(s).replace('[', chr(92) + '[').replace(']', chr(92) + ']')}]({_link(path)})"
               for s, path in sorted(reports.items())] + [""])


def _link(path: str) -> str:
    """A relative path as a Markdown link target (spaces and parentheses escaped)."""
    from urllib.parse import quote

    return quote(path, safe="/-_.~")


def render_report(study: StudyRows, summary: Sequence[Mapping[str, Any]], pairwise: Sequence[Mapping[str, Any]],
                  figures: Mapping[str, str], problems: Sequence[str] = (), label: str | None = None,
                  preprocessing: str | None = None, romberg: Sequence[Mapping[str, Any]] = (),
                  reports: Mapping[str, str] | None = None) -> str:
    """The Markdown report.

    Parameters
    ----------
    study : StudyRows
        The indexed rows of ``metrics.csv``.
    summary, pairwise : rows of :func:`.summary_rows` and :func:`.pairwise_rows`
    figures : mapping
        Figure name -> its path relative to the report (embedded in this order).
    problems : sequence of str
        What the study folder lacked (one line each).
    label : str, optional
        What the numbers are (e.g. ``"simulation"``), in the title.
    preprocessing : str, optional
        One sentence: the preprocessing the sway metrics were computed after (with its parameters).
    romberg : rows of :func:`psmat.study._romberg.romberg_rows`
        The Romberg quotients; a short section after the summary when there are any.
    reports : mapping, optional
        Subject -> the path of its HTML page relative to the report (``psmat study run --reports``):
        a section "Per-subject reports" linking each, after the summary; none: no section.
    """
    title = "Balance study results" + (f" ({label})" if label else "")
    out = _summary(summary) + romberg_section(romberg, label) + _subject_reports(reports or {})
    out += ["## Beside the thesis", "",
            "The thesis' numbers come from two experiments with real volunteers: "
            f"{thesis.FIRST}; {thesis.SECOND}. The Seating Mat is a commercial mat that is not reproduced here. "
            f"Ours: {label or 'this study'}. Eu = √(Σd²)/N (eq. 3.1) falls as 1/√N at a fixed RMS distance, so "
            "its size depends on the trial's length and rate (the thesis' second experiment: N = 3000); "
            "the comparisons between variants do not.", ""]
    out += _percent_table(thesis.TABLE_3_5, summary)
    out += _percent_table(thesis.TABLE_3_6, summary)
    out += _eu_table(thesis.TABLE_3_7, study)
    out += _eu_table(thesis.TABLE_3_8, study)
    out += _headlines(pairwise)
    out += _correlations(summary)
    out += _eu_gain(summary, study.trials)
    if figures:
        out += ["## Figures", ""]
        out += [f"![{name}]({path})\n" for name, path in figures.items()]
    out = [f"# {title}", "", *_size(study, problems, "\n".join(out)),
           *([f"Preprocessing: {preprocessing}", ""] if preprocessing else []), *out]
    return "\n".join(out).rstrip("\n") + "\n"

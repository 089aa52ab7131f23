"""Romberg quotients of a study (docs/spec.md §7 "Events, conditions, Romberg"; docs/spec.md §9):
``results/romberg.csv`` and the report's short Romberg section, from the condition rows of
``metrics.csv``.

A subject × trial × variant has a quotient when its conditions include exactly one eyes-open and
one eyes-closed condition (:func:`psmat.balance.romberg_role`); the quotient of each sway metric
is eyes closed / eyes open (:func:`psmat.balance.romberg`), NaN where either row is not ok.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from typing import Any

import numpy as np

from ..balance import romberg, romberg_role
from ._conditions import condition_of

__all__ = ["ROMBERG_METRICS", "ROMBERG_COLUMNS", "romberg_rows", "romberg_section"]

#: the sway metrics whose quotient romberg.csv holds
ROMBERG_METRICS = ("path_cm", "velocity_cm_s", "area95_cm2", "sd_ml_cm", "sd_ap_cm", "range_ml_cm", "range_ap_cm")
ROMBERG_COLUMNS = ("subject", "trial", "variant", "eyes_open", "eyes_closed") + tuple(
    f"romberg_{m}" for m in ROMBERG_METRICS)
_REPORTED = (("velocity_cm_s", "velocity"), ("area95_cm2", "area 95 %"))


def _number(value: Any) -> float:
    if value is None or (isinstance(value, str) and not value.strip()):
        return math.nan
    return float(value)


def romberg_rows(rows: Iterable[Mapping[str, Any]]) -> list[dict[str, Any]]:
    """One row (:data:`ROMBERG_COLUMNS`) per subject × trial × variant with one eyes-open and one
    eyes-closed condition, in the order of ``rows``; quotients dimensionless, NaN where a row of
    the two is not ok or its eyes-open value is 0."""
    found: dict[tuple[str, str, str], dict[str, list[Mapping[str, Any]]]] = {}
    for r in rows:
        label = condition_of(r)
        role = romberg_role(label) if label else None
        if role is not None:
            key = (str(r["subject"]), str(r["trial"]), str(r["variant"]))
            found.setdefault(key, {"EO": [], "EC": []})[role].append(r)
    out = []
    for (subject, trial, variant), roles in found.items():
        if len(roles["EO"]) != 1 or len(roles["EC"]) != 1:
            continue
        eo, ec = roles["EO"][0], roles["EC"][0]

        def values(r: Mapping[str, Any]) -> dict[str, float]:
            return {m: _number(r[m]) if r["status"] == "ok" else math.nan for m in ROMBERG_METRICS}

        out.append({"subject": subject, "trial": trial, "variant": variant, "eyes_open": str(eo["condition"]),
                    "eyes_closed": str(ec["condition"]), **romberg(values(eo), values(ec))})
    return out


def _f(x: float, fmt: str = ".3f") -> str:
    return format(x, fmt) if math.isfinite(x) else "—"


def romberg_section(quotients: Sequence[Mapping[str, Any]], label: str | None = None) -> list[str]:
    """The report's Romberg section (Markdown lines; none without quotients): per trial and variant
    the mean quotient of velocity and of the 95 % ellipse area across subjects, beside the
    platform's (FP) and the mean difference to it (over the subjects that have both)."""
    if not quotients:
        return []
    by: dict[tuple[str, str], dict[str, Mapping[str, Any]]] = {}
    for q in quotients:
        by.setdefault((str(q["trial"]), str(q["variant"])), {})[str(q["subject"])] = q
    header = ["trial", "variant", "n"]
    for _, name in _REPORTED:
        header += [f"{name}: quotient", f"{name}: FP", f"{name}: − FP"]
    table = []
    for (trial, variant), subjects in by.items():
        fp = by.get((trial, "FP"), {})
        cells = [trial, variant]
        n = 0
        for metric, _ in _REPORTED:
            col = f"romberg_{metric}"
            pairs = np.array([(_number(q[col]), _number(fp[s][col])) for s, q in subjects.items() if s in fp])
            pairs = pairs[np.all(np.isfinite(pairs), axis=1)] if pairs.size else np.empty((0, 2))
            n = max(n, len(pairs))
            mean = np.mean(pairs, axis=0) if len(pairs) else np.array([math.nan, math.nan])
            cells += [_f(mean[0]), _f(mean[1]), _f(mean[0] - mean[1], "+.3f") if len(pairs) else "—"]
        table.append([*cells[:2], str(n), *cells[2:]])
    what = f"Ours: {label}." if label else ""
    out = ["## Romberg", "",
           "Romberg quotient = eyes closed / eyes open of a trial whose markers (or its events file) name one "
           "eyes-open and one eyes-closed condition; mean across subjects, beside the platform's (FP), and the "
           f"mean difference variant − FP over the same subjects. All quotients in `romberg.csv`. {what}".rstrip(),
           "", "| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    out += ["| " + " | ".join(c.replace("|", "\\|") for c in row) + " |" for row in table]
    return out + [""]

"""``DIR/results/`` of a balance study (docs/spec.md §6, §12): ``summary.csv``, ``pairwise.csv``,
``figures/*.png`` and ``report.md`` from the rows of ``metrics.csv`` and the sessions' traces.
``metrics.csv`` itself is the runner's (:mod:`psmat.study.run`).
"""

from __future__ import annotations

import os
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

from . import figures as fig
from .report import render_report
from .summary import PAIRWISE_COLUMNS, SUMMARY_COLUMNS, index_rows, pairwise_rows, summary_rows, table_text

__all__ = ["write_results"]


def _write_text(path: Path, text: str) -> Path:
    """Write ``text`` whole or not at all (a temporary file renamed over ``path``)."""
    tmp = path.with_name(f".{path.name}.tmp")
    tmp.write_text(text, encoding="utf-8", newline="\n")
    os.replace(tmp, path)
    return path


def _slug(name: str) -> str:
    """A file-name-safe form of a trial name."""
    return "".join(c if c.isalnum() or c in "-_" else "_" for c in name)


def write_results(results_dir: str | os.PathLike[str], rows: Iterable[Mapping[str, Any]],
                  traces: Mapping[tuple[str, str], Mapping[str, Any]] | None = None, problems: Sequence[str] = (),
                  label: str | None = None) -> dict[str, Path]:
    """Write the summary, the pairwise comparisons, the figures and the report of a study.

    Parameters
    ----------
    results_dir : path-like
        ``DIR/results`` (created if needed).
    rows : iterable of mapping
        The rows of ``metrics.csv`` (:data:`psmat.study.trial.COLUMNS`; values as numbers or as
        CSV text). Rows whose ``status`` is not ``"ok"`` are counted, not used.
    traces : mapping, optional
        ``(subject, trial) -> {"t_s": (N,) s, "FP": (N, 2) cm, "<variant>": (N, 2) cm}`` (M-L,
        A-P) for the CoP figures; a trial without traces gets no trace figure.
    problems : sequence of str
        What the study folder lacked (listed in the report).
    label : str, optional
        What the numbers are (e.g. ``"simulation"``), shown in the titles and the report.

    Returns
    -------
    dict
        ``{"summary": path, "pairwise": path, "report": path, "<figure name>": path, ...}``;
        figure names ``sigma_bars``, ``eu_bars``, ``bland_altman_ml``, ``bland_altman_ap`` and
        ``cop_traces_<trial>``.

    Raises
    ------
    ValueError
        A row without subject, trial, variant or status, or two rows for one subject × trial × variant.
    """
    out_dir = Path(results_dir)
    figures_dir = out_dir / "figures"
    figures_dir.mkdir(parents=True, exist_ok=True)
    study = index_rows(rows)
    summary, pairwise = summary_rows(study), pairwise_rows(study)
    written: dict[str, Path] = {
        "summary": _write_text(out_dir / "summary.csv", table_text(summary, SUMMARY_COLUMNS)),
        "pairwise": _write_text(out_dir / "pairwise.csv", table_text(pairwise, PAIRWISE_COLUMNS)),
    }
    figures: dict[str, Path] = {}
    if study.trials:
        figures["sigma_bars"] = fig.sigma_bars(summary, figures_dir / "sigma_bars.png", label)
        figures["eu_bars"] = fig.eu_bars(summary, figures_dir / "eu_bars.png", label)
        for trial in study.trials:
            name = f"cop_traces_{_slug(trial)}"
            path = fig.cop_traces(study, traces or {}, trial, figures_dir / f"{name}.png", label)
            if path is not None:
                figures[name] = path
        for metric, name in (("sd_ml_cm", "bland_altman_ml"), ("sd_ap_cm", "bland_altman_ap")):
            figures[name] = fig.bland_altman_plot(study, summary, metric, figures_dir / f"{name}.png", label)
    relative = {name: path.relative_to(out_dir).as_posix() for name, path in figures.items()}
    report = render_report(study, summary, pairwise, relative, problems, label)
    written["report"] = _write_text(out_dir / "report.md", report)
    return {**written, **figures}

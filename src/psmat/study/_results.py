"""``DIR/results/`` of a balance study (docs/spec.md §6, §12): ``summary.csv``, ``pairwise.csv``,
``figures/*.png`` and ``report.md`` from the rows of ``metrics.csv`` and the sessions' traces.
``metrics.csv`` itself is the runner's (:mod:`psmat.study` (``_run.py``)).

:func:`write_outputs` skips the work when ``results/.outputs.json`` says the outputs on disk
were made from the same inputs and every output it names is still inside ``results/`` with
the bytes it had when written (SHA-256 per file); otherwise it writes them again.
"""

from __future__ import annotations

import hashlib
import json
import os
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any

from .._atomic import write_text_atomic
from ._cache import file_sha256
from ._conditions import condition_of
from ._report import render_report
from ._romberg import ROMBERG_COLUMNS, romberg_rows
from ._summary import PAIRWISE_COLUMNS, SUMMARY_COLUMNS, index_rows, pairwise_rows, summary_rows, table_text
from ._figure_tasks import FigureIndex, FigureTask, draw_figure, figure_tasks, most_work_first
from ._timings import Stopwatch, TaskTime, timed

__all__ = ["write_results", "write_outputs", "DrawFigures"]

#: what runs figure tasks: the tasks in, ``(name, PNG bytes, the task's time or None)`` out, in any order
DrawFigures = Callable[[list[FigureTask]], Iterable[tuple[str, bytes, "TaskTime | None"]]]

_INDEX = "psmat-study-outputs/2"  # the format of results/.outputs.json


def _write_text(path: Path, text: str) -> Path:
    """Write ``text`` whole or not at all (:func:`psmat._atomic.write_text_atomic`)."""
    write_text_atomic(path, text)
    return path


def _draw_here(tasks: list[FigureTask]) -> Iterator[tuple[str, bytes, TaskTime | None]]:
    """Figure tasks one after the other in this process."""
    for t in tasks:
        (name, data), took = timed(draw_figure, t)
        yield name, data, took


def _write_bytes(path: Path, data: bytes) -> None:
    """``data`` into ``path`` whole or not at all, unless the file already holds these bytes."""
    from .._atomic import replacing

    try:
        if path.read_bytes() == data:
            return
    except OSError:
        pass
    with replacing(path) as tmp:
        tmp.write_bytes(data)


def write_results(results_dir: str | os.PathLike[str], rows: Iterable[Mapping[str, Any]],
                  traces: Mapping[tuple[str, str], Mapping[str, Any]] | None = None, problems: Sequence[str] = (),
                  label: str | None = None, preprocessing: str | None = None,
                  reports: Mapping[str, str] | None = None, clock: Stopwatch | None = None,
                  draw: DrawFigures | None = None) -> dict[str, Path]:
    """Write the summary, the pairwise comparisons, the figures and the report of a study.

    Parameters
    ----------
    results_dir : path-like
        ``DIR/results`` (created if needed).
    rows : iterable of mapping
        The rows of ``metrics.csv`` (:data:`psmat.study.COLUMNS`; values as numbers or as
        CSV text). Rows whose ``status`` is not ``"ok"`` are counted, not used. The summary,
        the comparisons and the figures use the whole-trial rows (``condition`` "" or absent);
        the conditions' rows give ``romberg.csv`` (:mod:`psmat.study` (``_romberg.py``)).
    traces : mapping, optional
        ``(subject, trial) -> {"t_s": (N,) s, "FP": (N, 2) cm, "<variant>": (N, 2) cm}`` (M-L,
        A-P) for the CoP figures; a trial without traces gets no trace figure.
    problems : sequence of str
        What the study folder lacked (listed in the report).
    label : str, optional
        What the numbers are (e.g. ``"simulation"``), shown in the titles and the report.
    preprocessing : str, optional
        One sentence for the report: the preprocessing behind the sway metrics.
    reports : mapping, optional
        Subject -> its HTML page's path relative to ``results_dir`` (``psmat study run --reports``),
        linked from the report's section "Per-subject reports"; none: no such section.
    clock : psmat.study._timings.Stopwatch, optional
        Where the time of the tables (stage ``after_sessions``), the figures and the report go.
    draw : callable, optional
        Runs figure tasks (:mod:`psmat.study` (``_figure_tasks.py``)): given a list of them,
        yields ``(name, PNG bytes, TaskTime or None)`` for each, in any order — the study
        runner's worker pool, or a Dask cluster's workers (:mod:`psmat.study` (``_cluster.py``));
        default: one after the other in this process. A figure whose
        key and bytes ``results/figures/.keys.json`` records is not drawn again, and a file
        that already holds the bytes drawn is not rewritten.

    Returns
    -------
    dict
        ``{"summary": path, "pairwise": path, "report": path, "<figure name>": path, ...}``
        (and ``"romberg"`` when a trial has an eyes-open and an eyes-closed condition);
        figure names ``sigma_bars``, ``eu_bars``, ``bland_altman_ml``, ``bland_altman_ap`` and
        ``cop_traces_<trial>``.

    Raises
    ------
    ValueError
        A row without subject, trial, variant or status, or two rows for one subject × trial × variant.
    """
    clock = clock or Stopwatch()
    clock.begin("after_sessions")
    out_dir = Path(results_dir)
    figures_dir = out_dir / "figures"
    figures_dir.mkdir(parents=True, exist_ok=True)
    rows = list(rows)
    study = index_rows(r for r in rows if not condition_of(r))
    summary, pairwise = summary_rows(study), pairwise_rows(study)
    quotients = romberg_rows(rows)
    written: dict[str, Path] = {
        "summary": _write_text(out_dir / "summary.csv", table_text(summary, SUMMARY_COLUMNS)),
        "pairwise": _write_text(out_dir / "pairwise.csv", table_text(pairwise, PAIRWISE_COLUMNS)),
    }
    if quotients:
        written["romberg"] = _write_text(out_dir / "romberg.csv", table_text(quotients, ROMBERG_COLUMNS))
    else:
        (out_dir / "romberg.csv").unlink(missing_ok=True)  # not one left from an earlier run
    clock.end("after_sessions")
    clock.begin("figures")
    from .. import __version__

    tasks = figure_tasks(figures_dir, [r for r in rows if not condition_of(r)], study, summary, traces or {}, label,
                         __version__)
    index = FigureIndex(figures_dir)
    todo = most_work_first([t for t in tasks if not index.current(t)])
    by_name = {t.name: t for t in todo}
    cpu = 0.0
    for name, data, took in (draw or _draw_here)(todo):
        t = by_name[name]
        _write_bytes(Path(t.path), data)
        index.record(t, data)
        # a figure drawn in this process is already in the stage's own CPU time: only other processes' is added
        cpu += 0.0 if took is None or took.pid == os.getpid() else took.cpu_s
    if todo:
        index.save()
    figures: dict[str, Path] = {t.name: Path(t.path) for t in tasks}
    clock.end("figures")
    clock.stages["figures"].cpu_s += cpu  # the workers' CPU time drawing them
    clock.count("figures", len(todo), len(tasks) - len(todo))
    clock.begin("report")
    relative = {name: path.relative_to(out_dir).as_posix() for name, path in figures.items()}
    report = render_report(study, summary, pairwise, relative, problems, label, preprocessing, quotients, reports)
    written["report"] = _write_text(out_dir / "report.md", report)
    clock.end("report")
    clock.count("report", 1, 0)
    return {**written, **figures}


def _reusable(results: Path, index: Path, digest: str) -> tuple[dict[str, Path] | None, str | None]:
    """(the outputs ``index`` names, None) when they are proven those of ``digest``; else
    (None, why not) — why is None when there is nothing to report (no index, other inputs)."""
    try:
        doc = json.loads(index.read_text(encoding="utf-8"))
        if not isinstance(doc, dict) or doc.get("schema") != _INDEX or doc.get("digest") != digest:
            return None, None  # made from other inputs, or by another psmat
        top = results.resolve()
        done: dict[str, Path] = {}
        for name, entry in doc["outputs"].items():
            path = results / entry["path"]
            if not path.resolve().is_relative_to(top):
                return None, f"it names {entry['path']!r}, outside {results}"
            if not path.is_file():
                return None, f"{entry['path']} is missing"
            if file_sha256(path) != entry["sha256"]:
                return None, f"{entry['path']} changed after it was written"
            done[str(name)] = path
        return done, None
    except FileNotFoundError:
        return None, None
    except (OSError, ValueError, KeyError, TypeError, AttributeError) as exc:
        return None, f"unreadable ({type(exc).__name__}: {exc})"


def write_outputs(results: Path, rows: Iterable[Mapping[str, Any]], traces: Mapping[tuple[str, str], Any],
                  problems: list[str], inputs_digest: str, label: str | None = None,
                  preprocessing: str | None = None, reports: Mapping[str, str] | None = None,
                  clock: Stopwatch | None = None, draw: DrawFigures | None = None) -> dict[str, Path]:
    """:func:`write_results`, skipped when ``results/.outputs.json`` proves that the outputs on
    disk are those of ``inputs_digest`` (see the module docstring).

    Parameters
    ----------
    results : Path
        ``DIR/results``.
    rows, traces, label, preprocessing, reports
        As for :func:`write_results` (the caller's digest covers them).
    problems : list of str
        As for :func:`write_results`; a line is appended when outputs on disk were found
        changed or the index unreadable (they are written again, the line in the report).
    inputs_digest : str
        A digest of everything the outputs are made from (the caller's: metrics.csv, the
        problems, the traces files, the label, the psmat version).
    draw : callable, optional
        As for :func:`write_results`: what runs the figure tasks.
    clock : psmat.study._timings.Stopwatch, optional
        As for :func:`write_results`; the check of the index counts as ``after_sessions``, and
        outputs reused count as such (``results/timings.csv`` is never one of the outputs).
    """
    clock = clock or Stopwatch()
    index = results / ".outputs.json"
    with clock.stage("after_sessions"):
        done, why = _reusable(results, index, inputs_digest)
    if done is not None:
        figures = [n for n in done if n not in ("summary", "pairwise", "romberg", "report")]
        clock.count("figures", 0, len(figures))
        clock.count("report", 0, int("report" in done))
        return done
    if why is not None:
        problems.append(f"{index.name} not used ({' '.join(why.split())}); summary, figures and report rewritten")
        inputs_digest = hashlib.sha256((inputs_digest + "\n" + problems[-1]).encode()).hexdigest()
    outputs = write_results(results, rows, traces, problems, label=label, preprocessing=preprocessing,
                            reports=reports, clock=clock, draw=draw)
    top = results.resolve()
    entries = {name: {"path": Path(p).resolve().relative_to(top).as_posix(), "sha256": file_sha256(Path(p))}
               for name, p in outputs.items()}
    write_text_atomic(index, json.dumps({"schema": _INDEX, "digest": inputs_digest, "outputs": entries}, indent=1)
                      + "\n")
    return outputs

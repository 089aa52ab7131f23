"""``psmat study run``: every session of a study folder through :func:`process_trial`, as
independent tasks, into ``DIR/results/`` (docs/spec.md §6 layout, §9 ``metrics.csv``, §12).

**Where the cores go.** Each session is one task on one core: a session's IECM warm start
(each frame's solve starts from the previous frame's) and its sensor model's state are
sequential in time, so the parallelism is across sessions, and the processing chain runs with
``threads=1``. The tasks run in processes (joblib's loky pool, one per core by default), not
threads, because much of a session is Python (alignment, sway metrics, the scale factor's root
search) that the GIL would serialise. A task's result depends only on its inputs, so the
tables are bit-identical whatever the number of workers, or on a Dask cluster.

**Resumable.** Each session's result is written atomically under ``results/sessions/`` as it
finishes, keyed by the content of its inputs and the parameters (:mod:`psmat.study` (``_cache.py``),
the inputs hashed on threads from the start of the run, :mod:`psmat.study` (``_hashes.py``); a
session file whose bytes an earlier run read is not read again to find it, :mod:`psmat.study`
(``_discovery.py``));
a killed run resumes with the sessions it had not finished, and a changed weight, file,
calibration or parameter reruns only the sessions it touches. A session whose processing
failed (status ``error: …``) is not stored: it is tried again next run; nor is a recording that
was not closed (its journal alone, :mod:`psmat.io.session`), which is not processed:
its rows' status says which ``psmat repair`` command finishes it. ``metrics.csv`` is
written after the sessions, then :func:`psmat.study.write_results` (summary, figures,
report) — skipped when ``metrics.csv``, the problems and the traces are those it last wrote
from (``results/.outputs.json``); ``metrics.csv`` itself is not rewritten when its bytes are the
same. One run per study at a time (``results/.lock``). Every run writes where its time went,
``results/timings.csv`` and ``results/session_timings.csv`` (:mod:`psmat.study` (``_timings.py``)),
which no key or digest reads.

**Across volunteers.** After the sessions, ``SCHC-DYN`` (:mod:`psmat.study` (``_dynamic.py``), beyond the
thesis) corrects each session's SCHC trace by a model fitted on the other volunteers, so its fits are
computed for the study as a whole, never cached per session; what a fit needs from one session
alone (:func:`psmat.study.session_stats`) is formed in that session's task and stored with its
result, so a rerun does not form it again, and the fits read no trace. Each session's correction
and metrics are then tasks of the same pool (or cluster), one per volunteer
(:mod:`psmat.study` (``_dynamic_tasks.py``)); a rerun that computed no session runs them here.
The figures are tasks of the
same worker pool (or cluster) as the sessions, one per figure, each redrawn only when what it
draws changed (:mod:`psmat.study` (``_figure_tasks.py``)). A study whose sessions all say in
their metadata that a simulator wrote them is labelled "simulation" in its figures and report.

**Per-subject reports** (``reports=True``, opt-in: every session is processed a second time):
one HTML page per subject under ``results/reports/``, tasks of the same pool (or cluster) as the
sessions, resumable by their own keys (:mod:`psmat.study` (``_reports.py``)), linked from ``report.md``.

**Stored results are proven, not trusted** (:mod:`psmat.study` (``_cache.py``)): an entry under
``results/sessions`` whose digest, rows, traces file or paths do not check out is recomputed,
and the run says so among its problems.

**On a cluster** (``scheduler="tcp://host:8786"`` or ``scheduler_file``, TLS through
``security``; the extra ``psmat[cluster]``): the same tasks — sessions, pages, figures — go to a
Dask distributed scheduler and come back as they complete, as plain data (with each task's time
in its worker) that this process parses without pickle, checks and writes
(:mod:`psmat.study` (``_cluster.py``)). A Dask cluster must be trusted: its workers run
arbitrary code by design. Tasks carry file paths, not file contents, so the study folder must
be on a filesystem the workers share (the same path on every worker), and the workers need
psmat installed.
"""

from __future__ import annotations

import contextlib
import csv
import io
import math
import os
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..balance import KNOWN_VARIANTS, PLATFORM_AXES
from ._cache import SessionStore, Stored, TraceFiles, canonical_json, file_sha256, normalise_rows, result_key, \
    study_lock, write_text_atomic
from ._discovery import DiscoveryRecord
from ._dynamic import plan_dynamic
from ._dynamic_cache import DynamicStore
from ._dynamic_tasks import Answer, DynamicTask, RunDynamic, dynamic_tasks, run_dynamic
from ._figure_tasks import FigureTask, draw_figure
from ._hashes import FileHashes, study_inputs
from ._layout import PLATFORM_SUFFIXES, SessionMeta, StudyItem, StudyLayout, discover, session_events
from ._order import most_work_first
from ._reports import REPORTS_DIR, ReportIndex, ReportTask, report_tasks, run_report
from ._row_metrics import preprocessing_sentence
from ._task import SessionTask, run_task, status_rows
from ._timings import PoolClock, Stopwatch, TaskTime, timed
from ._trial import COLUMNS, DEFAULT_PARAMS, SUSPECT, Rows, Traces, suggested_axes

if TYPE_CHECKING:  # pragma: no cover
    from ._results import DrawFigures

__all__ = ["RunReport", "run_study", "write_metrics", "TRIALS"]

#: the presets of params "preprocess" and "descriptors" (None: no preprocessing / no descriptors)
PRESETS = ("quijoux2021", None)
#: the thesis' trials in the order of its tables (docs/spec.md §9); other trial names sort after them
TRIALS = ("right-leg", "left-leg", "rotation")


@dataclass
class RunReport:
    """What a run did: sessions computed now, reused from ``results/sessions``, failed; the
    problems found (inputs, failed sessions, stale results); where the results are."""

    root: Path
    sessions: int
    computed: int
    reused: int
    failed: int
    problems: list[str]
    metrics: Path
    outputs: dict[str, Path] = field(default_factory=dict)
    #: the per-subject pages up to date after this run, by subject (listed in report.md)
    reports: dict[str, Path] = field(default_factory=dict)
    #: with ``reports=True``: pages (written, reused, failed); None without
    report_counts: tuple[int, int, int] | None = None

    @property
    def results(self) -> Path:
        return self.root / "results"

    def __str__(self) -> str:
        files = [self.metrics, *self.outputs.values()]
        top = [p.name for p in files if p.parent == self.metrics.parent]
        below = sorted({p.parent.name for p in files if p.parent != self.metrics.parent})
        lines = [f"{self.sessions} sessions: {self.computed} computed, {self.reused} reused, {self.failed} failed",
                 f"results in {self.results}: {', '.join(top + [f'{d}/' for d in below])}"]
        if self.report_counts is not None:
            w, r, f = self.report_counts
            lines.append(f"{w + r + f} subject reports in {self.results / REPORTS_DIR}: {w} written, {r} reused, "
                         f"{f} failed")
        return "\n".join(lines + [f"problem: {p}" for p in self.problems])


def run_study(root: str | os.PathLike[str], *, workers: int | None = None, scheduler: str | None = None,
              params: dict[str, Any] | None = None, progress: bool = True,
              scheduler_file: str | os.PathLike[str] | None = None, security: Any = None,
              reports: bool = False) -> RunReport:
    """Process every session of the study folder ``root`` into ``root/results/``.

    Parameters
    ----------
    root : path
        A study folder (docs/spec.md §6).
    workers : int, optional
        Processes (default: every core); 1 runs the sessions in this process.
    scheduler : str, optional
        Address of a Dask distributed scheduler (``tcp://host:8786``, ``tls://host:8786``) to
        run the sessions on instead; needs ``psmat[cluster]``, the study folder on a shared
        filesystem and a cluster you trust (:mod:`psmat.study` (``_cluster.py``)).
    params : dict, optional
        Overrides of :data:`psmat.study.DEFAULT_PARAMS` (they are part of every key).
    progress : bool
        A progress bar over sessions on stderr.
    scheduler_file : path, optional
        The scheduler's file (``dask scheduler --scheduler-file``) instead of ``scheduler``.
    security : distributed.Security, optional
        TLS credentials for the cluster (:func:`psmat.study.security`).
    reports : bool
        Also write one HTML page per subject, ``results/reports/<subject>.html``
        (:func:`psmat.report.write_report` of its sessions; :mod:`psmat.study` (``_reports.py``)),
        as tasks in the same worker pool as the sessions (with a cluster: on its workers, each
        page sent back as text, checked and written by this process), a page whose inputs are
        unchanged not written again. Opt-in: each session is processed a second time. Without it, pages already there
        are left alone and ``report.md`` links those still up to date.

    Returns
    -------
    RunReport

    Raises
    ------
    FileNotFoundError
        ``root`` is not a study folder.
    ValueError
        Unknown parameters or variants, a bad ``workers``, both ``workers`` and a cluster, both
        ``scheduler`` and ``scheduler_file``, or ``security`` without a cluster.
    ImportError
        A cluster without Dask distributed installed.
    RuntimeError
        Another run is writing the same study, or a ``tls://`` scheduler without credentials.
    OSError
        The cluster cannot be reached or refused the connection (e.g. TLS credentials of
        another CA), or the scheduler file does not exist.
    """
    p = _checked_params(params)
    if (scheduler is not None or scheduler_file is not None) and workers is not None:
        raise ValueError("give workers or a scheduler, not both (the cluster's workers run the sessions)")
    if scheduler is not None and scheduler_file is not None:
        raise ValueError("give a scheduler address or a scheduler file, not both")
    if security is not None and scheduler is None and scheduler_file is None:
        raise ValueError("TLS settings are for a cluster: give a scheduler address or a scheduler file too")
    cluster = None
    if scheduler is not None or scheduler_file is not None:
        from ._cluster import Cluster

        cluster = Cluster(scheduler, None if scheduler_file is None else os.fspath(scheduler_file), security)
    if workers is not None and (isinstance(workers, bool) or not isinstance(workers, int) or workers < 1):
        raise ValueError(f"workers must be an integer >= 1, got {workers!r}")
    clock = Stopwatch()
    folder = Path(root)
    ready = _start_pool(folder, workers) if cluster is None else None
    # a first run's Dask workers import the tasks' modules while this process finds the sessions
    release = _warm_cluster(folder, cluster) if cluster is not None else None
    try:
        return _run(folder, p, workers, cluster, progress, reports, clock, ready)
    finally:
        if release is not None:
            release()


def _run(root: Path, p: dict[str, Any], workers: int | None, cluster: Any, progress: bool, reports: bool,
         clock: Stopwatch, ready: Callable[[], None] | None) -> RunReport:
    """:func:`run_study` once its arguments are checked and its workers started (or warmed)."""
    from psmat._progress import tqdm

    from .. import __version__

    # the inputs' hashes for the keys, on threads while this thread reads the sessions' metadata
    hashes = FileHashes(study_inputs(root, PLATFORM_SUFFIXES), _key_threads())
    try:
        with clock.stage("discover"):  # what an earlier run read from a file of the same bytes is not read again
            record = DiscoveryRecord(root / "results", __version__)
            read: dict[Path, SessionMeta] = {}
            layout = discover(root, lambda path: record.known(path, hashes), read)
    except BaseException:
        hashes.close()
        raise
    with hashes, study_lock(layout.results):
        clock.begin("keys")
        store = SessionStore(layout.results / "sessions")
        problems = list(layout.problems)
        if record.problem:
            problems.append(record.problem)
        if n := store.remove_temporaries():
            problems.append(f"removed {n} incomplete temporary file(s) an interrupted run left in {store.folder}")
        tasks = {t.stem: t for t in _tasks(layout, p, __version__, hashes)}
        hashes.close()
        try:
            record.write(read, hashes)
        except OSError as exc:  # a rerun then reads the files again: nothing else depends on it
            problems.append(f"{record.path} not written ({exc.strerror or exc}): the next run reads every "
                            "session's metadata again")
        stale = sorted(set(store.stems()) - set(tasks))
        if stale:
            problems.append(f"{store.folder} holds results of {len(stale)} session(s) no longer in the study, "
                            f"ignored (not deleted): {', '.join(stale)}")
        done: dict[str, Stored] = {}
        unclosed = _unclosed(layout.items, tasks)  # recordings not closed: a status row each, never processed
        for stem, t in tasks.items():
            if stem in unclosed:
                continue
            found = store.load(stem, t.key, t.expect)
            if found.stored is not None:
                done[stem] = found.stored
            elif found.problem is not None:  # on disk but not proven: recomputed, and said so
                problems.append(f"{stem}: {found.problem}")
        reused = len(done)
        failed: set[str] = set(unclosed)
        done.update(unclosed)
        todo = most_work_first([t for stem, t in tasks.items() if stem not in done],
                               {i.stem: i.circuit for i in layout.items})
        todo_stems = [t.stem for t in todo]
        order = sorted(tasks, key=lambda s: _order(tasks[s]))
        pages = report_tasks(layout, tasks, order, set(tasks) - set(unclosed), __version__)
        index = ReportIndex(layout.results / REPORTS_DIR)
        pages_todo: list[ReportTask] = []
        if reports:
            index.folder.mkdir(parents=True, exist_ok=True)
            if n := index.remove_temporaries():
                problems.append(f"removed {n} incomplete temporary file(s) an interrupted run left in {index.folder}")
            pages_todo = [r for r in pages if not index.current(r)]
        page_failed: list[str] = []
        by_subject = {r.subject: r for r in pages}
        clock.end("keys")
        pool = PoolClock(clock)
        if ready is not None:  # the pool's processes, started before discover: their wait is the sessions'
            ready()
        with contextlib.ExitStack() as bars:
            bar = bars.enter_context(tqdm(total=len(tasks), initial=reused, unit="session", desc="sessions",
                                          disable=not progress))
            rbar = bars.enter_context(tqdm(total=len(pages), initial=len(pages) - len(pages_todo), unit="report",
                                           desc="reports", disable=not (progress and reports)))
            for kind, result, took in _execute(todo, workers, cluster, pages_todo):
                pool.add(kind, took)
                if kind == "report":
                    subject, why = result
                    index.record(by_subject[subject], why is None)
                    if why is not None:
                        page_failed.append(f"report of {subject} not written: {why}")
                    rbar.update(1)
                    continue
                stem, rows, traces = result
                t = tasks[stem]
                rows = _with_notes(rows, t.notes)
                if all(r["status"].startswith("error:") for r in rows):
                    failed.add(stem)
                    done[stem] = Stored(normalise_rows(rows), None)
                else:
                    done[stem] = store.save(stem, t.key, t.inputs, rows, traces)
                clock.session(t.subject, t.trial, stem, "failed" if stem in failed else "computed", took)
                bar.update(1)
        pool.stop()
        from .._parallel import pool_size

        # the processes this run's pool has (1: none), which the maps after the sessions reuse
        # rather than start more (a rerun of 3 sessions on 16 cores: its 42 SCHC-DYN tasks on those 3)
        size = pool_size(workers, len(todo) + len(pages_todo))
        if ready is not None:  # started ahead for every session
            size = max(size, pool_size(workers, len(tasks)))
        clock.begin("after_sessions")
        listed = {r.subject: Path(r.out) for r in pages if index.current(r)}
        if reports:  # a note only where its page stands (a failed page is its own line)
            problems += sorted(page_failed) + [r.note for r in pages if r.note and r.subject in listed]
        keep = _first_of_each(order, tasks, problems)
        rows = [r for stem in keep for r in done[stem].rows]
        problems += _session_problems(layout.items, order, done, failed)
        files = TraceFiles({(tasks[s].subject, tasks[s].trial): t for s in keep if (t := done[s].traces)})
        traces: Mapping[tuple[str, str], Traces] = files
        if "SCHC" in p["variants"]:  # beyond the thesis: SCHC-DYN across volunteers
            dyn_store = DynamicStore(layout.results)  # the volunteers' answers of an earlier run
            run_dyn = dyn_store.around(_dynamic_runner(size, cluster))
            rows, traces, cpu = _with_dynamic(rows, files, p, run_dyn)
            problems += dyn_store.problems
            clock.add("after_sessions", 0.0, cpu)  # the workers' CPU time correcting the sessions
            clock.count("after_sessions", dyn_store.computed, dyn_store.reused)
        metrics = layout.results / "metrics.csv"
        write_metrics(metrics, rows)
        links = {s: path.relative_to(layout.results).as_posix() for s, path in listed.items()}
        clock.end("after_sessions")
        outputs = _write_outputs(layout.results, rows, traces, problems, __version__,
                                 "simulation" if layout.simulated else None, _preprocessing(p),
                                 links, clock, _drawer(size, cluster))
        for stem in set(tasks) - set(todo_stems):
            clock.session(tasks[stem].subject, tasks[stem].trial, stem, "not closed" if stem in unclosed else "reused")
        clock.count("sessions", len(tasks) - reused - len(failed), reused)
        if reports:
            clock.count("reports", len(pages_todo) - len(page_failed), len(pages) - len(pages_todo))
        clock.write(layout.results)
    counts = (len(pages_todo) - len(page_failed), len(pages) - len(pages_todo), len(page_failed)) if reports else None
    return RunReport(layout.root, len(tasks), len(tasks) - reused - len(failed), reused, len(failed), problems,
                     metrics, outputs, listed, counts)


def write_metrics(path: Path, rows: Sequence[dict[str, Any]]) -> None:
    """``metrics.csv`` (docs/spec.md §9): the columns of :data:`COLUMNS` then any further ones the
    rows hold (the descriptors, when asked for), floats as ``repr`` (exact, so a rerun is
    byte-identical), NaN or a missing value as an empty field; written atomically, and not at
    all when the file already holds these bytes (a rerun leaves it untouched, its mtime too)."""
    cols, seen = list(COLUMNS), set(COLUMNS)
    for r in rows:
        new = [c for c in r if c not in seen]
        cols += new
        seen.update(new)
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(cols)
    for r in rows:
        w.writerow([_cell(r.get(c, math.nan)) for c in cols])
    text = buf.getvalue()
    with contextlib.suppress(OSError, UnicodeDecodeError):
        if path.is_file() and path.read_bytes() == text.encode("utf-8"):
            return
    write_text_atomic(path, text)


def _with_dynamic(rows: Rows, traces: TraceFiles, params: Mapping[str, Any], run: RunDynamic
                  ) -> tuple[Rows, Mapping[tuple[str, str], Traces], float]:
    """The study's rows and traces with ``SCHC-DYN``, and the CPU seconds its tasks took in the
    workers. The fits (:func:`psmat.study.plan_dynamic`: across volunteers, so computed after
    every session, never cached per session) are made here from each session's own part, formed
    by its task and stored with its traces; each session's correction and metrics are then the
    tasks ``run`` runs, one per volunteer (:mod:`psmat.study` (``_dynamic_tasks.py``)), the same
    numbers in any process. Each session's new row follows its own rows."""
    plan = plan_dynamic(rows, traces, stats={k: traces.stats(k) for k in traces}, trust_stats=True)
    todo = dynamic_tasks(plan, {k: traces.path(k) for k in plan.jobs}, preprocess=params["preprocess"],
                         descriptors=params["descriptors"])
    dyn_traces: dict[tuple[str, str], Traces] = {}
    cpu = 0.0
    for task, answers, took in run(todo):
        for trial, row, c in answers:
            plan.rows[(task.subject, trial)] = row
            if c is not None:
                dyn_traces[(task.subject, trial)] = {plan.name: c}
        cpu += took.cpu_s if took is not None and took.pid != os.getpid() else 0.0
    by_key = {k: {**plan.rows[k], "condition": ""} for k in plan.order if k in plan.rows}
    out: Rows = []
    for i, r in enumerate(rows):
        out.append(r)
        key = (r["subject"], r["trial"])
        last = (i + 1 == len(rows) or (rows[i + 1]["subject"], rows[i + 1]["trial"]) != key
                or (r["condition"] == "" and rows[i + 1]["condition"] != ""))  # after the whole-trial rows
        if last and key in by_key:
            out.append(by_key.pop(key))
    out += list(by_key.values())
    return out, _MergedTraces(traces, dyn_traces), cpu


def _dynamic_runner(size: int, cluster: Any) -> RunDynamic:
    """What runs SCHC-DYN's tasks: the cluster's workers (:func:`psmat.study._cluster.cluster_dynamic`),
    the ``size`` processes of this run's pool when its sessions or pages started one, else this
    process (a rerun that computed nothing: the pool's start would cost more than the tasks)."""
    if cluster is not None:
        from ._cluster import cluster_dynamic

        return cluster_dynamic(cluster)

    def run(tasks: list[DynamicTask]) -> Iterator[tuple[DynamicTask, list[Answer], TaskTime | None]]:
        if size <= 1:
            for t in tasks:
                yield t, *timed(run_dynamic, t)
            return
        from .._parallel import map_unordered

        by_subject = {t.subject: t for t in tasks}
        for _, (subject, answers), took in map_unordered(_work, tasks, size, keep_pool=True):
            yield by_subject[subject], answers, took

    return run


class _MergedTraces(Mapping[tuple[str, str], Traces]):
    """The sessions' traces (read on access) with the study-level variants' added."""

    def __init__(self, base: Mapping[tuple[str, str], Traces], extra: Mapping[tuple[str, str], Traces]) -> None:
        self._base, self._extra = base, extra

    def __getitem__(self, key: tuple[str, str]) -> Traces:
        return {**self._base[key], **self._extra.get(key, {})}

    def __iter__(self) -> Iterator[tuple[str, str]]:
        return iter(self._base)

    def __len__(self) -> int:
        return len(self._base)

    def path(self, key: tuple[str, str]) -> Path:
        return self._base.path(key)  # type: ignore[attr-defined]


def _write_outputs(results: Path, rows: Rows, traces: Mapping[tuple[str, str], Traces], problems: list[str],
                   version: str, label: str | None = None, preprocessing: str | None = None,
                   reports: Mapping[str, str] | None = None, clock: Stopwatch | None = None,
                   draw: DrawFigures | None = None) -> dict[str, Path]:
    """:func:`~psmat.study._results.write_outputs` (summary, figures, report), skipped when its
    inputs (metrics.csv, the problems, the traces files, the label, the subject reports linked)
    are those of the outputs on disk and those outputs are unchanged; ``draw`` runs the figure
    tasks (:func:`_drawer`)."""
    import hashlib

    from ._results import write_outputs  # matplotlib: imported when a study is run, not with psmat

    if clock is not None:
        clock.begin("after_sessions")
    digest = hashlib.sha256(canonical_json({
        "psmat": version, "metrics": file_sha256(results / "metrics.csv"), "problems": problems, "label": label,
        "preprocessing": preprocessing, "reports": dict(reports or {}),
        "traces": sorted([*k, traces.path(k).name] for k in traces)}).encode()).hexdigest()
    if clock is not None:
        clock.end("after_sessions")
    return write_outputs(results, rows, traces, problems, digest, label, preprocessing, reports, clock, draw)


def _cell(v: Any) -> str:
    if isinstance(v, float):
        return "" if math.isnan(v) else repr(v)
    return str(v)


def _preprocessing(p: dict[str, Any]) -> str:
    """report.md's preprocessing sentence, and the platform's axes when they were not read as they are."""
    text = preprocessing_sentence(p["preprocess"])
    if p["platform_axes"] != "x,y":
        text += (f" The force platform's axes were turned onto the mat's: M-L, A-P = {p['platform_axes']} of its "
                 "files (platform_axes).")
    return text


def _checked_params(params: dict[str, Any] | None) -> dict[str, Any]:
    """The whole parameter dict (defaults filled in) as plain JSON values; ValueError if unknown."""
    import json

    given = dict(params or {})
    unknown = sorted(set(given) - set(DEFAULT_PARAMS))
    if unknown:
        raise ValueError(f"unknown parameter(s) {', '.join(unknown)}; known: {', '.join(DEFAULT_PARAMS)}")
    p = {**DEFAULT_PARAMS, **given}
    bad = [v for v in p["variants"] if v not in KNOWN_VARIANTS]
    if bad or not p["variants"]:
        raise ValueError(f"unknown variant(s) {bad or '(none given)'}; known: {', '.join(KNOWN_VARIANTS)}")
    for name in ("preprocess", "descriptors"):
        if p[name] not in PRESETS:
            raise ValueError(f"{name} must be one of {', '.join(map(str, PRESETS))}, got {p[name]!r}")
    if p["platform_axes"] not in PLATFORM_AXES:
        raise ValueError(f"platform_axes must be one of {', '.join(PLATFORM_AXES)}, got {p['platform_axes']!r}")
    try:
        return json.loads(canonical_json(p))
    except ValueError as exc:
        raise ValueError(f"params: {exc}") from None


def _from_stem(stem: str) -> tuple[str, str]:
    """(subject, trial) from a file name ``<subject>_<trial>`` (docs/spec.md §6), for sessions whose metadata lacks them."""
    subject, _, trial = stem.partition("_")
    return subject, trial


def _key_threads() -> int:
    """Threads that hash and read the inputs for the keys: the usable cores, at most 8."""
    from .._cpus import usable_cpus

    return max(1, min(usable_cpus(), 8))


def _tasks(layout: StudyLayout, params: dict[str, Any], version: str, hashes: FileHashes) -> list[SessionTask]:
    """:func:`_task` of every session of ``layout``, in its order, on a few threads: the time goes into
    reading and hashing the input files, and both release the GIL (a thesis-size study's 252 files,
    about 1 GB, hash in ~0.4 s on one core). ``hashes``: the session, platform and calibration files'
    hashes, started before the sessions were found (:mod:`psmat.study` (``_hashes.py``)); the other
    files (journals, events) are hashed here."""
    from concurrent.futures import ThreadPoolExecutor

    n = min(len(layout.items), _key_threads())
    if n <= 1:
        return [_task(item, layout, params, version, hashes) for item in layout.items]
    with ThreadPoolExecutor(n, thread_name_prefix="psmat-keys") as pool:
        return list(pool.map(lambda item: _task(item, layout, params, version, hashes), layout.items))


def _task(item: StudyItem, layout: StudyLayout, params: dict[str, Any], version: str,
          hashes: FileHashes) -> SessionTask:
    """The task of one session and the inputs its key is made of (see :mod:`psmat.study` (``_cache.py``))."""
    from ..io import journal_path

    named = _from_stem(item.stem)
    subject, trial = item.subject or named[0], item.trial or named[1]
    notes = tuple(f"session metadata has no {what}: {what} {value!r} taken from the file name"
                  for what, have, value in (("subject", item.subject, subject), ("trial", item.trial, trial))
                  if have is None)
    who = layout.subjects.get(item.subject) if item.subject is not None else None
    weight = None if who is None else who.weight_kg
    cal = layout.calibrations.get(item.serial) if item.serial is not None else None
    jpath = journal_path(item.session)
    inputs = {"psmat": version, "params": params, "stem": item.stem, "subject": subject, "trial": trial,
              "weight_kg": weight, "session_sha256": hashes.sha(item.session),
              "journal_sha256": hashes.sha(jpath) if jpath.is_file() else None,
              "forceplate_sha256": hashes.sha(item.forceplate), "calibration": None if cal is None else cal.name,
              "calibration_sha256": hashes.sha(cal), "events_sha256": hashes.sha(item.events)}
    if item.events_unusable:  # its markers are not used (only then in the key: the others' keys stay)
        inputs["events_unusable"] = True
    return SessionTask(item.stem, str(item.session), None if item.forceplate is None else str(item.forceplate),
                       subject, trial, weight, None if cal is None else str(cal), params, result_key(inputs), inputs,
                       notes, () if item.events_unusable else _events(item.events, item.session))


def _events(path: Path | None, session: Path) -> tuple[tuple[float, str], ...] | None:
    """The markers of a study's events file as host times of its session (None: none, the session's own
    are used); a file that cannot be read gives no markers (:func:`psmat.study.find_study` lists its
    problem)."""
    if path is None:
        return None
    try:
        return tuple(session_events(path, session))
    except (ValueError, OSError):
        return ()


def _with_notes(rows: Rows, notes: tuple[str, ...]) -> Rows:
    """The problems :func:`process_trial` cannot see, added to the status of rows that were computed."""
    if not notes:
        return rows
    extra = "; ".join(notes)
    return [{**r, "status": r["status"] if r["status"].startswith("error:")
             else extra if r["status"] == "ok" else f"{r['status']}; {extra}"} for r in rows]


def _order(t: SessionTask) -> tuple[Any, ...]:
    """metrics.csv order: subject, then trial (the thesis' trials first, in its order), then file."""
    rank = TRIALS.index(t.trial) if t.trial in TRIALS else len(TRIALS)
    return t.subject, rank, t.trial, t.stem


def _first_of_each(order: Sequence[str], tasks: dict[str, SessionTask], problems: list[str]) -> list[str]:
    """The first session of each subject × trial (docs/spec.md §9: one row per subject × trial × variant);
    any other is named in ``problems`` and left out of the tables (its result stays stored)."""
    first: dict[tuple[str, str], str] = {}
    for stem in order:
        who = (tasks[stem].subject, tasks[stem].trial)
        if who in first:
            problems.append(f"{stem}: {who[0]} {who[1]} again (first {first[who]}); left out of metrics.csv")
        first.setdefault(who, stem)
    return list(first.values())


def _session_problems(items: Sequence[StudyItem], order: Sequence[str], done: dict[str, Stored],
                      failed: set[str]) -> list[str]:
    """One line per problem of a session (what find_study saw, else a failed session's error)."""
    by_stem = {i.stem: i for i in items}
    out = []
    for stem in order:
        problems = list(by_stem[stem].problems)
        if stem in failed and not problems:
            problems.append(done[stem].rows[0]["status"])
        elif suspect := next((st[st.index(k):] for r in done[stem].rows for k in SUSPECT if k in (st := r["status"])),
                             None):
            problems.append(suspect)  # a poor alignment or a platform spread: its rows are left out of the summary
        out += [f"{stem}: {p}" for p in problems]
    # a platform whose axes lie otherwise than the mat's does so in every trial: said once, first
    axes = [a for stem in order if stem not in failed and (a := _axes_of(done[stem].rows)) is not None]
    common = {a: axes.count(a) for a in axes}
    return [f"{n} trials align only with the platform's axes {a}: run the study again with --platform-axes={a}"
            for a, n in common.items() if n > 1] + out


def _axes_of(rows: Rows) -> str | None:
    """The platform axes a session's poor alignment names, if any (psmat.study._trial.suggested_axes)."""
    return next((a for r in rows if (a := suggested_axes(r["status"])) is not None), None)


def _unclosed(items: Sequence[StudyItem], tasks: Mapping[str, SessionTask]) -> dict[str, Stored]:
    """The rows of each session whose recording was not closed (:attr:`StudyItem.not_closed`): no
    numbers, the status says which ``psmat repair`` command finishes it; not stored, so the next
    run processes the repaired file."""
    return {i.stem: Stored(normalise_rows(status_rows(tasks[i.stem], i.not_closed)), None)
            for i in items if i.not_closed}


def _execute(todo: list[SessionTask], workers: int | None, cluster: Any, pages: Sequence[ReportTask] = ()
             ) -> Iterator[tuple[str, Any, TaskTime | None]]:
    """``("session", (stem, rows, traces), time)`` of each session task and ``("report", (subject,
    why not or None), time)`` of each page, in the order they finish, with the task's time in
    its worker, in one pool of this machine's processes or, given ``cluster`` (a
    :class:`psmat.study.Cluster`), on its workers (:func:`psmat.study._cluster.run_on_cluster`:
    each page sent back as text, checked and written here; the time None for a task whose
    answer was refused or lost)."""
    if cluster is not None:
        from ._cluster import run_on_cluster

        yield from run_on_cluster(todo, pages, cluster)
        return
    from .._parallel import map_unordered  # workers that end with this process, even after kill -9

    yield from map_unordered(_work, [*todo, *pages], workers)


def _first_run(root: Path) -> int:
    """The sessions of a first run (no stored session result): its workers are started, or
    warmed, before the sessions are found; 0 for a run that may reuse everything."""
    sessions = root / "sessions"
    store = root / "results" / "sessions"
    if not sessions.is_dir() or (store.is_dir() and any(store.glob("*.json"))):
        return 0
    return sum(1 for _ in sessions.glob("*.h5"))


def _start_pool(root: Path, workers: int | None) -> Callable[[], None] | None:
    """On a first run (:func:`_first_run`), start the pool's processes now, without waiting, each
    running :func:`psmat.study._warm.warm`, so that their start and imports (~1.4 s, matplotlib's
    for the figures included) pass while this process finds the sessions and their keys; what is
    returned waits for them (:func:`psmat._parallel.start_pool`). None otherwise: a run that may
    reuse everything starts its pool only if it has sessions to compute."""
    from .._parallel import start_pool
    from ._warm import warm

    count = 0 if workers == 1 else _first_run(root)
    return start_pool(warm, count, workers) if count > 1 else None


def _warm_cluster(root: Path, cluster: Any) -> Callable[[], None]:
    """On a first run (:func:`_first_run`), one :func:`psmat.study._warm.warm` task on each of the
    cluster's workers now (:func:`psmat.study._cluster.warm_cluster`); what is returned lets go of
    them. A cluster that cannot be reached raises here, as the sessions' own connection would."""
    if not _first_run(root):
        return lambda: None
    from ._cluster import warm_cluster

    return warm_cluster(cluster)


def _drawer(size: int, cluster: Any) -> DrawFigures | None:
    """What draws the figures: the cluster's workers (:func:`psmat.study._cluster.cluster_drawer`),
    the ``size`` processes of this run's pool (:func:`_pool_drawer`) when its sessions or pages
    started one, else this process (None)."""
    if cluster is not None:
        from ._cluster import cluster_drawer

        return cluster_drawer(cluster)
    return _pool_drawer(size) if size > 1 else None


def _pool_drawer(size: int) -> DrawFigures:
    """What runs the figure tasks: the same pool of this machine's processes as the sessions, all
    ``size`` of them (joblib's loky executor is kept between the two maps, so its workers,
    already started and with their imports done, draw the figures; a larger map would start
    more, and a map sized to the 7 figures would first stop the other processes and wait for
    them). Used only when the sessions or pages of this run started that pool: otherwise (every
    session reused) the figures to redraw are drawn in this process, as starting a pool and its
    imports costs about what drawing a study's few figures does."""
    from .._parallel import map_unordered

    def draw(tasks: list[FigureTask]) -> Iterator[tuple[str, bytes, TaskTime | None]]:
        for _, (name, data), took in map_unordered(_work, tasks, size, keep_pool=True):
            yield name, data, took

    return draw


def _work(task: SessionTask | ReportTask | FigureTask | DynamicTask) -> tuple[str, Any, TaskTime]:
    """One task of the pool, a session, a subject's page, a figure or a volunteer's SCHC-DYN: its
    kind, its result and its time in the worker (:file:`results/session_timings.csv`)."""
    if isinstance(task, ReportTask):
        return ("report", *timed(run_report, task))
    if isinstance(task, FigureTask):
        return ("figure", *timed(draw_figure, task))
    if isinstance(task, DynamicTask):
        answers, took = timed(run_dynamic, task)
        return "dynamic", (task.subject, answers), took
    return ("session", *timed(run_task, task))

"""A study's sessions, per-subject pages and figures on a Dask distributed cluster (``psmat
study run --scheduler``), and what that asks you to trust.

**A Dask cluster must be trusted.** Its workers run whatever code a client sends them — by
design, that is what they are for — and Dask's wire protocol lets any peer (the scheduler or a
worker) send the client pickled messages, which the client unpickles: an exception a task
raised, for one. So a cluster you run a study on is a cluster you would let run code on your
machine: only your own scheduler and workers, on a network you control, over TLS with
certificates (below) when that network is shared.

What psmat narrows, where Dask allows it:

* **Results come back as data.** A task returns bytes (:func:`psmat.study.encode_result`:
  an ``.npz`` holding the rows as JSON and the traces as float64 arrays) and never raises (a
  session that fails returns error rows), and the client asks for results in msgpack only
  (``Client(deserializers=["msgpack"])``): a result a worker sends as pickle, or in Dask's own
  format (whose header is a pickle), is refused before it is read, and the session is
  reported as failed (tried again next run). The bytes are then parsed without pickle
  (``allow_pickle=False``, JSON) and checked (:func:`psmat.study.decode_result`: the
  session's stem, subject, trial, one row per variant asked for, traces' shapes) before this
  process writes them to ``results/sessions`` with their digests (:mod:`psmat.study` (``_cache.py``)).
* **Every task's answer is the pair (result, time)**: its time in the worker (start, wall and
  CPU seconds, pid, the worker's address) as plain numbers and text
  (:func:`psmat.study._plain.stamp`), checked (:func:`psmat.study._plain.check_timed`) and
  written to ``results/session_timings.csv``.
* **Figures and per-subject pages are tasks of the cluster too**, their results data this
  process checks and writes atomically: a figure comes back as its PNG's bytes, checked as one
  well-formed PNG (:func:`psmat._png.check_png`) — a figure refused or lost is drawn in this
  process instead; a page (``--reports``) comes back as its HTML text, checked to hold only what
  psmat's pages hold (:func:`psmat.report.check_page`: no script, no link, no other style
  sheet) — a page refused is a problem line of the run, tried again next run.
* **SCHC-DYN's per-volunteer corrections are tasks of the cluster too**
  (:mod:`psmat.study` (``_dynamic_tasks.py``)): each sends its rows and corrected traces back as
  an ``.npz`` of JSON and float64 arrays, checked (:func:`psmat.study._dynamic_tasks.decode_dynamic`)
  before use; an answer refused or lost is computed in this process instead.
* **TLS and authentication are passed through**: ``scheduler_file`` (the JSON a scheduler
  writes with ``--scheduler-file``) and a :class:`distributed.Security` (TLS CA, client
  certificate and key, ``require_encryption``; :func:`security`). Dask's TLS is mutual: the
  scheduler refuses a client without a certificate its CA signed, and the client refuses a
  scheduler whose certificate it cannot verify.

Tasks carry file paths, not file contents: the study folder must be on a filesystem the
workers share (the same path on every worker) for them to read the sessions; they write nothing
there. The workers need psmat installed, the version of this process (and its matplotlib, for
figures of the same bytes: both versions are part of each figure's key, read here).
"""

from __future__ import annotations

import gc
import os
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ._dynamic_tasks import (Answer, DynamicTask, RunDynamic, decode_dynamic, encode_dynamic, run_dynamic, task_key,
                             trace_lengths)
from ._figure_tasks import FigureTask, draw_figure
from ._plain import check_timed, decode_result, encode_result, first_line, stamp
from ._reports import ReportTask, render_page
from ._timings import TaskTime, timed
from ._trial import Rows, Traces

if TYPE_CHECKING:  # pragma: no cover
    from ._results import DrawFigures
    from ._task import SessionTask

__all__ = ["PLAIN_DESERIALIZERS", "Cluster", "security", "run_encoded", "run_session", "run_page", "run_figure",
           "run_on_cluster", "on_cluster", "cluster_drawer", "run_dynamic_plain", "cluster_dynamic", "warm_cluster"]

#: the only way a result may come back to the client: msgpack (bytes, numbers, text, lists, maps)
PLAIN_DESERIALIZERS = ("msgpack",)


@dataclass(frozen=True)
class Cluster:
    """Where the cluster is: a scheduler address (``tcp://host:8786``, ``tls://host:8786``) or
    a scheduler file, and the :class:`distributed.Security` to connect with (None: Dask's
    configuration)."""

    scheduler: str | None = None
    scheduler_file: str | None = None
    security: Any = None

    def __post_init__(self) -> None:
        if (self.scheduler is None) == (self.scheduler_file is None):
            raise ValueError("give a scheduler address or a scheduler file, one of them")


def security(ca_file: str | os.PathLike[str] | None = None, cert: str | os.PathLike[str] | None = None,
             key: str | os.PathLike[str] | None = None, require_encryption: bool = False) -> Any:
    """A :class:`distributed.Security` for a client from PEM files (None when nothing is given).

    Parameters
    ----------
    ca_file : path, optional
        The certificate authority that signed the scheduler's (and workers') certificates.
    cert : path, optional
        This client's certificate (and its key, unless ``key`` is given).
    key : path, optional
        This client's private key.
    require_encryption : bool
        Refuse any connection that is not TLS.

    Raises
    ------
    ValueError
        A TLS file given without both the CA and the certificate (Dask needs the two).
    FileNotFoundError
        A file that does not exist.
    ImportError
        Dask distributed is not installed.
    """
    if ca_file is None and cert is None and key is None and not require_encryption:
        return None
    if (ca_file, cert, key) != (None, None, None) and (ca_file is None or cert is None):
        raise ValueError("TLS needs both --tls-ca-file and --tls-cert (and --tls-key unless the certificate "
                         "file holds the key): Dask's TLS is mutual")
    for what, path in (("TLS CA file", ca_file), ("TLS certificate", cert), ("TLS key", key)):
        if path is not None and not Path(path).is_file():
            raise FileNotFoundError(f"{what} not found: {path}")
    Security = _distributed().Security
    files = {"tls_ca_file": ca_file, "tls_client_cert": cert, "tls_client_key": key}
    return Security(require_encryption=require_encryption,
                    **{k: os.fspath(v) for k, v in files.items() if v is not None})


def _distributed() -> Any:
    try:
        import distributed
    except ImportError:
        raise ImportError("a scheduler needs Dask distributed: pip install 'psmat[cluster]'") from None
    return distributed


def run_encoded(task: SessionTask) -> bytes:
    """Process one session on a worker; its result as :func:`encode_result`'s bytes (never raises)."""
    from ._task import error_rows, run_task

    try:
        return encode_result(*run_task(task))
    except Exception as exc:  # noqa: BLE001 - the client gets error rows, never a pickled exception
        return encode_result(task.stem, error_rows(task, exc), {})


def _worker() -> str:
    """The address of the Dask worker running this task ("" outside one)."""
    try:
        from distributed import get_worker

        return str(get_worker().address)
    except (ImportError, ValueError):
        return ""


def _stamped(fn: Callable[[Any], Any], task: Any) -> tuple[Any, dict[str, Any]]:
    out, took = timed(fn, task)
    return stamp(out, TaskTime(took.start, took.wall_s, took.cpu_s, took.pid, _worker()))


def run_session(task: SessionTask) -> tuple[bytes, dict[str, Any]]:
    """A session on a worker: (:func:`run_encoded`'s bytes, its time) (:func:`stamp`)."""
    return _stamped(run_encoded, task)


def run_page(task: ReportTask) -> tuple[tuple[str | None, str | None], dict[str, Any]]:
    """A subject's page on a worker: ((its HTML text, None) or (None, why not), its time); the
    worker writes nothing (:func:`psmat.study._reports.render_page`)."""
    return _stamped(render_page, task)


def run_figure(task: FigureTask) -> tuple[tuple[str, bytes], dict[str, Any]]:
    """A figure on a worker: ((its name, the PNG's bytes), its time) (:func:`draw_figure`)."""
    return _stamped(draw_figure, task)


def _client(cluster: Cluster) -> Any:
    """A client that reads results as msgpack only (see the module docstring)."""
    distributed = _distributed()
    if cluster.scheduler_file is not None and not Path(cluster.scheduler_file).is_file():
        raise FileNotFoundError(f"scheduler file not found: {cluster.scheduler_file}")
    where = cluster.scheduler or cluster.scheduler_file
    try:
        return distributed.Client(cluster.scheduler, scheduler_file=cluster.scheduler_file,
                                  security=cluster.security, deserializers=list(PLAIN_DESERIALIZERS))
    except TypeError as exc:  # distributed's words for a tls:// address without credentials
        why = (f"{' '.join(str(exc).split())} (a tls:// scheduler needs --tls-ca-file, --tls-cert and "
               "--tls-key)")
    except Exception as exc:  # noqa: BLE001 - refused, timed out, a TLS handshake that failed: one line
        # (distributed reports a failed handshake as an OSError, or, depending on timing, an
        # AssertionError from the thread of its event loop)
        why = " ".join(str(exc).split()) or type(exc).__name__
    # The client that failed is in a reference cycle. Collected later, from whatever thread the
    # collector then runs in, its __del__ stops its event loop under distributed's lock of event
    # loops; run in the new event loop thread of this process's next client, it waited 10 s for
    # the lock that client's start holds, which then failed ("AssertionError": a retry in the same
    # process, after a failed TLS handshake, with nothing allocated between). Collected here, with
    # no exception holding its frames, it stops now, on this thread.
    gc.collect()
    raise RuntimeError(f"cannot connect to the Dask scheduler {where}: {why}")


def warm_cluster(cluster: Cluster) -> Callable[[], None]:
    """Send :func:`psmat.study._warm.warm` to each of the cluster's workers now, one task pinned to
    each, without waiting: the imports a worker's first task needs (the chain's, matplotlib's for
    the figures) then pass while this process finds the sessions, instead of delaying each worker's
    first session. What is returned lets go of those tasks and closes this connection: call it once
    the run is over (a warm-up still running then, on a worker busy with another client's tasks, is
    cancelled; nothing depends on it).

    Raises
    ------
    RuntimeError, OSError
        The cluster cannot be reached, or refused the connection: raised here, before the sessions
        are found, as the sessions' own connection would raise it (:func:`_client`).
    """
    from uuid import uuid4

    from ._warm import warm

    client = _client(cluster)
    try:
        token = uuid4().hex  # a run's own keys on a cluster that others may use too
        futures = [client.submit(warm, key=f"psmat-warm-{token}-{i}", workers=[w], allow_other_workers=False,
                                 pure=False) for i, w in enumerate(client.ncores())]
    except Exception:  # noqa: BLE001 - the warm-up only saves time: the run goes on without it
        client.close()
        return lambda: None

    def release() -> None:
        for f in futures:
            f.release()
        client.close()

    return release


def _answers(client: Any, jobs: Sequence[tuple[Callable[[Any], Any], Any, str]]
             ) -> Iterator[tuple[Any, Any, TaskTime | None, Exception | None]]:
    """Each job (what the worker runs, its task, its Dask key) submitted at once; (task, result,
    time, None) as each answers with a pair that passes :func:`check_timed`, or (task, None,
    None, why) for one refused (a result not sent as msgpack, a time that fails the check) or
    lost, in the order they finish."""
    distributed = _distributed()
    futures = {client.submit(fn, task, key=key): task for fn, task, key in jobs}
    for fut in distributed.as_completed(futures):
        task = futures.pop(fut)
        try:
            result, took = check_timed(fut.result())
        except Exception as exc:  # noqa: BLE001 - a lost worker, a refused format: the run goes on
            yield task, None, None, exc
        else:
            yield task, result, took, None
        fut.release()


def _why(exc: Exception) -> Exception:
    """What a result refused by a check says; any other failure as it is."""
    return ValueError(f"the cluster's result was refused: {exc}") if isinstance(exc, ValueError) else exc


def _page(task: ReportTask, result: Any) -> str | None:
    """A page the cluster sent (``(text, None)`` or ``(None, why not)``), checked and written
    atomically here: None, or why it is not written (one line)."""
    from .._atomic import write_text_atomic
    from ..report import check_page

    if not isinstance(result, (tuple, list)) or len(result) != 2:
        raise ValueError("a page's result must be the pair (page, why not)")
    text, why = result
    if text is None and isinstance(why, str):
        return first_line(why)
    if why is not None:
        raise ValueError("a page's result holds both a page and why not")
    write_text_atomic(task.out, check_page(text))
    return None


def run_on_cluster(sessions: Sequence[SessionTask], pages: Sequence[ReportTask], cluster: Cluster,
                   fn: Callable[[SessionTask], Any] = run_session) -> Iterator[tuple[str, Any, TaskTime | None]]:
    """Sessions and per-subject pages on the cluster, submitted together: ``("session", (stem,
    rows, traces), time)`` and ``("report", (subject, why not or None), time)`` in the order they
    finish, time the task's in its worker (None when its answer was refused or lost).

    A session whose result is refused or lost gives error rows (tried again next run); a page
    is written here once checked (:func:`psmat.report.check_page`), a page refused or lost is
    ``why not``. ``fn`` is what the workers run for a session (default :func:`run_session`):
    whatever it returns must be the pair (:func:`encode_result`'s bytes, its time) to be accepted.
    """
    from ._task import error_rows

    if not sessions and not pages:
        return
    jobs = [(fn, t, f"psmat-study-{t.key}") for t in sessions]
    jobs += [(run_page, r, f"psmat-report-{r.key}") for r in pages]
    with _client(cluster) as client:
        for task, result, took, exc in _answers(client, jobs):
            if isinstance(task, ReportTask):
                try:
                    if exc is not None:
                        raise exc
                    why = _page(task, result)
                except Exception as err:  # noqa: BLE001 - refused, lost or not written: a problem line
                    err = _why(err)
                    why = first_line(str(err) if isinstance(err, ValueError) else f"{type(err).__name__}: {err}")
                yield "report", (task.subject, why), took
                continue
            try:
                if exc is not None:
                    raise exc
                out = decode_result(result, task.expect)
            except Exception as err:  # noqa: BLE001 - a lost worker, a refused format: the run goes on
                out = task.stem, error_rows(task, _why(err)), {}
            yield "session", out, took


def on_cluster(todo: Sequence[SessionTask], cluster: Cluster, fn: Callable[[SessionTask], Any] = run_session
               ) -> Iterator[tuple[str, Rows, Traces]]:
    """(stem, rows, traces) of each task run on the cluster, in the order they finish; a task
    whose result is refused, or that the cluster lost, gives error rows (tried again next run).

    ``fn`` is what the workers run (default :func:`run_session`); whatever it returns must be
    the pair (:func:`encode_result`'s bytes, its time) to be accepted (:func:`run_on_cluster`
    gives the times too).
    """
    for _, out, _ in run_on_cluster(todo, (), cluster, fn):
        yield out


def _checked_or_here(cluster: Cluster, tasks: Sequence[Any], jobs: Callable[[Any], tuple[Callable[[Any], Any], str]],
                     check: Callable[[Any, Any], Any], here: Callable[[Any], Any]
                     ) -> Iterator[tuple[Any, Any, TaskTime | None]]:
    """(task, value, time) for each task: run on the cluster (``jobs(task)``: what the worker
    runs and its Dask key) and its answer passed through ``check(task, result)``, or, when that
    answer is refused or lost, or the cluster cannot be reached, ``here(task)`` in this process."""
    if not tasks:
        return
    again: list[Any] = []
    done: set[int] = set()
    try:
        with _client(cluster) as client:
            for task, result, took, exc in _answers(client, [(fn, t, key) for t in tasks for fn, key in [jobs(t)]]):
                try:
                    if exc is not None:
                        raise exc
                    value = check(task, result)
                except Exception:  # noqa: BLE001 - refused or lost: done here below
                    again.append(task)
                    continue
                done.add(id(task))
                yield task, value, took
    except (RuntimeError, OSError):  # the cluster cannot be reached now: every task not yet had
        again = [t for t in tasks if id(t) not in done]
    for t in again:
        value, took = timed(here, t)
        yield t, value, took


def cluster_drawer(cluster: Cluster) -> DrawFigures:
    """What runs the figure tasks on the cluster (:func:`psmat.study.write_results`' ``draw``):
    each figure a task (:func:`run_figure`), its PNG checked (:func:`psmat._png.check_png`) and
    handed back to be written here; a figure refused or lost, or all of them when the cluster
    cannot be reached, drawn in this process instead (the bytes are the task's alone)."""
    from .._png import check_png

    def check(task: FigureTask, result: Any) -> tuple[str, bytes]:
        if not isinstance(result, (tuple, list)) or len(result) != 2 or result[0] != task.name:
            raise ValueError(f"not the figure {task.name}")
        return task.name, check_png(result[1])

    def draw(tasks: list[FigureTask]) -> Iterator[tuple[str, bytes, TaskTime | None]]:
        for _, (name, data), took in _checked_or_here(
                cluster, tasks, lambda t: (run_figure, f"psmat-figure-{t.name}-{t.key}"), check, draw_figure):
            yield name, data, took

    return draw


def _encoded_dynamic(task: DynamicTask) -> bytes:
    """One volunteer's SCHC-DYN on a worker as :func:`encode_dynamic`'s bytes; b"" (refused by
    the client, which then computes it) when it raised: an exception is never sent back."""
    try:
        return encode_dynamic(task, run_dynamic(task))
    except Exception:  # noqa: BLE001 - see above
        return b""


def run_dynamic_plain(task: DynamicTask) -> tuple[bytes, dict[str, Any]]:
    """One volunteer's SCHC-DYN on a worker: (:func:`_encoded_dynamic`'s bytes, its time)."""
    return _stamped(_encoded_dynamic, task)


def cluster_dynamic(cluster: Cluster) -> RunDynamic:
    """What runs SCHC-DYN's tasks (:mod:`psmat.study` (``_dynamic_tasks.py``)) on the cluster: each
    answer checked (:func:`decode_dynamic`, against the length of each session's trace read here)
    or, refused or lost, computed in this process."""
    def check(task: DynamicTask, result: Any) -> list[Answer]:
        return decode_dynamic(result, task, trace_lengths(task))

    def run(tasks: list[DynamicTask]) -> Iterator[tuple[DynamicTask, list[Answer], TaskTime | None]]:
        yield from _checked_or_here(cluster, tasks, lambda t: (run_dynamic_plain, f"psmat-dynamic-{task_key(t)}"),
                                    check, run_dynamic)

    return run

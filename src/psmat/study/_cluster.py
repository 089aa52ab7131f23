"""A study's sessions on a Dask distributed cluster (``psmat study run --scheduler``), and what
that asks you to trust.

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
* **TLS and authentication are passed through**: ``scheduler_file`` (the JSON a scheduler
  writes with ``--scheduler-file``) and a :class:`distributed.Security` (TLS CA, client
  certificate and key, ``require_encryption``; :func:`security`). Dask's TLS is mutual: the
  scheduler refuses a client without a certificate its CA signed, and the client refuses a
  scheduler whose certificate it cannot verify.

Tasks carry file paths, not file contents: the study folder must be on a filesystem the
workers share (the same path on every worker), and the workers need psmat installed.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ._plain import decode_result, encode_result
from ._trial import Rows, Traces

if TYPE_CHECKING:  # pragma: no cover
    from ._task import SessionTask

__all__ = ["PLAIN_DESERIALIZERS", "Cluster", "security", "run_encoded", "on_cluster"]

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
        raise RuntimeError(f"cannot connect to the Dask scheduler {where}: {' '.join(str(exc).split())} "
                           "(a tls:// scheduler needs --tls-ca-file, --tls-cert and --tls-key)") from None
    except Exception as exc:  # noqa: BLE001 - refused, timed out, a TLS handshake that failed: one line
        # (distributed reports a failed handshake as an OSError, or, depending on timing, an
        # AssertionError from the thread of its event loop)
        why = " ".join(str(exc).split()) or type(exc).__name__
        raise RuntimeError(f"cannot connect to the Dask scheduler {where}: {why}") from None


def on_cluster(todo: Sequence[SessionTask], cluster: Cluster, fn: Callable[[SessionTask], Any] = run_encoded
               ) -> Iterator[tuple[str, Rows, Traces]]:
    """(stem, rows, traces) of each task run on the cluster, in the order they finish; a task
    whose result is refused, or that the cluster lost, gives error rows (tried again next run).

    ``fn`` is what the workers run (default :func:`run_encoded`); whatever it returns must be
    :func:`encode_result`'s bytes to be accepted.
    """
    from ._task import error_rows

    if not todo:
        return
    distributed = _distributed()
    with _client(cluster) as client:
        futures = {client.submit(fn, t, key=f"psmat-study-{t.key}"): t for t in todo}
        for fut in distributed.as_completed(futures):
            t = futures[fut]
            try:
                out = decode_result(fut.result(), t.expect)
            except ValueError as exc:
                out = t.stem, error_rows(t, ValueError(f"the cluster's result was refused: {exc}")), {}
            except Exception as exc:  # noqa: BLE001 - a lost worker, a refused format: the run goes on
                out = t.stem, error_rows(t, exc), {}
            fut.release()
            yield out

"""Balance studies processed in batch (docs/spec.md §6 study layout, §7, §12): discovery, one
session, the whole study, its results.

* :func:`find_study` — a study folder's sessions paired with their platform files and subjects
  (:class:`StudyLayout`, :class:`StudyItem`, :class:`Subject`, :func:`read_subjects`);
* :func:`process_trial` — one session through the one chain (:func:`psmat.process.process_loaded`),
  every variant, aligned with the force platform: rows of :data:`COLUMNS` (:data:`DEFAULT_PARAMS`);
* :func:`run_study` — every session, in worker processes or on a Dask cluster (:class:`Cluster`,
  :func:`on_cluster`, :func:`security`), each kept in a cache keyed by its inputs
  (:func:`result_key`, :func:`file_sha256`, :func:`study_lock`); results cross processes as plain
  data (:func:`encode_result`, :func:`decode_result`, :class:`Expect`); the sessions handed out
  most expected work first (:func:`most_work_first`, :func:`expected_work`);
* :func:`dynamic_rows` — SCHC-DYN, a linear correction fitted on the other volunteers
  (:func:`fit_correction`; :func:`session_stats`, each session's own part of its fit;
  :func:`plan_dynamic` the fits and :func:`correct_session` one session's part, as a run splits it);
* :func:`write_results` — summary, figures and report (:func:`summary_rows`, :func:`pairwise_rows`,
  :func:`index_rows`, :func:`median_session`); :mod:`psmat.study.thesis_tables` holds the
  thesis' Tables 3.5-3.8 they are compared with.

A simulated balance study comes from :func:`psmat.synth.simulate_study`. Each part lives in a
private module (``_trial.py``, ``_run.py``, ...); the names below are the package's API.
"""

from . import thesis_tables
from ._cache import file_sha256, result_key, study_lock
from ._cluster import Cluster, on_cluster, security
from ._dynamic import DynamicPlan, correct_session, dynamic_rows, fit_correction, plan_dynamic, session_stats
from ._figures import median_session
from ._layout import StudyItem, StudyLayout, Subject, find_study, read_subjects, session_events
from ._order import expected_work, most_work_first
from ._plain import Expect, StaleEntry, decode_result, digest, encode_result, first_line, npz_text, parse_json
from ._results import write_results
from ._run import RunReport, run_study
from ._summary import index_rows, pairwise_rows, summary_rows
from ._task import SessionTask
from ._trial import COLUMNS, DEFAULT_PARAMS, METRICS, Rows, Traces, process_trial

__all__ = ["Subject", "StudyItem", "StudyLayout", "find_study", "read_subjects", "process_trial", "COLUMNS",
           "METRICS", "DEFAULT_PARAMS", "Rows", "Traces", "RunReport", "SessionTask", "run_study", "Cluster",
           "on_cluster", "security", "file_sha256", "result_key", "study_lock", "Expect", "encode_result",
           "decode_result", "digest", "first_line", "parse_json", "npz_text", "StaleEntry", "dynamic_rows",
           "fit_correction", "write_results",
           "session_stats", "plan_dynamic", "correct_session", "DynamicPlan", "summary_rows", "pairwise_rows",
           "index_rows", "median_session", "thesis_tables", "expected_work", "most_work_first", "session_events"]

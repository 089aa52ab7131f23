"""SCHC-DYN's per-session part as tasks (``psmat.study._dynamic_tasks``): the same rows and traces,
bit for bit, as :func:`psmat.study.dynamic_rows` in one process, whether a pool's other processes
or this one run them; the study's own statistics spare the plan every usable trace; and an
answer that comes back as data is refused unless it is exactly what the task asked for.

The study is built here: four volunteers, two trial types, each platform trace a random sway
(a 2 Hz low-passed random walk) and the mat's trace a gain and a lag of it plus noise, written
as a study run stores them (``.npz`` with the session's ``stats:*`` arrays)."""

from __future__ import annotations

import io
import math
import os
import pickle
from pathlib import Path

import numpy as np
import pytest
from scipy import signal

from psmat.study import COLUMNS, DEFAULT_PARAMS, dynamic_rows, session_stats
from psmat.study._cache import TraceFiles
from psmat.study._dynamic import plan_dynamic
from psmat.study._dynamic_tasks import DynamicTask, decode_dynamic, dynamic_tasks, encode_dynamic, run_dynamic
from psmat.study._plain import STATS_PREFIX
from psmat.study._run import _dynamic_runner, _with_dynamic

FS = 50.0
TRIALS = ("right-leg", "left-leg")


def _sessions(volunteers: int = 4, seconds: float = 20.0, seed: int = 5):
    rng = np.random.default_rng(seed)
    sos = signal.butter(2, 2.0, fs=FS, output="sos")
    rows, traces = [], {}
    for v in range(volunteers):
        for trial in TRIALS:
            n = int(seconds * FS)
            fp = signal.sosfilt(sos, np.cumsum(rng.standard_normal((n, 2)), axis=0), axis=0) * 0.05
            mat = 0.6 * np.roll(fp, 3, axis=0) + 1e-3 * rng.standard_normal((n, 2)) + [12.0, 20.0]
            key = (f"V{v + 1:02d}", trial)
            traces[key] = {"t_s": 30.0 + np.arange(n) / FS, "FP": fp, "SCHC": mat}
            for variant in ("FP", "SCHC"):
                rows.append({**dict.fromkeys(COLUMNS, math.nan), "subject": key[0], "trial": trial,
                             "variant": variant, "condition": "", "ispgr": "", "status": "ok"})
    return rows, traces


def _files(traces, folder: Path) -> TraceFiles:
    """Each session's traces and statistics as a study run stores them."""
    out = {}
    for (subject, trial), tr in traces.items():
        path = folder / f"{subject}_{trial}.npz"
        np.savez(path, **tr, **{STATS_PREFIX + k: v for k, v in session_stats(tr).items()})
        out[(subject, trial)] = path
    return TraceFiles(out)


@pytest.fixture(scope="module")
def study(tmp_path_factory):
    rows, traces = _sessions()
    return rows, traces, _files(traces, tmp_path_factory.mktemp("dyn"))


def _params():
    return {"preprocess": DEFAULT_PARAMS["preprocess"], "descriptors": None}


def _same(a: dict, b: dict) -> bool:
    return a.keys() == b.keys() and all(
        (isinstance(x, float) and isinstance(y, float) and math.isnan(x) and math.isnan(y)) or x == y
        for x, y in zip(a.values(), b.values()))


@pytest.mark.parametrize("pooled", [True, False])
def test_the_tasks_give_the_rows_and_traces_of_one_process_bit_for_bit(study, pooled) -> None:
    rows, traces, files = study
    ref_rows, ref_traces = dynamic_rows(rows, traces, preprocess=DEFAULT_PARAMS["preprocess"])
    assert len(ref_rows) == 8 and all(r["status"] == "ok" for r in ref_rows)
    runner = _dynamic_runner(2 if pooled else 1, None)
    took = []

    def run(tasks):
        assert len(tasks) == 4  # one per volunteer
        for task, answers, t in runner(tasks):
            took.append(t)
            yield task, answers, t

    out, merged, cpu = _with_dynamic(rows, files, _params(), run)
    dyn = [r for r in out if r["variant"] == "SCHC-DYN"]
    assert len(dyn) == 8 and all(_same(a, b) for a, b in zip(dyn, ref_rows))
    # each session's new row right after its own rows
    assert [r["variant"] for r in out[:3]] == ["FP", "SCHC", "SCHC-DYN"]
    for key, tr in ref_traces.items():
        m = merged[key]
        assert np.array_equal(m["SCHC-DYN"], tr["SCHC-DYN"]) and np.array_equal(m["t_s"], tr["t_s"])
    pids = {t.pid for t in took}
    if pooled:  # the pool's processes ran them, and their CPU time is counted
        assert os.getpid() not in pids and cpu > 0
    else:
        assert pids == {os.getpid()} and cpu == 0.0


class _Guarded(dict):
    """Traces that fail the test when one of ``guarded`` is read."""

    def __init__(self, traces, guarded) -> None:
        super().__init__(traces)
        self.guarded = set(guarded)

    def get(self, key, default=None):
        assert key not in self.guarded, f"read the trace of {key}"
        return super().get(key, default)

    def __getitem__(self, key):
        assert key not in self.guarded, f"read the trace of {key}"
        return super().__getitem__(key)


def test_trusted_statistics_spare_the_plan_every_usable_trace(study) -> None:
    rows, traces, _ = study
    stats = {k: session_stats(t) for k, t in traces.items()}
    ref = plan_dynamic(rows, traces, stats=stats)
    assert set(ref.series) == set(traces)  # untrusted: every trace read
    trusted = plan_dynamic(rows, _Guarded(traces, traces), stats=stats, trust_stats=True)
    assert trusted.series == {} and trusted.rate_hz == ref.rate_hz and list(trusted.jobs) == list(ref.jobs)
    for key, (row, corr) in trusted.jobs.items():
        assert all(np.array_equal(a, b) for a, b in zip(corr.coef, ref.jobs[key][1].coef))
    # statistics at another rate than the fitting rate: that trace alone is read and resampled
    other = dict(stats)
    key = ("V02", "left-leg")
    other[key] = {**stats[key], "rate_hz": np.array(40.0)}
    fs = float(stats[("V01", "right-leg")]["rate_hz"])  # the others' own rate (50 Hz up to round-off)
    rates = plan_dynamic(rows, _Guarded(traces, set(traces) - {key}), stats=other, trust_stats=True, rate_hz=fs)
    assert set(rates.series) == {key}
    # a session without statistics is read to learn whether it is usable
    missing = {k: v for k, v in stats.items() if k != key}
    assert set(plan_dynamic(rows, traces, stats=missing, trust_stats=True).series) == {key}


def _task(study) -> tuple[DynamicTask, dict[str, int]]:
    rows, traces, files = study
    plan = plan_dynamic(rows, files, stats={k: files.stats(k) for k in files}, trust_stats=True)
    task = dynamic_tasks(plan, {k: files.path(k) for k in plan.jobs}, preprocess=DEFAULT_PARAMS["preprocess"])[1]
    return task, {trial: traces[(task.subject, trial)]["t_s"].size for trial, *_ in task.sessions}


def test_an_answer_as_data_reads_back_exactly(study) -> None:
    task, lengths = _task(study)
    answers = run_dynamic(task)
    back = decode_dynamic(encode_dynamic(task, answers), task, lengths)
    assert [(t, c.tobytes()) for t, _, c in back] == [(t, c.tobytes()) for t, _, c in answers]
    assert all(_same(a[1], b[1]) for a, b in zip(back, answers))
    # a session whose trace was not usable comes back without a trace, its row saying why
    bad = [(answers[0][0], {**answers[0][1], "status": "not corrected: no aligned SCHC and platform traces"}, None),
           answers[1]]
    assert decode_dynamic(encode_dynamic(task, bad), task, lengths)[0][2] is None


def _npz(**arrays) -> bytes:
    buf = io.BytesIO()
    np.savez(buf, **arrays)
    return buf.getvalue()


def test_answers_that_are_not_what_the_task_asked_for_are_refused(study) -> None:
    task, lengths = _task(study)
    answers = run_dynamic(task)
    (t0, r0, c0), second = answers

    def refused(bad, match: str) -> None:
        with pytest.raises(ValueError, match=match):
            decode_dynamic(encode_dynamic(task, bad) if isinstance(bad, list) else bad, task, lengths)

    refused([(t0, {**r0, "subject": "V09"}, c0), second], "not SCHC-DYN of")
    refused([(t0, {**r0, "trial": second[0]}, c0), second], "not SCHC-DYN of")
    refused([(t0, {**r0, "variant": "SCHC"}, c0), second], "not SCHC-DYN of")
    refused([(t0, {**r0, "condition": "eyes closed"}, c0), second], "not SCHC-DYN of")
    refused([(t0, {**r0, "status": "error: boom"}, c0), second], "status")
    refused([(t0, {**r0, "eu_cm": "small"}, c0), second], "eu_cm is not a finite number")
    refused([(t0, {**r0, "whim": 1.0}, c0), second], "exactly the columns")
    refused([(t0, r0, c0[:-1]), second], "shape")
    refused([(t0, r0, None), second], "shape")
    refused([(t0, {**r0, "status": "not corrected: no fit"}, c0), second], "no row corrected")
    refused([answers[0]], "1 rows for 2 sessions")
    refused(b"not an npz", "not a result file")
    refused(pickle.dumps(answers), "not a result file")
    refused(_npz(__result__=np.array([object()], dtype=object)), "not a result file")
    other = DynamicTask("V09", task.sessions, task.rate_hz, task.base, task.preprocess, task.descriptors)
    refused(encode_dynamic(other, answers), "a result for 'V09'")
    with pytest.raises(ValueError, match="must be bytes"):
        decode_dynamic({"rows": []}, task, lengths)

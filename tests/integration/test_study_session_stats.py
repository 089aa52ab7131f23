"""Each session's own part of the SCHC-DYN fit is formed in its task and stored with its result.

A small simulated study (two volunteers, right-leg and left-leg, 4 s at 50 Hz, PROP and SCHC)
is run; each stored ``.npz`` must hold ``stats:*`` arrays equal, bit for bit, to the
statistics the study-level step formed itself before they were formed in the task: the
session's stored SCHC and platform traces resampled at its rate (the study's fitting rate, the
median of the sessions' rates, where the two are the same), mean-removed, and ``(WᵀW, Wᵀy)``
of their lag windows per axis.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from small_study import two_trial_study

from psmat.study import Expect, run_study
from psmat.study._dynamic import _fir_half, _fir_stats, _series
from psmat.study._plain import check_traces

PARAMS = {"variants": ["PROP", "SCHC"]}


@pytest.fixture(scope="module")
def study(tmp_path_factory):
    root = two_trial_study(tmp_path_factory.mktemp("stats") / "study", duration_s=4.0, seed=12)
    report = run_study(root, workers=1, params=PARAMS, progress=False)
    assert report.computed == 4 and report.failed == 0, str(report)
    return root


def _stored(root) -> dict[str, dict[str, np.ndarray]]:
    out = {}
    for entry in sorted((root / "results" / "sessions").glob("*.json")):
        doc = json.loads(entry.read_text())
        with np.load(entry.parent / doc["traces"]) as z:
            out[entry.stem] = {k: z[k] for k in z.files}
    return out


def test_the_tasks_statistics_equal_those_formed_after_the_sessions(study) -> None:
    stored = _stored(study)
    assert len(stored) == 4
    series = {stem: _series({k: v for k, v in z.items() if not k.startswith("stats:")}, "SCHC")
              for stem, z in stored.items()}
    assert not any(isinstance(s, str) for s in series.values())
    rates = {stem: float(1.0 / np.median(np.diff(s.t))) for stem, s in series.items()}
    for stem, s in series.items():
        z = stored[stem]
        assert float(z["stats:rate_hz"]) == rates[stem]  # each session's own rate
        s.resample(rates[stem])
        half = _fir_half(0.1, rates[stem])
        for a in range(2):
            gram, rhs = _fir_stats(s.x[:, a], s.y[:, a], half)
            assert np.array_equal(z["stats:gram"][a], gram), (stem, a)
            assert np.array_equal(z["stats:rhs"][a], rhs), (stem, a)


def test_a_rerun_reuses_the_stored_statistics_and_gives_the_same_metrics(study) -> None:
    before = (study / "results" / "metrics.csv").read_bytes()
    report = run_study(study, workers=1, params=PARAMS, progress=False)
    assert report.reused == 4 and report.computed == 0 and not report.problems
    assert (study / "results" / "metrics.csv").read_bytes() == before
    assert b"SCHC-DYN" in before


def test_statistics_cross_the_plain_data_check_and_bad_ones_do_not() -> None:
    expect = Expect("V01_right-leg", "V01", "right-leg", ("SCHC",))
    t = np.arange(5.0)
    ok = check_traces({"t_s": t, "SCHC": np.zeros((5, 2)), "stats:gram": np.zeros((2, 3, 3))}, expect)
    assert set(ok) == {"t_s", "SCHC", "stats:gram"}
    with pytest.raises(ValueError, match="dtype"):
        check_traces({"t_s": t, "stats:gram": np.zeros((2, 3, 3), np.float32)}, expect)
    with pytest.raises(ValueError, match="at most 3"):
        check_traces({"t_s": t, "stats:gram": np.zeros((1, 2, 3, 3))}, expect)
    with pytest.raises(ValueError, match="not FP or a variant"):
        check_traces({"t_s": t, "gram": np.zeros((2, 3, 3))}, expect)

"""SCHC-DYN's answers kept between runs (``results/dynamic``, psmat.study._dynamic_cache): a rerun
with nothing changed computes no volunteer's correction again and writes the same ``metrics.csv``;
a stored answer that fails its check is computed again and said; a changed session computes every
volunteer again (each is fitted on the others); a run stopped after some volunteers keeps theirs.

A simulated study of three volunteers (4 s trials at 50 Hz) is run once in this process; each
test works on a copy. Which volunteers a run corrects is seen by wrapping the function that
corrects one (it still runs: the wrapper only counts). A stored file's digest is recomputed here
from its documented definition (SHA-256 over each part's length as 8 bytes big-endian, then the
part), not with psmat's function."""

from __future__ import annotations

import csv
import hashlib
import io
import shutil
from pathlib import Path

import numpy as np
import pytest

import psmat.study._run as run_module
from psmat.study import run_study
from psmat.study._dynamic_tasks import encode_dynamic, run_dynamic
from psmat.synth import simulate_study

SUBJECTS = ("V01", "V02", "V03")


@pytest.fixture(scope="module")
def study(tmp_path_factory) -> tuple[Path, bytes]:
    root = simulate_study(tmp_path_factory.mktemp("dyn") / "study", volunteers=len(SUBJECTS), duration_s=4.0,
                          seed=9, rate_hz=50.0)
    report = run_study(root, workers=1, progress=False)
    assert (report.failed, report.problems) == (0, []), report
    return root, (root / "results" / "metrics.csv").read_bytes()


@pytest.fixture
def corrected(monkeypatch) -> list[str]:
    """The volunteers whose SCHC-DYN a run computes in this process (the real function, counted)."""
    seen: list[str] = []

    def counted(task):
        seen.append(task.subject)
        return run_dynamic(task)

    monkeypatch.setattr(run_module, "run_dynamic", counted)
    return seen


def _copy(study, dst: Path) -> Path:
    return Path(shutil.copytree(study[0], dst))


def _after_sessions(root: Path) -> tuple[str, str]:
    with open(root / "results" / "timings.csv", newline="") as fh:
        row = next(r for r in csv.DictReader(fh) if r["stage"] == "after_sessions")
    return row["computed"], row["reused"]


def _file(root: Path, subject: str) -> Path:
    return root / "results" / "dynamic" / f"{hashlib.sha256(subject.encode()).hexdigest()[:16]}.npz"


def _digest(*parts: bytes) -> str:
    h = hashlib.sha256()
    for p in parts:
        h.update(len(p).to_bytes(8, "big"))
        h.update(p)
    return h.hexdigest()


def _entries(path: Path) -> dict[str, np.ndarray]:
    with np.load(path, allow_pickle=False) as z:
        return {k: z[k] for k in z.files}


def _write(path: Path, key: str, answer: bytes, digest: str | None = None) -> None:
    buf = io.BytesIO()
    np.savez(buf, key=np.array(key), answer=np.frombuffer(answer, np.uint8),
             digest=np.array(digest if digest is not None else _digest(key.encode(), answer)))
    path.write_bytes(buf.getvalue())


def test_a_rerun_reads_every_volunteers_answer_back_and_computes_none(study, tmp_path, corrected) -> None:
    root = _copy(study, tmp_path / "s")
    assert sorted(p.name for p in (root / "results" / "dynamic").iterdir()) == sorted(
        _file(root, s).name for s in SUBJECTS)
    for s in SUBJECTS:  # each file as documented: key, answer bytes, their digest
        e = _entries(_file(root, s))
        assert set(e) == {"key", "answer", "digest"} and e["answer"].dtype == np.uint8
        assert str(e["digest"]) == _digest(str(e["key"]).encode(), e["answer"].tobytes())
    report = run_study(root, workers=1, progress=False)
    assert corrected == [] and report.problems == []
    assert (root / "results" / "metrics.csv").read_bytes() == study[1]
    assert _after_sessions(root) == ("0", "3")
    assert any(r["variant"] == "SCHC-DYN" and r["status"] == "ok"
               for r in csv.DictReader(io.StringIO(study[1].decode())))


def _truncated(root: Path, subject: str) -> None:
    p = _file(root, subject)
    p.write_bytes(p.read_bytes()[: p.stat().st_size // 2])


def _answer_edited(root: Path, subject: str) -> None:
    # one byte of the answer changed, the stored digest kept
    e = _entries(_file(root, subject))
    answer = bytearray(e["answer"].tobytes())
    answer[len(answer) // 2] ^= 0x01
    _write(_file(root, subject), str(e["key"]), bytes(answer), str(e["digest"]))


def _another_volunteers_answer(root: Path, subject: str) -> None:
    # V02's answer under V01's key, with a digest that matches: the check of the answer refuses it
    own, other = _entries(_file(root, subject)), _entries(_file(root, "V02"))
    _write(_file(root, subject), str(own["key"]), other["answer"].tobytes())


def _an_extra_entry(root: Path, subject: str) -> None:
    e = _entries(_file(root, subject))
    buf = io.BytesIO()
    np.savez(buf, **e, extra=np.zeros(3))
    _file(root, subject).write_bytes(buf.getvalue())


@pytest.mark.parametrize("spoil, why", [
    (_truncated, "not used ("),
    (_answer_edited, "digest mismatch"),
    (_another_volunteers_answer, "a result for 'V02', expected 'V01'"),
    (_an_extra_entry, "entries ["),
])
def test_an_answer_that_fails_its_check_is_computed_again_and_said(study, tmp_path, corrected, spoil, why) -> None:
    root = _copy(study, tmp_path / "s")
    spoil(root, "V01")
    report = run_study(root, workers=1, progress=False)
    assert corrected == ["V01"]
    [problem] = report.problems
    assert problem.startswith(f"V01: stored SCHC-DYN answer dynamic/{_file(root, 'V01').name} not used (")
    assert why in problem and problem.endswith("computed again")
    assert (root / "results" / "metrics.csv").read_bytes() == study[1]
    assert _after_sessions(root) == ("1", "2")
    again = run_study(root, workers=1, progress=False)  # rewritten: trusted again
    assert (corrected, again.problems) == (["V01"], [])


def test_a_stored_answer_that_leads_outside_the_results_is_not_read(study, tmp_path, corrected) -> None:
    root = _copy(study, tmp_path / "s")
    outside = tmp_path / "outside.npz"
    shutil.copyfile(_file(root, "V01"), outside)
    _file(root, "V01").unlink()
    _file(root, "V01").symlink_to(outside)
    report = run_study(root, workers=1, progress=False)
    assert corrected == ["V01"]
    [problem] = report.problems
    assert "it leads outside" in problem and "not read" in problem
    assert not _file(root, "V01").is_symlink()  # replaced by a file of its own
    assert (root / "results" / "metrics.csv").read_bytes() == study[1]


def test_a_changed_volunteer_computes_every_volunteer_again(study, tmp_path, corrected) -> None:
    # V01's weight changes its SCHC traces, so the fits of V02 and V03 (made on the others) too
    root = _copy(study, tmp_path / "s")
    subjects = root / "subjects.csv"
    lines = subjects.read_text().splitlines()
    header = lines[0].split(",")
    w = header.index("weight_kg")
    for i, line in enumerate(lines):
        fields = line.split(",")
        if fields[0] == "V01":
            fields[w] = f"{float(fields[w]) + 5.0:.1f}"
            lines[i] = ",".join(fields)
    subjects.write_text("\n".join(lines) + "\n")
    report = run_study(root, workers=1, progress=False)
    assert report.problems == []
    assert sorted(corrected) == sorted(SUBJECTS)
    assert _after_sessions(root) == ("3", "0")
    assert (root / "results" / "metrics.csv").read_bytes() != study[1]


def test_a_run_stopped_during_the_corrections_keeps_those_it_finished(study, tmp_path, monkeypatch) -> None:
    root = _copy(study, tmp_path / "s")
    shutil.rmtree(root / "results" / "dynamic")
    done: list[str] = []

    def stopped_at_the_second(task):
        if done:
            raise KeyboardInterrupt
        done.append(task.subject)
        return run_dynamic(task)

    monkeypatch.setattr(run_module, "run_dynamic", stopped_at_the_second)
    with pytest.raises(KeyboardInterrupt):
        run_study(root, workers=1, progress=False)
    assert [p.name for p in (root / "results" / "dynamic").iterdir()] == [_file(root, done[0]).name]
    (root / "results" / "dynamic" / ".tmp-half").write_bytes(b"PK")  # as a write killed midway leaves
    seen: list[str] = []
    monkeypatch.setattr(run_module, "run_dynamic", lambda task: (seen.append(task.subject), run_dynamic(task))[1])
    report = run_study(root, workers=1, progress=False)
    assert report.problems == [f"removed 1 incomplete temporary file(s) an interrupted run left in "
                               f"{root / 'results' / 'dynamic'}"]
    assert sorted(seen) == sorted(set(SUBJECTS) - set(done))
    assert sorted(p.name for p in (root / "results" / "dynamic").iterdir()) == sorted(
        _file(root, s).name for s in SUBJECTS)
    assert (root / "results" / "metrics.csv").read_bytes() == study[1]


def test_the_stored_answer_is_the_answer_the_task_gives(study, tmp_path, monkeypatch) -> None:
    # each volunteer's file holds encode_dynamic's bytes of its task's answers, under the task's
    # key: the tasks a run hands out, seen where they run
    from psmat.study._dynamic_cache import DynamicStore

    root = _copy(study, tmp_path / "s")
    shutil.rmtree(root / "results" / "dynamic")
    tasks = []
    monkeypatch.setattr(run_module, "run_dynamic", lambda task: (tasks.append(task), run_dynamic(task))[1])
    run_study(root, workers=1, progress=False)
    store = DynamicStore(root / "results")
    assert sorted(t.subject for t in tasks) == sorted(SUBJECTS)
    for task in tasks:
        e = _entries(_file(root, task.subject))
        assert str(e["key"]) == store.key(task)
        assert e["answer"].tobytes() == encode_dynamic(task, run_dynamic(task))

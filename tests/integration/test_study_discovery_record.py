"""A rerun finds its sessions from ``results/.discovery.json`` (what an earlier run read from each
session file, kept by the SHA-256 of the file's bytes) and reads again only the files whose bytes,
journal or record changed.

A small simulated study (two volunteers, right-leg and left-leg, 2 s at 50 Hz, the variant PROP)
is run once in this process; each test works on a copy. Which files a run reads is seen by
wrapping the function that opens a session file's metadata (it still runs: the wrapper only counts);
the record's digest is recomputed here from its documented definition (docs: the module
``psmat.study._discovery``), not with psmat's function.
"""

from __future__ import annotations

import hashlib
import json
import shutil
from pathlib import Path

import h5py
import pytest
from small_study import first_run, two_trial_study

import psmat.study._layout as layout_module
from psmat import __version__
from psmat.study import run_study
from psmat.study._hashes import FileHashes

PARAMS = {"variants": ["PROP"]}
NAMES = ("V01_left-leg.h5", "V01_right-leg.h5", "V02_left-leg.h5", "V02_right-leg.h5")


@pytest.fixture(scope="module")
def study(tmp_path_factory) -> tuple[Path, bytes]:
    root = two_trial_study(tmp_path_factory.mktemp("found") / "study", duration_s=2.0, seed=5)
    return root, first_run(root, PARAMS)


@pytest.fixture
def reads(monkeypatch) -> list[str]:
    """The names of the session files whose metadata a run reads (the real reader, counted)."""
    seen: list[str] = []
    real = layout_module._session_meta

    def counted(path: Path):
        seen.append(path.name)
        return real(path)

    monkeypatch.setattr(layout_module, "_session_meta", counted)
    return seen


def _copy(root: Path, dst: Path) -> Path:
    shutil.copytree(root, dst)
    return dst


def _digest(doc: dict) -> str:
    """sha256(len(c) as 8 bytes, big-endian || c), c the canonical JSON of every field but the digest."""
    c = json.dumps({k: v for k, v in doc.items() if k != "digest"}, sort_keys=True, separators=(",", ":"),
                   allow_nan=False).encode()
    return hashlib.sha256(len(c).to_bytes(8, "big") + c).hexdigest()


def _record(copy: Path) -> tuple[Path, dict]:
    path = copy / "results" / ".discovery.json"
    return path, json.loads(path.read_text())


def test_a_rerun_reads_no_session_file_it_has_seen(study, reads, tmp_path) -> None:
    root, metrics = study
    copy = _copy(root, tmp_path / "s")
    path, doc = _record(copy)
    assert doc["psmat"] == __version__ and sorted(doc["entries"]) == sorted(NAMES)
    assert doc["digest"] == _digest(doc)
    for name, e in doc["entries"].items():  # what was read, by the file's bytes
        assert e["sha256"] == hashlib.sha256((copy / "sessions" / name).read_bytes()).hexdigest()
        assert (e["subject"], e["trial"]) == tuple(name[:-3].split("_"))
        assert e["simulated"] is True and e["circuit"]["r_o_ohm"] > 0
    before = path.read_bytes()
    report = run_study(copy, workers=1, progress=False, params=PARAMS)
    assert reads == []
    assert (report.computed, report.reused, report.problems) == (0, 4, [])
    assert (copy / "results" / "metrics.csv").read_bytes() == metrics
    assert path.read_bytes() == before  # nothing new: not rewritten


def test_the_record_gives_what_reading_the_files_gives(study, reads, tmp_path) -> None:
    """The sessions' order, keys and rows are the same with the record as from the files: the run
    without the record (deleted) computes nothing new and writes the same record."""
    root, metrics = study
    copy = _copy(root, tmp_path / "s")
    path, doc = _record(copy)
    path.unlink()
    report = run_study(copy, workers=1, progress=False, params=PARAMS)
    assert sorted(reads) == sorted(NAMES)
    assert (report.computed, report.reused, report.problems) == (0, 4, [])
    assert _record(copy)[1] == doc


def test_a_session_whose_bytes_changed_is_read_again(study, reads, tmp_path) -> None:
    root, _ = study
    copy = _copy(root, tmp_path / "s")
    session = copy / "sessions" / "V01_left-leg.h5"
    with h5py.File(session, "r+") as f:  # the subject in its metadata, as a typo would have it
        meta = json.loads(f["metadata"].attrs["json"])
        meta["subject"] = "V09"
        f["metadata"].attrs["json"] = json.dumps(meta)
    report = run_study(copy, workers=1, progress=False, params=PARAMS)
    assert reads == ["V01_left-leg.h5"]
    assert any("subject 'V09' is not in subjects.csv" in p for p in report.problems)
    assert _record(copy)[1]["entries"]["V01_left-leg.h5"]["subject"] == "V09"
    reads.clear()
    run_study(copy, workers=1, progress=False, params=PARAMS)
    assert reads == []


def test_an_edited_record_is_not_used_and_the_run_says_so(study, reads, tmp_path) -> None:
    root, metrics = study
    copy = _copy(root, tmp_path / "s")
    path, doc = _record(copy)
    doc["entries"]["V02_left-leg.h5"]["subject"] = "V01"  # the digest left as it was
    path.write_text(json.dumps(doc))
    report = run_study(copy, workers=1, progress=False, params=PARAMS)
    assert sorted(reads) == sorted(NAMES)
    assert report.problems == [f"{path} not used (its digest does not match: edited or damaged); every "
                               "session's metadata read again"]
    assert (copy / "results" / "metrics.csv").read_bytes() == metrics
    assert _record(copy)[1]["entries"]["V02_left-leg.h5"]["subject"] == "V02"  # written again from the file


@pytest.mark.parametrize("field, value, why", [
    ("sha256", "not a hash", "no SHA-256"),
    ("simulated", "yes", "simulated and uncalibrated are true or false"),
    ("subject", 7, "subject, trial and serial are text or null"),
    ("circuit", {"r_o_ohm": 2200.0}, "not a circuit"),
])
def test_a_record_whose_entry_does_not_check_out_is_not_used(study, reads, tmp_path, field, value, why) -> None:
    """A forged record (its digest made to match) with an entry that is not what a run writes."""
    root, _ = study
    copy = _copy(root, tmp_path / "s")
    path, doc = _record(copy)
    doc["entries"]["V01_right-leg.h5"][field] = value
    doc["digest"] = _digest(doc)
    path.write_text(json.dumps(doc))
    report = run_study(copy, workers=1, progress=False, params=PARAMS)
    assert sorted(reads) == sorted(NAMES)
    assert len(report.problems) == 1 and "entry 'V01_right-leg.h5': " + why in report.problems[0]


def test_a_record_of_another_psmat_is_quietly_read_again(study, reads, tmp_path) -> None:
    root, _ = study
    copy = _copy(root, tmp_path / "s")
    path, doc = _record(copy)
    doc["psmat"] = "0.0.1"
    doc["digest"] = _digest(doc)
    path.write_text(json.dumps(doc))
    report = run_study(copy, workers=1, progress=False, params=PARAMS)
    assert sorted(reads) == sorted(NAMES) and report.problems == []
    assert _record(copy)[1]["psmat"] == __version__


def test_a_session_with_a_journal_beside_it_is_read_every_time(study, reads, tmp_path) -> None:
    """A journal may make a finished file another recording's to repair: never taken from the record."""
    root, _ = study
    copy = _copy(root, tmp_path / "s")
    journal = copy / "sessions" / "V02_right-leg.h5.journal"
    journal.write_bytes(b"not a journal")
    for _ in range(2):
        reads.clear()
        run_study(copy, workers=1, progress=False, params=PARAMS)
        assert reads == ["V02_right-leg.h5"]
    assert "V02_right-leg.h5" not in _record(copy)[1]["entries"]
    journal.unlink()
    reads.clear()
    run_study(copy, workers=1, progress=False, params=PARAMS)
    assert reads == ["V02_right-leg.h5"]  # once more, then from the record
    reads.clear()
    run_study(copy, workers=1, progress=False, params=PARAMS)
    assert reads == []


# ------------------------------------------------------------------ the hashes ahead
def test_hashes_ahead_are_the_files_sha256_and_a_write_since_is_seen(tmp_path) -> None:
    a, b, c = (tmp_path / n for n in ("a.bin", "b.bin", "c.bin"))
    a.write_bytes(b"x" * 3_000_000)
    b.write_bytes(b"")
    c.write_bytes(b"late")
    with FileHashes([a, b, tmp_path / "missing.h5"], threads=2) as hashes:
        assert hashes.sha(a) == hashlib.sha256(b"x" * 3_000_000).hexdigest()
        assert hashes.sha(b) == hashlib.sha256(b"").hexdigest()
        assert hashes.sha(tmp_path / "missing.h5") is None
        assert hashes.sha(None) is None
        assert hashes.sha(c) == hashlib.sha256(b"late").hexdigest()  # not started ahead: hashed when asked
        assert (hashes.ahead, hashes.late) == (3, 1)
        assert hashes.unchanged(a) and not hashes.unchanged(c) and not hashes.unchanged(tmp_path / "missing.h5")
        with open(a, "ab") as fh:  # written to since its hash started
            fh.write(b"y")
        assert not hashes.unchanged(a) and hashes.unchanged(b)
    with pytest.raises(ValueError, match="threads must be >= 1"):
        FileHashes([], threads=0)


def test_a_record_that_cannot_be_read_or_written_costs_only_its_time(study, reads, tmp_path) -> None:
    root, metrics = study
    copy = _copy(root, tmp_path / "s")
    path, _ = _record(copy)
    path.unlink()
    path.mkdir()  # neither readable nor replaceable as a file
    report = run_study(copy, workers=1, progress=False, params=PARAMS)
    assert sorted(reads) == sorted(NAMES)
    assert len(report.problems) == 2
    assert report.problems[0].startswith(f"{path} not used (") and report.problems[0].endswith("read again")
    assert report.problems[1].startswith(f"{path} not written (") and "reads every session's metadata again" in \
        report.problems[1]
    assert (report.computed, report.reused) == (0, 4)
    assert (copy / "results" / "metrics.csv").read_bytes() == metrics


def test_a_record_too_large_is_not_read(study, reads, tmp_path, monkeypatch) -> None:
    import psmat.study._discovery as discovery

    root, _ = study
    copy = _copy(root, tmp_path / "s")
    path, _ = _record(copy)
    monkeypatch.setattr(discovery, "MAX_BYTES", path.stat().st_size - 1)
    report = run_study(copy, workers=1, progress=False, params=PARAMS)
    assert sorted(reads) == sorted(NAMES)
    assert report.problems == [f"{path} not used (larger than {path.stat().st_size - 1} bytes, which no record "
                               "of a study is); every session's metadata read again"]


def test_a_hash_dropped_before_it_started_is_made_when_asked(tmp_path) -> None:
    files = [tmp_path / f"{k}.bin" for k in range(20)]
    for k, p in enumerate(files):
        p.write_bytes(bytes([k]) * 2_000_000)
    hashes = FileHashes(files, threads=1)
    hashes.close()  # those not started yet (one thread, 2 ms a file) are dropped
    assert [hashes.sha(p) for p in files] == [hashlib.sha256(p.read_bytes()).hexdigest() for p in files]
    assert hashes.late >= 1 and hashes.ahead + hashes.late == 20


def test_the_sessions_a_journal_lies_beside(tmp_path) -> None:
    from psmat.study._discovery import _journalled

    for name in ("a.h5.journal", "b.h5.imu.journal", "c.h5x.journal", "d.h5.h5.journal", "e.h5", "f.journal"):
        (tmp_path / name).write_bytes(b"")
    # its own journal, a stream's, and for d both d.h5 and d.h5.h5 (either may own it); not c.h5x's
    assert _journalled(tmp_path) == {"a.h5", "b.h5", "d.h5", "d.h5.h5"}
    assert _journalled(tmp_path / "missing") == set()

"""Stored results are proven before they are used, and a cluster's results come back as data.

A small simulated balance study (two volunteers, right-leg and left-leg, 4 s at 50 Hz, the
variants PROP and SCHC) is run once in this process; its ``metrics.csv`` is the reference.
Each tampering with ``results/`` (an edited digit, no rows, a traces path leaving the folder, a
corrupt ``.npz``, links to files outside, edited outputs) must be recomputed with a note and give
the reference bytes again; a file outside ``results/`` is watched with an audit hook
(:func:`sys.addaudithook`, the interpreter's own record of every ``open``) and must never be
opened. The digest of an entry is recomputed here from its documented definition
(:mod:`psmat.study` (``_cache.py``)), not with psmat's function, to forge entries that only the other
checks can refuse. The posture input cache is tampered with likewise. A real Dask cluster on
127.0.0.1 with TLS (throwaway credentials from ``distributed.Security.temporary``) runs the study
through its scheduler file and gives the same bytes; a worker sending a pickle is refused. A
task's time and a figure come back as data, checked (a PNG built here by hand from its
specification is accepted, each damage to it refused); the cluster's figures are the bytes this
process draws, and a figure a worker sends as a pickle is refused, never unpickled, and drawn
here instead; likewise each volunteer's SCHC-DYN corrections, computed here when refused.
"""

from __future__ import annotations

import csv
import hashlib
import json
import os
import pickle
import re
import shutil
import struct
import sys
import zlib
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
from dask_cluster import LOOPBACK_HTTP
from small_study import first_run, two_trial_study

from psmat.study import run_study

PARAMS = {"variants": ["PROP", "SCHC"]}
STEMS = ("V01_right-leg", "V01_left-leg", "V02_right-leg", "V02_left-leg")


# ------------------------------------------------------------------ watching what is opened
class _Opens:
    """Paths opened (``open`` audit events) that resolve, at the moment of opening, into a
    watched folder. Audit hooks cannot be removed: one for the module, armed on demand."""

    def __init__(self) -> None:
        self.folders: tuple[str, ...] = ()
        self.seen: list[str] = []

    def __call__(self, event: str, args: tuple) -> None:
        if event != "open" or not self.folders or not args or isinstance(args[0], int) or args[0] is None:
            return
        try:
            real = os.path.realpath(os.fsdecode(args[0]))
        except (TypeError, ValueError, OSError):
            return
        if real.startswith(self.folders):
            self.seen.append(real)

    def watching(self, *folders: Path) -> _Opens:
        self.folders = tuple(os.path.realpath(f) + os.sep for f in folders)
        self.seen = []
        return self

    def __enter__(self) -> _Opens:
        return self

    def __exit__(self, *exc: object) -> None:
        self.folders = ()


_OPENS = _Opens()
sys.addaudithook(_OPENS)


# ------------------------------------------------------------------ the study
@pytest.fixture(scope="module")
def study(tmp_path_factory) -> tuple[Path, bytes]:
    root = two_trial_study(tmp_path_factory.mktemp("trust") / "study", duration_s=4.0, seed=12)
    return root, first_run(root, PARAMS)


def _copy(root: Path, dst: Path, results: bool = True) -> Path:
    shutil.copytree(root, dst, ignore=None if results else shutil.ignore_patterns("results"))
    return dst


def _doc(copy: Path, stem: str) -> tuple[Path, dict]:
    path = copy / "results" / "sessions" / f"{stem}.json"
    return path, json.loads(path.read_text())


def _forged(doc: dict) -> str:
    """The entry with its digest recomputed as documented: sha256(8-byte big-endian length || c),
    c the canonical JSON (sorted keys, no spaces) of every other field."""
    c = json.dumps({k: v for k, v in doc.items() if k != "digest"}, sort_keys=True, separators=(",", ":"),
                   allow_nan=False).encode()
    return json.dumps({**doc, "digest": hashlib.sha256(len(c).to_bytes(8, "big") + c).hexdigest()})


def _notes(problems: list[str]) -> dict[str, str]:
    """{stem: the note on its stored result}."""
    out = {}
    for line in problems:
        stem, _, rest = line.partition(": ")
        if rest.startswith("stored result"):
            out[stem] = rest
    return out


def _run(copy: Path):
    return run_study(copy, workers=1, progress=False, params=PARAMS)


def test_edited_or_corrupt_results_are_recomputed_with_a_note(study, tmp_path) -> None:
    root, metrics = study
    copy = _copy(root, tmp_path / "edited")
    outside = tmp_path / "outside"
    outside.mkdir()
    (outside / "traces.npz").write_bytes(b"not an npz: a run that read this as traces would break")
    # V01_right-leg: one digit of sd_ml_cm, 0.x -> 9.x, in the JSON as a text editor would
    p, _ = _doc(copy, "V01_right-leg")
    text, n = re.subn(r'("sd_ml_cm": )0\.', r"\g<1>9.", p.read_text(), count=1)
    assert n == 1
    p.write_text(text)
    # V01_left-leg: no rows at all
    p, doc = _doc(copy, "V01_left-leg")
    p.write_text(json.dumps({**doc, "rows": []}))
    # V02_right-leg: its traces path leaves the results folder
    p, doc = _doc(copy, "V02_right-leg")
    p.write_text(json.dumps({**doc, "traces": os.path.relpath(outside / "traces.npz", p.parent)}))
    # V02_left-leg: its traces file cut in half
    p, doc = _doc(copy, "V02_left-leg")
    npz = p.parent / doc["traces"]
    npz.write_bytes(npz.read_bytes()[: npz.stat().st_size // 2])
    with _OPENS.watching(outside) as opens:
        report = _run(copy)
    assert opens.seen == []
    assert (report.computed, report.reused, report.failed) == (4, 0, 0)
    assert (copy / "results" / "metrics.csv").read_bytes() == metrics
    notes = _notes(report.problems)
    assert set(notes) == set(STEMS)
    assert all(n.endswith("recomputed") for n in notes.values())
    for stem in ("V01_right-leg", "V01_left-leg", "V02_right-leg"):
        assert "digest mismatch" in notes[stem], notes[stem]
    assert "V02_left-leg.json not used (its traces file" in notes["V02_left-leg"]
    assert "changed after it was written" in notes["V02_left-leg"]
    assert "V01_left-leg: stored result V01_left-leg.json not used" in (copy / "results" / "report.md").read_text()
    # rewritten whole: the next run trusts them again
    again = _run(copy)
    assert (again.computed, again.reused, again.problems) == (0, 4, [])
    assert (copy / "results" / "metrics.csv").read_bytes() == metrics


def test_entries_with_a_valid_digest_are_still_checked_and_never_lead_outside(study, tmp_path) -> None:
    root, metrics = study
    copy = _copy(root, tmp_path / "forged")
    sessions = copy / "results" / "sessions"
    outside = tmp_path / "outside"
    outside.mkdir()
    sentinel = outside / "traces.npz"
    sentinel.write_bytes(b"not an npz: a run that read this as traces would break")
    sha = hashlib.sha256(sentinel.read_bytes()).hexdigest()
    # V01_right-leg: no rows, digest recomputed
    p, doc = _doc(copy, "V01_right-leg")
    p.write_text(_forged({**doc, "rows": []}))
    # V01_left-leg: traces named outside (its digest and the sentinel's SHA-256 made to match)
    p, doc = _doc(copy, "V01_left-leg")
    p.write_text(_forged({**doc, "traces": os.path.relpath(sentinel, sessions), "traces_sha256": sha}))
    # V02_right-leg: its traces file a link to the sentinel (SHA-256 and digest made to match)
    p, doc = _doc(copy, "V02_right-leg")
    (sessions / doc["traces"]).unlink()
    (sessions / doc["traces"]).symlink_to(sentinel)
    p.write_text(_forged({**doc, "traces_sha256": sha}))
    # V02_left-leg: the entry itself a link to a copy outside
    p, _ = _doc(copy, "V02_left-leg")
    entry = outside / "entry.json"
    shutil.copyfile(p, entry)
    p.unlink()
    p.symlink_to(entry)
    with _OPENS.watching(outside) as opens:
        report = _run(copy)
    assert opens.seen == []
    assert sentinel.read_bytes().startswith(b"not an npz") and entry.is_file()
    assert (report.computed, report.reused, report.failed) == (4, 0, 0)
    assert (copy / "results" / "metrics.csv").read_bytes() == metrics
    notes = _notes(report.problems)
    assert set(notes) == set(STEMS)
    assert "no rows" in notes["V01_right-leg"]
    assert "names the traces file" in notes["V01_left-leg"]
    assert "leads outside" in notes["V02_right-leg"] and "leads outside" in notes["V02_left-leg"]
    assert not any(p.is_symlink() for p in sessions.iterdir())  # replaced by the recomputed files


def test_edited_outputs_are_rewritten_and_an_index_leading_outside_is_not_followed(study, tmp_path) -> None:
    root, metrics = study
    copy = _copy(root, tmp_path / "outputs")
    results = copy / "results"
    summary = (results / "summary.csv").read_bytes()
    (results / "summary.csv").write_bytes(summary.replace(b"0.", b"9.", 1))
    report = _run(copy)
    assert (report.computed, report.reused) == (0, 4)
    assert any(p.startswith(".outputs.json not used (summary.csv changed") for p in report.problems)
    assert (results / "summary.csv").read_bytes() == summary
    # an index naming a file outside results/ (its digest left as it was)
    outside = tmp_path / "outside"
    outside.mkdir()
    (outside / "report.md").write_text("not the report")
    again = _run(copy)  # without the note: the outputs are written once more, then reused
    index = json.loads((results / ".outputs.json").read_text())
    index["outputs"]["report"]["path"] = os.path.relpath(outside / "report.md", results)
    (results / ".outputs.json").write_text(json.dumps(index))
    with _OPENS.watching(outside) as opens:
        third = _run(copy)
    assert opens.seen == [] and again.problems == []
    assert any("outside" in p and p.startswith(".outputs.json not used") for p in third.problems)
    assert third.outputs["report"] == results / "report.md"
    assert (results / "metrics.csv").read_bytes() == metrics


# ------------------------------------------------------------------ the posture input cache
def test_the_posture_input_cache_recomputes_what_it_cannot_prove(tmp_path) -> None:
    from psmat.posture import load_posture_study
    from psmat.synth import simulate_posture_study

    root = simulate_posture_study(tmp_path / "posture", subjects=2, days=1, seed=11, duration_s=8.0)
    first = load_posture_study(root, workers=1, progress=False)
    assert (first.problems, first.computed) == ([], 2)
    inputs = root / "results" / "posture" / "inputs"
    # P01: a corrupt file (half of it); P02: one image value changed, the rest (digest too) kept
    p01 = inputs / "P01_d1.npz"
    p01.write_bytes(p01.read_bytes()[: p01.stat().st_size // 2])
    with np.load(inputs / "P02_d1.npz") as z:
        arrays = {k: z[k] for k in z.files}
    arrays["image"][3, 4, 5] += np.float32(1e-3)
    np.savez(inputs / "P02_d1.npz", **arrays)
    second = load_posture_study(root, workers=1, progress=False)
    assert (second.computed, second.problems, len(second.notes)) == (2, [], 2)
    assert second.notes[0].startswith("P01_d1: cached inputs P01_d1.npz not used (")
    assert "P02_d1: cached inputs P02_d1.npz not used (digest mismatch" in second.notes[1]
    assert all(n.endswith("recomputed") for n in second.notes)
    for a, b in zip(first.recordings, second.recordings):
        np.testing.assert_array_equal(a.image, b.image)
        np.testing.assert_array_equal(a.angles_rad, b.angles_rad)
        np.testing.assert_array_equal(a.t_s, b.t_s)
    # a cache file that is a link to a copy outside results/ is not read
    outside = tmp_path / "outside"
    outside.mkdir()
    shutil.copyfile(p01, outside / "P01_d1.npz")
    p01.unlink()
    p01.symlink_to(outside / "P01_d1.npz")
    with _OPENS.watching(outside) as opens:
        third = load_posture_study(root, workers=1, progress=False)
    assert opens.seen == [] and (third.computed, third.problems) == (1, [])
    [note] = third.notes
    assert note.startswith("P01_d1: cached inputs P01_d1.npz not used (it leads outside ") and "not read" in note
    assert not p01.is_symlink()
    fourth = load_posture_study(root, workers=1, progress=False)
    assert (fourth.problems, fourth.notes, fourth.computed) == ([], [], 0)


# ------------------------------------------------------------------ results from a cluster
class _MakeDir:
    """Unpickling it creates a folder: what a rogue worker's pickle could do in the client."""

    def __init__(self, path: str) -> None:
        self.path = path

    def __reduce__(self):
        return os.mkdir, (self.path,)


def test_a_result_is_decoded_without_pickle_and_checked(tmp_path) -> None:
    import io

    from psmat.study import Expect, decode_result, encode_result

    expect = Expect("V01_right-leg", "V01", "right-leg", ("PROP",))
    rows = [{"subject": "V01", "trial": "right-leg", "variant": v, "condition": "", "status": "ok", "ispgr": "ok"}
            for v in ("FP", "PROP")]
    from psmat.study import COLUMNS

    rows = [{c: r.get(c, 1.5) for c in COLUMNS} for r in rows]
    traces = {"t_s": np.arange(3.0), "FP": np.zeros((3, 2)), "PROP": np.ones((3, 2))}
    stem, back, tr = decode_result(encode_result("V01_right-leg", rows, traces), expect)
    assert stem == "V01_right-leg" and back == rows and all(np.array_equal(tr[k], traces[k]) for k in traces)
    for other in (Expect("V02_right-leg", "V01", "right-leg", ("PROP",)), Expect("V01_right-leg", "V02",
                  "right-leg", ("PROP",)), Expect("V01_right-leg", "V01", "right-leg", ("PROP", "SCHC"))):
        with pytest.raises(ValueError):
            decode_result(encode_result("V01_right-leg", rows, traces), other)
    # an .npz holding a pickled object: refused, and the pickle never runs
    sentinel = tmp_path / "ran"
    buf = io.BytesIO()
    np.savez(buf, __result__=np.frombuffer(b"{}", np.uint8), FP=np.array([_MakeDir(str(sentinel))], object))
    with pytest.raises(ValueError, match="not a result file"):
        decode_result(buf.getvalue(), expect)
    assert not sentinel.exists()
    with pytest.raises(ValueError, match="must be bytes"):
        decode_result(pickle.dumps(_MakeDir(str(sentinel))).decode("latin-1"), expect)  # type: ignore[arg-type]


def _chunk(kind: bytes, body: bytes) -> bytes:
    """A PNG chunk as its specification writes it: length, type, data, CRC-32 of type and data."""
    return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body))


def test_a_task_time_and_a_png_are_checked_as_data() -> None:
    from psmat._png import check_png
    from psmat.study._plain import check_timed

    time = {"start": 1.7e9, "wall_s": 0.5, "cpu_s": 0.25, "pid": 4321, "worker": "tls://127.0.0.1:40001"}
    result, took = check_timed((b"result", time))
    assert result == b"result" and (took.start, took.wall_s, took.cpu_s, took.pid, took.worker) == tuple(time.values())
    assert check_timed([b"", {**time, "worker": ""}])[1].worker == ""  # msgpack may send a list
    for bad in ({**time, "pid": True}, {**time, "pid": -1}, {**time, "pid": 1.0}, {**time, "wall_s": float("nan")},
                {**time, "cpu_s": -0.1}, {**time, "start": float("inf")}, {**time, "worker": "a\nb"},
                {**time, "worker": "w" * 257}, {**time, "worker": 7}, {**time, "extra": 1},
                {k: v for k, v in time.items() if k != "pid"}):
        with pytest.raises(ValueError):
            check_timed((b"", bad))
    for bad in (b"result", (b"", time, 1), None, "text"):
        with pytest.raises(ValueError, match="pair"):
            check_timed(bad)

    # a 2 x 1 grey image: signature, IHDR (width, height, depth 8, colour type 0), IDAT, IEND
    png = (b"\x89PNG\r\n\x1a\n" + _chunk(b"IHDR", struct.pack(">IIBBBBB", 2, 1, 8, 0, 0, 0, 0))
           + _chunk(b"IDAT", zlib.compress(b"\x00\x10\x20")) + _chunk(b"IEND", b""))
    assert check_png(png) == png
    flipped = bytearray(png)
    flipped[41] ^= 1  # the first byte of IDAT's data: its CRC no longer holds
    for bad in (png[:-1], png + b"\x00", b"GIF89a" + png[6:], bytes(flipped), png[:8] + _chunk(b"IEND", b""),
                png[:8] + _chunk(b"IHDR", struct.pack(">IIBBBBB", 0, 1, 8, 0, 0, 0, 0)) + png[33:],
                png.replace(b"IDAT", b"ID4T")):
        with pytest.raises(ValueError):
            check_png(bad)
    with pytest.raises(ValueError, match="must be bytes"):
        check_png(png.decode("latin-1"))


@pytest.fixture(scope="module")
def tls_cluster(tmp_path_factory) -> Iterator[tuple[object, object, Path]]:
    """A LocalCluster on 127.0.0.1 over TLS: one worker process, throwaway CA and certificates."""
    distributed = pytest.importorskip("distributed")
    pytest.importorskip("cryptography")  # Security.temporary makes its certificates with it
    security = distributed.Security.temporary()
    scheduler_file = tmp_path_factory.mktemp("dask") / "scheduler.json"
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=True, protocol="tls",
                                  host="127.0.0.1", security=security, dashboard_address=None,
                                  scheduler_kwargs={"scheduler_file": str(scheduler_file), **LOOPBACK_HTTP}) as cluster:
        yield cluster, security, scheduler_file


def test_a_study_on_a_tls_cluster_gives_the_same_metrics(study, tls_cluster, tmp_path) -> None:
    import dask
    import distributed

    root, metrics = study
    cluster, security, scheduler_file = tls_cluster
    assert cluster.scheduler_address.startswith("tls://127.0.0.1:")
    assert json.loads(scheduler_file.read_text())["address"] == cluster.scheduler_address
    copy = _copy(root, tmp_path / "tls", results=False)
    # no credentials, or credentials from another CA: refused, one line, nothing written
    with pytest.raises(RuntimeError, match="a tls:// scheduler needs --tls-ca-file"):
        run_study(copy, scheduler=cluster.scheduler_address, params=PARAMS, progress=False)
    with dask.config.set({"distributed.comm.timeouts.connect": "10s"}), \
            pytest.raises(RuntimeError, match="cannot connect to the Dask scheduler tls://"):
        run_study(copy, scheduler=cluster.scheduler_address, security=distributed.Security.temporary(),
                  params=PARAMS, progress=False)
    assert not (copy / "results" / "metrics.csv").exists()
    report = run_study(copy, scheduler_file=scheduler_file, security=security, params=PARAMS, progress=False)
    assert (report.computed, report.reused, report.failed, report.problems) == (4, 0, 0, [])
    assert (copy / "results" / "metrics.csv").read_bytes() == metrics


def _rogue(payload: bytes):
    """On the worker: a result already serialised as a pickle, as a rogue worker would send it."""
    from distributed.protocol.serialize import Serialized

    return Serialized({"serializer": "pickle", "writeable": ()}, [payload])


def test_a_worker_sending_a_pickle_is_refused(tls_cluster, tmp_path) -> None:
    import cloudpickle
    import distributed

    from psmat.study import Cluster, on_cluster
    from psmat.study import SessionTask

    cloudpickle.register_pickle_by_value(sys.modules[__name__])  # the workers need not import this file
    cluster, security, _ = tls_cluster
    sentinel = tmp_path / "ran"
    payload = pickle.dumps(_MakeDir(str(sentinel)))
    task = SessionTask("V01_right-leg", str(tmp_path / "none.h5"), None, "V01", "right-leg", None, None,
                       {"variants": ["PROP"]}, "0" * 64, {})
    [(stem, rows, traces)] = on_cluster([task], Cluster(cluster.scheduler_address, security=security),
                                        fn=lambda t: _rogue(payload))
    assert not sentinel.exists()
    assert stem == "V01_right-leg" and traces == {} and [r["variant"] for r in rows] == ["FP", "PROP"]
    assert all(r["status"].startswith("error:") and "pickle" in r["status"] for r in rows)
    # the same payload through a client that accepts pickles runs it: the refusal above is what stops it
    with distributed.Client(cluster.scheduler_address, security=security) as client:
        client.submit(_rogue, payload, pure=False).result()
    assert sentinel.is_dir()


def test_the_command_line_passes_tls_and_the_scheduler_file_through(study, tls_cluster, tmp_path, capsys) -> None:
    from psmat.cli import main

    root, metrics = study
    cluster, security, scheduler_file = tls_cluster
    pem = {}
    for name, text in (("ca", security.tls_ca_file), ("cert", security.tls_client_cert),
                       ("key", security.tls_client_key)):
        assert "-----BEGIN" in text  # Security.temporary keeps its PEM text in memory
        pem[name] = tmp_path / f"{name}.pem"
        pem[name].write_text(text)
    copy = _copy(root, tmp_path / "cli")
    (copy / "results" / "sessions" / "V02_left-leg.json").unlink()  # one session for the cluster
    args = ["study", "run", str(copy), "--scheduler-file", str(scheduler_file), "--variants", "PROP,SCHC",
            "--quiet", "--require-encryption"]
    # a certificate without its CA: one line, exit status 1
    assert main(args + ["--tls-cert", str(pem["cert"])]) == 1
    assert capsys.readouterr().err.strip().splitlines() == [
        "psmat study run: TLS needs both --tls-ca-file and --tls-cert (and --tls-key unless the certificate file "
        "holds the key): Dask's TLS is mutual"]
    tls = ["--tls-ca-file", str(pem["ca"]), "--tls-cert", str(pem["cert"]), "--tls-key", str(pem["key"])]
    assert main(args + tls) == 0
    assert "4 sessions: 1 computed, 3 reused, 0 failed" in capsys.readouterr().out
    assert (copy / "results" / "metrics.csv").read_bytes() == metrics


def test_the_cluster_draws_the_figures_this_process_draws_and_a_pickled_one_is_drawn_here(
        study, tls_cluster, tmp_path, monkeypatch) -> None:
    import cloudpickle
    import distributed

    from psmat.study import Cluster, write_results
    from psmat.study import _cluster

    root, _ = study
    cluster, security, _ = tls_cluster
    with open(root / "results" / "metrics.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    with distributed.Client(cluster.scheduler_address, security=security) as client:
        pids = client.run(os.getpid)  # {worker address: its pid}, as the cluster knows them
    drawer = _cluster.cluster_drawer(Cluster(cluster.scheduler_address, security=security))
    times: dict[str, list] = {}

    def draw(into: str):
        def run(tasks):
            for name, data, took in drawer(tasks):
                times.setdefault(into, []).append(took)
                yield name, data, took
        return run

    here = write_results(tmp_path / "here", rows)  # drawn in this process
    figures = sorted(n for n, p in here.items() if p.suffix == ".png")
    assert len(figures) == 4  # bars and Bland-Altman plots: no traces given
    there = write_results(tmp_path / "cluster", rows, draw=draw("cluster"))
    assert all(there[n].read_bytes() == here[n].read_bytes() for n in figures)
    assert len(times["cluster"]) == 4 and all(pids.get(t.worker) == t.pid != os.getpid() for t in times["cluster"])
    # workers sending each figure as a pickle: refused before it is read, the figures drawn here
    cloudpickle.register_pickle_by_value(sys.modules[__name__])
    sentinel = tmp_path / "ran"
    payload = pickle.dumps(_MakeDir(str(sentinel)))
    monkeypatch.setattr(_cluster, "run_figure", lambda t: _rogue(payload))
    rogue = write_results(tmp_path / "rogue", rows, draw=draw("rogue"))
    assert not sentinel.exists()
    assert all(rogue[n].read_bytes() == here[n].read_bytes() for n in figures)
    assert len(times["rogue"]) == 4 and all((t.pid, t.worker) == (os.getpid(), "") for t in times["rogue"])


def _dynamic_tasks(root: Path):
    """The study's SCHC-DYN tasks, planned from its stored results as a run plans them."""
    from psmat.study._cache import TraceFiles, normalise_rows
    from psmat.study._dynamic import plan_dynamic
    from psmat.study._dynamic_tasks import dynamic_tasks

    folder = root / "results" / "sessions"
    docs = [json.loads(p.read_text()) for p in sorted(folder.glob("*.json"))]
    rows = [r for d in docs for r in normalise_rows(d["rows"])]
    files = TraceFiles({(d["rows"][0]["subject"], d["rows"][0]["trial"]): folder / d["traces"] for d in docs})
    plan = plan_dynamic(rows, files, stats={k: files.stats(k) for k in files}, trust_stats=True)
    return dynamic_tasks(plan, {k: files.path(k) for k in plan.jobs}, preprocess="quijoux2021")


def _same_answers(a, b) -> bool:
    """Two lists of (trial, row, trace) equal bit for bit (NaN where both hold NaN)."""
    def same(u, v) -> bool:
        return (isinstance(u, float) and isinstance(v, float) and u != u and v != v) or u == v

    return len(a) == len(b) and all(
        ta == tb and ra.keys() == rb.keys() and all(same(ra[k], rb[k]) for k in ra)
        and (ca is None) == (cb is None) and (ca is None or ca.tobytes() == cb.tobytes())
        for (ta, ra, ca), (tb, rb, cb) in zip(a, b))


def test_the_cluster_corrects_each_volunteer_as_this_process_does_and_a_pickled_answer_is_computed_here(
        study, tls_cluster, tmp_path, monkeypatch) -> None:
    import cloudpickle
    import distributed

    from psmat.study import Cluster
    from psmat.study import _cluster
    from psmat.study._dynamic_tasks import run_dynamic

    root, _ = study
    cluster, security, _ = tls_cluster
    tasks = _dynamic_tasks(root)
    assert len(tasks) == 2 and all(len(t.sessions) == 2 for t in tasks)
    here = {t.subject: run_dynamic(t) for t in tasks}
    assert all(r["status"] == "ok" for a in here.values() for _, r, _ in a)
    with distributed.Client(cluster.scheduler_address, security=security) as client:
        pids = client.run(os.getpid)
    run = _cluster.cluster_dynamic(Cluster(cluster.scheduler_address, security=security))
    got = list(run(tasks))
    assert sorted(t.subject for t, _, _ in got) == ["V01", "V02"]
    for task, answers, took in got:
        assert pids.get(took.worker) == took.pid != os.getpid()
        assert _same_answers(answers, here[task.subject])
    # workers answering with a pickle: refused before it is read, each volunteer computed here
    cloudpickle.register_pickle_by_value(sys.modules[__name__])
    sentinel = tmp_path / "ran"
    payload = pickle.dumps(_MakeDir(str(sentinel)))
    monkeypatch.setattr(_cluster, "run_dynamic_plain", lambda t: _rogue(payload))
    got = list(run(tasks))
    assert not sentinel.exists() and len(got) == 2
    for task, answers, took in got:
        assert (took.pid, took.worker) == (os.getpid(), "")
        assert _same_answers(answers, here[task.subject])


def test_figures_are_drawn_here_when_the_cluster_cannot_be_reached(study, tmp_path) -> None:
    import socket

    import dask

    from psmat.study import Cluster, write_results
    from psmat.study._cluster import cluster_drawer

    root, _ = study
    with open(root / "results" / "metrics.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    with socket.socket() as s:  # a port of this machine that nothing listens on once closed
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    drawer = cluster_drawer(Cluster(f"tcp://127.0.0.1:{port}"))
    times = []

    def draw(tasks):
        for name, data, took in drawer(tasks):
            times.append(took)
            yield name, data, took

    here = write_results(tmp_path / "here", rows)
    with dask.config.set({"distributed.comm.timeouts.connect": "2s"}):
        there = write_results(tmp_path / "there", rows, draw=draw)
    figures = sorted(n for n, p in here.items() if p.suffix == ".png")
    assert len(figures) == 4 and all(there[n].read_bytes() == here[n].read_bytes() for n in figures)
    assert len(times) == 4 and all((t.pid, t.worker) == (os.getpid(), "") for t in times)

"""Sessions of several devices (docs/spec.md §8): the mat at the root, the spine IMUs as stream ``imu``.

Each check compares what is loaded with the arrays that were appended; damage is made by
flipping bytes of real files, located by HDF5's own chunk index or the journal header.
docs/spec.md §6's integrity promises are checked per stream.
"""

from __future__ import annotations

import csv
import json
import os
import signal
import subprocess
import sys
import textwrap
import threading
import time
from pathlib import Path

import h5py
import numpy as np
import pytest

from psmat.io import (
    FORMAT_VERSION,
    STREAMS_FORMAT_VERSION,
    SessionWriter,
    export_csv,
    info,
    journal_path,
    load_session,
    repair_session,
    save_product,
    stream_csv_path,
)
from conftest import child_preexec

MAT_DEV = {"serial": "0000A1B2", "r_o": 2200.0, "v_ref": 3.3, "bits": 12, "fw": "0.1.0", "protocol": 2, "rate": 100}
IMU_DEV = {"serial": "IMU00001", "fw": "0.1.0", "protocol": 2, "rate": 10}
META = {"subject": "P01", "trial": "posture", "day": 1}
PER_FRAME = ("host_time_s", "valid", "seq", "device_time_us")


def mat_data(n: int, seed: int = 0) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(seed)
    return {"frames": rng.integers(0, 4096, size=(n, 4, 4), dtype=np.uint16),
            "t": 100.0 + np.arange(n) * 0.01, "valid": rng.random(n) > 0.1,
            "seq": np.arange(n, dtype=np.int64) + 5, "dt": np.arange(n, dtype=np.int64) * 10_000}


def imu_data(n: int, seed: int = 1) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(seed)
    return {"frames": rng.uniform(-180, 180, size=(n, 5, 3)).astype(np.float32),
            "t": 100.003 + np.arange(n) * 0.1, "valid": rng.random(n) > 0.1,
            "seq": np.arange(n, dtype=np.int64), "dt": np.arange(n, dtype=np.int64) * 100_000}


def append_in_batches(w, d: dict[str, np.ndarray], batch: int) -> None:
    for a in range(0, d["frames"].shape[0], batch):
        sl = slice(a, a + batch)
        w.append(d["frames"][sl], d["t"][sl], d["valid"][sl], seq=d["seq"][sl], device_time_us=d["dt"][sl])


def assert_holds(s, d: dict[str, np.ndarray]) -> None:
    np.testing.assert_array_equal(s.counts, d["frames"])
    assert s.counts.dtype == d["frames"].dtype
    np.testing.assert_array_equal(s.host_time_s, d["t"])
    np.testing.assert_array_equal(s.valid, d["valid"])
    np.testing.assert_array_equal(s.seq, d["seq"])
    np.testing.assert_array_equal(s.device_time_us, d["dt"])


def write_two(path: Path, mat: dict[str, np.ndarray], imu: dict[str, np.ndarray], chunk_frames: int = 8) -> Path:
    """A mat and an IMU recorded together, each appended by its own reader thread."""
    with SessionWriter(path, (4, 4), MAT_DEV, {"serial": "0000A1B2"}, META, chunk_frames=chunk_frames) as w:
        s_imu = w.add_stream("imu", kind="imu", shape=(5, 3), device=IMU_DEV)
        threads = [threading.Thread(target=append_in_batches, args=(w, mat, 3)),
                   threading.Thread(target=append_in_batches, args=(s_imu, imu, 1))]
        for th in threads:
            th.start()
        for th in threads:
            th.join()
        w.set_counters(dropped_frames=2)
        s_imu.set_counters(dropped_frames=7, bad_frames=1)
    return path


def chunk_offsets(path: Path, name: str) -> list[tuple[int, int, int]]:
    """(first frame, byte offset, byte size) of each stored chunk of dataset ``name``."""
    with h5py.File(path, "r") as f:
        ds = f[name]
        return sorted((int(c.chunk_offset[0]), int(c.byte_offset), int(c.size))
                      for c in (ds.id.get_chunk_info(i) for i in range(ds.id.get_num_chunks())))


def flip(path: Path, offset: int) -> None:
    with open(path, "r+b") as fh:
        fh.seek(offset)
        b = fh.read(1)[0]
        fh.seek(offset)
        fh.write(bytes([b ^ 0xFF]))


# ---------------------------------------------------------------------- round trip
def test_mat_and_imu_round_trip(tmp_path: Path) -> None:
    mat, imu = mat_data(100), imu_data(11)
    p = write_two(tmp_path / "two.h5", mat, imu)
    assert not journal_path(p).exists() and not journal_path(p, "imu").exists()
    s = load_session(p)
    assert s.complete and s.kind == "psm" and s.format_version == STREAMS_FORMAT_VERSION
    assert_holds(s, mat)
    assert list(s.streams) == ["imu"]
    st = s.streams["imu"]
    assert st.kind == "imu" and st.frame_shape == (5, 3) and st.complete and not st.streams
    assert_holds(st, imu)
    assert st.device["serial"] == "IMU00001" and st.device["kind"] == "imu" and st.device["shape"] == [5, 3]
    assert s.device["serial"] == "0000A1B2"
    assert st.metadata == s.metadata == META and st.calibration is None and s.calibration == {"serial": "0000A1B2"}
    assert s.counters["dropped_frames"] == 2 and st.counters["dropped_frames"] == 7 and st.counters["bad_frames"] == 1
    assert s.notes == [] and st.notes == []
    # a product added afterwards goes to the root; the stream is kept
    save_product(p, "g", np.ones((100, 4, 4)), {"method": "test"}, "S")
    s2 = load_session(p)
    assert "g" in s2.products and s2.streams["imu"].n_frames == 11


def test_stream_layout_is_plain_hdf5_with_checksums(tmp_path: Path) -> None:
    p = write_two(tmp_path / "two.h5", mat_data(30), imu_data(9))
    with h5py.File(p, "r") as f:
        assert int(f.attrs["format_version"]) == STREAMS_FORMAT_VERSION
        g = f["streams/imu"]
        assert g.attrs["kind"] == b"imu" and list(g.attrs["frame_shape"]) == [5, 3] and int(g.attrs["n_frames"]) == 9
        assert g["angles"].shape == (9, 5, 3) and g["angles"].dtype == np.float32 and g["angles"].attrs["unit"] == b"deg"
        for name in ("angles", *PER_FRAME, "counters"):
            assert g[name].fletcher32, name
        assert json.loads(g["device"].attrs["json"])["serial"] == "IMU00001"


def test_a_one_device_session_is_unchanged(tmp_path: Path) -> None:
    mat = mat_data(20)
    p = tmp_path / "one.h5"
    with SessionWriter(p, (4, 4), MAT_DEV, metadata=META) as w:
        append_in_batches(w, mat, 4)
    with h5py.File(p, "r") as f:
        assert int(f.attrs["format_version"]) == FORMAT_VERSION == 2 and "streams" not in f
    s = load_session(p)
    assert s.streams == {} and s.format_version == 2
    assert_holds(s, mat)


def test_a_format_2_file_of_an_older_psmat_loads(tmp_path: Path) -> None:
    """Format 2 as psmat wrote it before streams (built here by hand from the documented layout)."""
    d = mat_data(12)
    p = tmp_path / "v2.h5"
    with h5py.File(p, "w", libver="latest") as f:
        f.attrs.update({"format": "psmat-session", "format_version": 2, "kind": "psm", "frame_dataset": "counts",
                        "frame_shape": [4, 4], "complete": 1, "n_frames": 12, "created_utc": "2025-01-01T10:00:00"})
        f.create_dataset("counts", data=d["frames"], chunks=(8, 4, 4), maxshape=(None, 4, 4), fletcher32=True)
        for name, arr in (("host_time_s", d["t"]), ("valid", d["valid"].astype(np.uint8)), ("seq", d["seq"]),
                          ("device_time_us", d["dt"])):
            f.create_dataset(name, data=arr, chunks=(8,), maxshape=(None,), fletcher32=True)
        f.create_dataset("counters", data=np.array([1, 2, 3, 4]), chunks=(4,), fletcher32=True)
        f["counters"].attrs["names"] = [b"dropped_frames", b"bad_frames", b"resyncs", b"bytes_discarded"]
        f.create_group("device").attrs["json"] = json.dumps(MAT_DEV).encode()
        f.create_group("metadata").attrs["json"] = json.dumps(META).encode()
        f.create_group("products")
    s = load_session(p)
    assert s.format_version == 2 and s.complete and s.streams == {}
    assert len(s.notes) == 1 and "Fletcher-32 only" in s.notes[0]  # no CRC-32 table: said, still loads
    assert_holds(s, d)
    assert s.device == MAT_DEV and s.metadata == META
    assert s.counters == {"dropped_frames": 1, "bad_frames": 2, "resyncs": 3, "bytes_discarded": 4}


# ---------------------------------------------------------------------- names and misuse
@pytest.mark.parametrize("name", ["counts", "angles", "host_time_s", "device", "streams", "products", "",
                                  "2imu", "imu.x", "a/b", "ímu", 3])
def test_a_bad_stream_name_is_a_value_error(tmp_path: Path, name) -> None:
    with SessionWriter(tmp_path / "n.h5", (4, 4), MAT_DEV) as w:
        with pytest.raises(ValueError, match="stream name"):
            w.add_stream(name, kind="imu", shape=(5, 3), device=IMU_DEV)
        assert w.streams == {}


def test_duplicate_stream_bad_kind_and_closed_writer(tmp_path: Path) -> None:
    w = SessionWriter(tmp_path / "d.h5", (4, 4), MAT_DEV)
    imu = w.add_stream("imu", kind="imu", shape=(5, 3), device=IMU_DEV)
    with pytest.raises(ValueError, match="'imu' already added"):
        w.add_stream("imu", kind="imu", shape=(5, 3), device=IMU_DEV)
    with pytest.raises(ValueError, match="kind"):
        w.add_stream("imu2", kind="eeg", shape=(5, 3), device=IMU_DEV)
    with pytest.raises(ValueError, match="imu frame shape"):
        w.add_stream("imu2", kind="imu", shape=(5, 4), device=IMU_DEV)
    with pytest.raises(ValueError, match=r"frames must have shape \(N, 5, 3\)"):
        imu.append(np.zeros((2, 4, 4)), [0.0, 0.1], True)
    w.close()
    with pytest.raises(ValueError, match="closed"):
        w.add_stream("later", kind="imu", shape=(5, 3), device=IMU_DEV)
    with pytest.raises(ValueError, match="stream 'imu'.*closed"):
        imu.append(np.zeros((5, 3)), 1.0, True)
    assert load_session(tmp_path / "d.h5").streams["imu"].n_frames == 0


# ---------------------------------------------------------------------- damage, per stream and dataset
@pytest.mark.parametrize("name", ["angles", "host_time_s", "seq"])
def test_a_flipped_byte_in_a_stream_chunk_costs_that_chunk_of_that_stream(tmp_path: Path, name: str) -> None:
    mat, imu = mat_data(40), imu_data(40)
    imu["valid"][:] = True
    p = write_two(tmp_path / "f.h5", mat, imu, chunk_frames=8)
    first, off, size = chunk_offsets(p, f"streams/imu/{name}")[1]  # frames 8..15
    flip(p, off + size // 2)
    s = load_session(p)
    st = s.streams["imu"]
    bad = np.zeros(40, bool)
    bad[8:16] = True
    assert first == 8 and st.n_frames == 40
    np.testing.assert_array_equal(st.valid, ~bad)  # never returned as valid
    assert_holds(s, mat)  # the mat loses nothing
    lost = {"angles": np.nan, "host_time_s": np.nan, "seq": -1}[name]
    got = {"angles": st.counts, "host_time_s": st.host_time_s, "seq": st.seq}[name]
    want = {"angles": imu["frames"], "host_time_s": imu["t"], "seq": imu["seq"]}[name]
    np.testing.assert_array_equal(got[~bad], want[~bad])
    np.testing.assert_array_equal(got[bad], np.full_like(got[bad], lost))
    # reported for the stream and the dataset, with the frames: in the stream and in the root's notes
    assert len(st.notes) == 1 and f"/streams/imu/{name}" in st.notes[0] and "8..15" in st.notes[0]
    assert s.notes == [f"stream imu: {st.notes[0]}"]
    text = info(s)
    assert "stream imu" in text and f"/streams/imu/{name}" in text


def test_a_damaged_stream_group_costs_that_stream_only(tmp_path: Path) -> None:
    mat = mat_data(20)
    p = write_two(tmp_path / "g.h5", mat, imu_data(5))
    with h5py.File(p, "r+") as f:
        f["streams/imu"].attrs["kind"] = b"eeg"
    s = load_session(p)
    assert s.streams == {}
    assert_holds(s, mat)
    assert len(s.notes) == 1 and "stream 'imu' damaged and left out" in s.notes[0] and "eeg" in s.notes[0]


# ---------------------------------------------------------------------- interrupted recordings
def killed_copy(tmp_path: Path, mat: dict[str, np.ndarray], imu: dict[str, np.ndarray]) -> Path:
    """What a kill leaves: the journals of the root and of the stream (copied while the writer is open)."""
    import shutil

    w = SessionWriter(tmp_path / "live.h5", (4, 4), MAT_DEV, metadata=META, background=False)
    try:
        s_imu = w.add_stream("imu", kind="imu", shape=(5, 3), device=IMU_DEV)
        append_in_batches(w, mat, 5)
        append_in_batches(s_imu, imu, 2)
        s_imu.set_counters(dropped_frames=4)
        dst = tmp_path / "killed.h5"
        shutil.copyfile(journal_path(w.path), journal_path(dst))
        shutil.copyfile(journal_path(w.path, "imu"), journal_path(dst, "imu"))
    finally:
        w.close()
    return dst


def test_an_interrupted_two_device_recording_loads_and_repairs(tmp_path: Path) -> None:
    mat, imu = mat_data(50), imu_data(12)
    p = killed_copy(tmp_path, mat, imu)
    s = load_session(p)
    assert s.recovered and not s.complete and s.format_version == STREAMS_FORMAT_VERSION
    assert_holds(s, mat)
    st = s.streams["imu"]
    assert st.recovered and not st.complete and st.counters["dropped_frames"] == 4 and st.device["serial"] == "IMU00001"
    assert_holds(st, imu)
    assert any("stream imu: 12 frames recovered from the journal killed.h5.imu.journal" == n for n in s.notes)
    assert "INTERRUPTED" in info(s) and "stream imu" in info(s)

    r = repair_session(p)
    assert r.complete and not r.recovered and not journal_path(p).exists() and not journal_path(p, "imu").exists()
    assert_holds(r, mat)
    assert_holds(r.streams["imu"], imu)
    assert r.streams["imu"].counters["dropped_frames"] == 4


def test_a_damaged_stream_journal_record_costs_that_record(tmp_path: Path) -> None:
    mat, imu = mat_data(30), imu_data(12)
    p = killed_copy(tmp_path, mat, imu)
    jp = journal_path(p, "imu")
    raw = jp.read_bytes()
    hlen = int.from_bytes(raw[8:12], "little")
    rsize = int(json.loads(raw[12 : 12 + hlen])["record_bytes"])
    flip(jp, 12 + hlen + 4 + 6 * rsize + 40)  # inside the payload of record 6 (frame 6)
    s = load_session(p)
    keep = np.arange(12) != 6
    assert_holds(s, mat)
    assert_holds(s.streams["imu"], {k: v[keep] for k, v in imu.items()})
    assert any(n.startswith("stream imu: 1 journal record damaged and skipped") and "frame(s) 6 " in n for n in s.notes)


def test_close_checks_every_stream_journal_it_reads_back(tmp_path: Path) -> None:
    """A stream's journal damaged while recording: close() keeps every journal, the loader skips the record."""
    mat, imu = mat_data(20), imu_data(10)
    p = tmp_path / "c.h5"
    w = SessionWriter(p, (4, 4), MAT_DEV, metadata=META, background=False)
    s_imu = w.add_stream("imu", kind="imu", shape=(5, 3), device=IMU_DEV)
    append_in_batches(w, mat, 20)
    append_in_batches(s_imu, imu, 10)
    jp = journal_path(p, "imu")
    raw = jp.read_bytes()
    hlen = int.from_bytes(raw[8:12], "little")
    rsize = int(json.loads(raw[12 : 12 + hlen])["record_bytes"])
    flip(jp, 12 + hlen + 4 + 3 * rsize + 40)
    with pytest.raises(RuntimeError, match=r"c\.h5\.imu\.journal damaged.*9 of 10 frames.*journals .* were kept"):
        w.close()
    assert not p.exists() and journal_path(p).exists() and jp.exists()
    s = load_session(p)
    assert_holds(s, mat)
    assert_holds(s.streams["imu"], {k: v[np.arange(10) != 3] for k, v in imu.items()})


def test_journals_of_other_sessions_are_not_taken_as_streams(tmp_path: Path) -> None:
    """``killed.h5.x.journal`` is the journal of a session ``killed.h5.x``; an old ``.imu`` journal is stale."""
    import shutil

    mat, imu = mat_data(10), imu_data(4)
    p = killed_copy(tmp_path, mat, imu)
    (tmp_path / "other").mkdir()
    other = killed_copy(tmp_path / "other", mat_data(3), imu_data(3))
    shutil.copyfile(journal_path(other), journal_path(tmp_path / "killed.h5.x"))  # a session named killed.h5.x
    shutil.copyfile(journal_path(other, "imu"), journal_path(p, "old"))  # another recording's stream
    s = load_session(p)
    assert sorted(s.streams) == ["imu"]
    assert_holds(s.streams["imu"], imu)
    # overwriting the interrupted recording removes its journals and no one else's
    with SessionWriter(p, (4, 4), MAT_DEV, overwrite=True):
        pass
    assert not journal_path(p, "imu").exists()
    assert journal_path(p, "old").exists() and journal_path(tmp_path / "killed.h5.x").exists()
    assert load_session(p).streams == {}


WRITER = textwrap.dedent(
    """
    import os, sys, threading
    import numpy as np
    from psmat.io import SessionWriter

    path, progress = sys.argv[1], sys.argv[2]
    fd = os.open(progress, os.O_WRONLY | os.O_CREAT | os.O_APPEND)

    def mat(k):
        return ((k[:, None] * 7 + np.arange(256)[None, :]) % 4096).astype(np.uint16).reshape(-1, 16, 16)

    def imu(k):
        return ((k[:, None] * 0.37 + np.arange(15)[None, :] * 1.25) % 360.0 - 180.0).astype(np.float32).reshape(-1, 5, 3)

    w = SessionWriter(path, (16, 16), device={"serial": "MAT1"}, metadata={"subject": "K"}, chunk_frames=32,
                      flush_frames=24, flush_interval_s=0.05)
    s = w.add_stream("imu", kind="imu", shape=(5, 3), device={"serial": "IMU1"})

    def reader(stream, make, tag, batch, dt):
        k = 0
        while True:
            ks = np.arange(k, k + batch)
            stream.append(make(ks), 1000.0 + ks * dt, ks % 7 != 3, seq=ks, device_time_us=ks * int(dt * 1e6))
            k += batch
            os.write(fd, b"%s %d\\n" % (tag, k))

    for args in ((w, mat, b"M", 3, 0.01), (s, imu, b"I", 1, 0.1)):
        threading.Thread(target=reader, args=args, daemon=True).start()
    threading.Event().wait()
    """
)


def expected(kind: str, n: int) -> dict[str, np.ndarray]:
    ks = np.arange(n)
    if kind == "psm":
        fr, dt = ((ks[:, None] * 7 + np.arange(256)[None, :]) % 4096).astype(np.uint16).reshape(n, 16, 16), 0.01
    else:
        fr = ((ks[:, None] * 0.37 + np.arange(15)[None, :] * 1.25) % 360.0 - 180.0).astype(np.float32).reshape(n, 5, 3)
        dt = 0.1
    return {"frames": fr, "t": 1000.0 + ks * dt, "valid": ks % 7 != 3, "seq": ks, "dt": ks * int(dt * 1e6)}


@pytest.mark.parametrize("wait_s", [0.05, 0.3])
def test_sigkill_keeps_every_returned_append_of_both_streams(tmp_path: Path, wait_s: float) -> None:
    """A real writer process, two reader threads, killed with SIGKILL: each stream is a prefix of what was
    appended holding at least every frame whose append had returned."""
    path, progress, script = tmp_path / "k.h5", tmp_path / "progress.txt", tmp_path / "writer.py"
    script.write_text(WRITER)
    errlog = tmp_path / "stderr.txt"
    with open(errlog, "wb") as err:
        proc = subprocess.Popen([sys.executable, str(script), str(path), str(progress)], stderr=err,
                                env=dict(os.environ), preexec_fn=child_preexec())
    try:
        deadline = time.monotonic() + 60
        while not all(tag in (progress.read_bytes() if progress.exists() else b"") for tag in (b"M ", b"I 3\n")):
            assert proc.poll() is None, errlog.read_text()
            assert time.monotonic() < deadline, "writer made no progress"
            time.sleep(0.01)
        time.sleep(wait_s)
        proc.send_signal(signal.SIGKILL)
        proc.wait(10)
        assert proc.returncode == -signal.SIGKILL
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    acked = {"M": 0, "I": 0}
    for line in progress.read_text().splitlines():
        parts = line.split()
        if len(parts) == 2 and parts[0] in acked:
            acked[parts[0]] = max(acked[parts[0]], int(parts[1]))
    assert not path.exists() and journal_path(path).exists() and journal_path(path, "imu").exists()
    s = load_session(path)
    for st, kind, tag in ((s, "psm", "M"), (s.streams["imu"], "imu", "I")):
        assert st.n_frames >= acked[tag] >= 3, (kind, st.n_frames, acked)
        assert_holds(st, expected(kind, st.n_frames))
    assert s.device["serial"] == "MAT1" and s.streams["imu"].device["serial"] == "IMU1"
    r = repair_session(path)
    assert r.complete and r.n_frames == s.n_frames and r.streams["imu"].n_frames == s.streams["imu"].n_frames


# ---------------------------------------------------------------------- people and other programs
def test_export_writes_one_csv_per_stream_and_info_lists_them(tmp_path: Path) -> None:
    mat, imu = mat_data(6), imu_data(4)
    p = write_two(tmp_path / "e.h5", mat, imu)
    out = export_csv(p, tmp_path / "e.csv")
    assert out == tmp_path / "e.csv" and stream_csv_path(out, "imu") == tmp_path / "e.imu.csv"
    with open(tmp_path / "e.imu.csv", newline="") as fh:
        rows = list(csv.reader(fh))
    assert rows[0][:4] == ["time_s", "valid", "seq", "s0_heading_deg"] and len(rows) == 5
    np.testing.assert_array_equal([float(r[0]) for r in rows[1:]], imu["t"])
    np.testing.assert_array_equal(np.array([[float(x) for x in r[3:]] for r in rows[1:]], np.float32),
                                  imu["frames"].reshape(4, 15))
    with open(out, newline="") as fh:
        assert len(list(csv.reader(fh))) == 7
    text = info(p)
    assert "stream imu: kind imu, frame shape (5, 3)" in text and "IMU00001" in text
    assert "    frames        4, duration 0.300 s" in text

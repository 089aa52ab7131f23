"""A finished session file cut short (docs/spec.md §6): the frames of the chunks before the cut come back.

Files are written by :class:`psmat.io.SessionWriter` and cut with plain byte slicing. What
each cut must give back is worked out from HDF5's own chunk index of the intact file
(``chunk_iter``: where each chunk lies): a frame is intact when the chunk holding it in every
per-frame dataset ends at or before the cut. The loaded frames are compared with the arrays
that were appended. Superblocks are read and forged byte by byte after the HDF5 file format
specification ("Superblock"), their checksum recomputed with Bob Jenkins' lookup3, which HDF5
uses for every metadata checksum.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import h5py
import numpy as np
import pytest

import psmat._atomic
from psmat.io import SessionFormatError, SessionWriter, journal_path, load_session, repair_session
from psmat.io.session import recorded_size

DEVICE = {"serial": "0000A1B2", "r_o": 2200.0, "v_ref": 3.3, "bits": 12, "fw": "0.1.0", "protocol": 2, "rate": 100}
IMU_DEV = {"serial": "IMU00001", "fw": "0.1.0", "protocol": 2, "rate": 10}
CAL = {"serial": "0000A1B2", "r_adc": 6.9e6, "r_mux": 145.0}
META = {"subject": "S03", "trial": 4}
FRAME_SETS = {"psm": ("counts", "host_time_s", "valid", "seq", "device_time_us"),
              "imu": ("angles", "host_time_s", "valid", "seq", "device_time_us")}


def mat_data(n: int, seed: int = 3) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(seed)
    return {"frames": rng.integers(0, 4096, size=(n, 4, 4), dtype=np.uint16), "t": 10.0 + np.arange(n) * 0.01,
            "valid": rng.random(n) > 0.1, "seq": np.arange(n, dtype=np.int64) + 9,
            "dt": np.arange(n, dtype=np.int64) * 10_000}


def imu_data(n: int, seed: int = 4) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(seed)
    return {"frames": rng.uniform(-180, 180, size=(n, 5, 3)).astype(np.float32), "t": 10.004 + np.arange(n) * 0.1,
            "valid": rng.random(n) > 0.1, "seq": np.arange(n, dtype=np.int64),
            "dt": np.arange(n, dtype=np.int64) * 100_000}


def append(w, d: dict[str, np.ndarray], batch: int) -> None:
    for a in range(0, d["frames"].shape[0], batch):
        s = slice(a, a + batch)
        w.append(d["frames"][s], d["t"][s], d["valid"][s], seq=d["seq"][s], device_time_us=d["dt"][s])


def write(path: Path, mat: dict[str, np.ndarray], imu: dict[str, np.ndarray] | None = None,
          chunk_frames: int = 8) -> Path:
    with SessionWriter(path, (4, 4), DEVICE, CAL, META, chunk_frames=chunk_frames, background=False) as w:
        st = w.add_stream("imu", kind="imu", shape=(5, 3), device=IMU_DEV) if imu is not None else None
        append(w, mat, 7)
        if st is not None:
            append(st, imu, 3)
            st.set_counters(dropped_frames=5)
        w.set_counters(dropped_frames=2, bytes_discarded=17)
    return path


def chunk_ends(path: Path, group: str, names: tuple[str, ...]) -> dict[str, dict[int, int]]:
    """For each dataset of ``group``: first frame of each chunk -> the byte where the chunk ends, from HDF5's index."""
    out: dict[str, dict[int, int]] = {}
    with h5py.File(path, "r") as f:
        for name in names:
            ends: dict[int, int] = {}
            f[group][name].id.chunk_iter(lambda c: ends.__setitem__(int(c.chunk_offset[0]),
                                                                    int(c.byte_offset) + int(c.size)))
            out[name] = ends
    return out


def first_chunk(path: Path, groups: dict[str, str]) -> int:
    """The byte where the first chunk of any frame or per-frame dataset begins."""
    starts: list[int] = []
    with h5py.File(path, "r") as f:
        for group, kind in groups.items():
            for name in FRAME_SETS[kind]:
                f[group][name].id.chunk_iter(lambda c: starts.append(int(c.byte_offset)))
    return min(starts)


def intact(ends: dict[str, dict[int, int]], n: int, c: int, cut: int) -> np.ndarray:
    """Frames whose chunk ends at or before ``cut`` in every dataset."""
    ok = np.ones(n, bool)
    for per_chunk in ends.values():
        for a in range(0, n, c):
            ok[a : a + c] &= per_chunk[a] <= cut
    return ok


def lost_note(cut: int, size: int, ok: np.ndarray) -> str:
    if ok.all():
        return f"file truncated at byte {cut} of {size}: no frames lost"
    a, z = int(np.argmin(ok)), ok.size - 1
    return f"file truncated at byte {cut} of {size}: frames {a if a == z else f'{a}..{z}'} lost"


def check_device(s, d: dict[str, np.ndarray], ends: dict[str, dict[int, int]], c: int, cut: int,
                 where: str) -> np.ndarray:
    """``s`` holds every frame of ``d``; exactly the intact ones valid (as written), equal to what was appended.

    Returns the intact frames.
    """
    n = d["frames"].shape[0]
    ok = intact(ends, n, c, cut)
    assert s.n_frames == n, where
    assert ok[: int(ok.sum())].all(), where  # the intact frames are the first ones: chunks lie in frame order
    np.testing.assert_array_equal(s.valid, d["valid"] & ok, err_msg=where)
    v = s.valid
    np.testing.assert_array_equal(s.counts[v], d["frames"][v], err_msg=where)
    np.testing.assert_array_equal(s.host_time_s[v], d["t"][v], err_msg=where)
    if v.any():
        np.testing.assert_array_equal(s.seq[v], d["seq"][v], err_msg=where)
        np.testing.assert_array_equal(s.device_time_us[v], d["dt"][v], err_msg=where)
    gone = ~intact({"host_time_s": ends["host_time_s"]}, n, c, cut)
    assert np.all(np.isnan(s.host_time_s[gone])), where  # nothing of the zeros past the cut is returned
    return ok


def cuts(size: int, seed: int) -> list[int]:
    """~200 seeded offsets across the whole file, and every offset of its last 600 bytes."""
    rng = np.random.default_rng(seed)
    return sorted({*rng.integers(0, size, 200).tolist(), *range(max(size - 600, 0), size)})


# ---------------------------------------------------------------------- one device
def test_every_cut_gives_back_the_frames_before_it(tmp_path: Path) -> None:
    d = mat_data(300)
    good = write(tmp_path / "good.h5", d)
    raw = good.read_bytes()
    ends = chunk_ends(good, "/", FRAME_SETS["psm"])
    data_start = first_chunk(good, {"/": "psm"})
    p = tmp_path / "cut.h5"
    raised = recovered = 0
    for cut in cuts(len(raw), 0):
        p.write_bytes(raw[:cut])
        try:
            s = load_session(p)
        except SessionFormatError as e:
            assert cut < data_start, (cut, str(e))  # only a cut before the first frame's chunk
            assert "cut.h5" in str(e) and "\n" not in str(e), str(e)
            with pytest.raises(SessionFormatError):  # refused without reading frames too
                load_session(p, frames=False)
            raised += 1
            continue
        ok = check_device(s, d, ends, 8, cut, f"cut {cut}")
        assert lost_note(cut, len(raw), ok) in s.notes, (cut, s.notes)
        if cut >= data_start:  # (a cut in the counters, stored just before the frames, costs them: noted)
            assert not any("damaged" in n for n in s.notes), (cut, s.notes)
            assert s.counters["dropped_frames"] == 2 and s.counters["bytes_discarded"] == 17, cut
        assert s.metadata == META and s.calibration == CAL and s.complete, cut
        bare = load_session(p, frames=False)  # no frame read, the same cut found and noted
        assert bare.n_frames == 0 and lost_note(cut, len(raw), ok) in bare.notes, (cut, bare.notes)
        recovered += int(s.valid.sum())
        assert sorted(x.name for x in tmp_path.iterdir()) == ["cut.h5", "good.h5"]  # nothing copied or left behind
    assert raised and recovered  # cuts fell in both the metadata and the frames


def test_one_byte_short_loses_the_last_chunk_only(tmp_path: Path) -> None:
    d = mat_data(300)
    good = write(tmp_path / "good.h5", d)
    p = tmp_path / "short.h5"
    p.write_bytes(good.read_bytes()[:-1])
    s = load_session(p)
    lost = np.zeros(300, bool)
    lost[296:] = True  # 300 = 37 chunks of 8 + 4: the last chunk (4 frames) is the file's last bytes
    np.testing.assert_array_equal(s.valid, d["valid"] & ~lost)
    np.testing.assert_array_equal(s.counts[:296], d["frames"][:296])
    assert f"file truncated at byte {good.stat().st_size - 1} of {good.stat().st_size}: frames 296..299 lost" in s.notes


def test_a_cut_in_the_metadata_is_one_error_or_the_journal(tmp_path: Path) -> None:
    d = mat_data(40)
    p = tmp_path / "s.h5"
    w = SessionWriter(p, (4, 4), DEVICE, CAL, META, chunk_frames=8, background=False)
    append(w, d, 7)
    kept = tmp_path / "journal.copy"
    shutil.copyfile(journal_path(p), kept)  # the journal as a crash between writing the file and removing it leaves it
    w.close()
    p.write_bytes(p.read_bytes()[:300])
    with pytest.raises(SessionFormatError, match=r"s\.h5: truncated at byte 300 of \d+ .*metadata"):
        load_session(p)
    shutil.copyfile(kept, journal_path(p))
    s = load_session(p)
    assert s.recovered and s.n_frames == 40 and any("s.h5 unusable" in n for n in s.notes)
    np.testing.assert_array_equal(s.counts, d["frames"])
    np.testing.assert_array_equal(s.valid, d["valid"])


def _closed_keeping_journal(tmp_path: Path, n: int) -> tuple[dict, Path, Path]:
    """A finished session of ``n`` frames (chunks of 8) and a copy of the journal it was written from."""
    d = mat_data(n)
    p = tmp_path / "s.h5"
    w = SessionWriter(p, (4, 4), DEVICE, CAL, META, chunk_frames=8, background=False)
    append(w, d, 7)
    shutil.copyfile(journal_path(p), tmp_path / "journal.copy")
    w.close()
    return d, p, tmp_path / "journal.copy"


def test_a_cut_file_beside_its_journal_loads_from_the_journal(tmp_path: Path) -> None:
    d, p, _ = _closed_keeping_journal(tmp_path, 64)
    p.write_bytes(p.read_bytes()[:-100])  # among the frames: the file alone loses its last chunk
    assert not load_session(p, use_journal=False).valid[-1]
    shutil.copyfile(tmp_path / "journal.copy", journal_path(p))
    s = load_session(p)  # the journal holds every frame
    assert s.recovered and any("unusable as it is (file truncated at byte" in n for n in s.notes)
    np.testing.assert_array_equal(s.valid, d["valid"])
    np.testing.assert_array_equal(s.counts, d["frames"])


# ---------------------------------------------------------------------- streams
def test_every_cut_of_a_file_with_a_stream(tmp_path: Path) -> None:
    mat, imu = mat_data(200), imu_data(60)
    good = write(tmp_path / "good.h5", mat, imu)
    raw = good.read_bytes()
    ends_mat = chunk_ends(good, "/", FRAME_SETS["psm"])
    ends_imu = chunk_ends(good, "/streams/imu", FRAME_SETS["imu"])
    data_start = first_chunk(good, {"/": "psm", "/streams/imu": "imu"})
    p = tmp_path / "cut.h5"
    loaded = 0
    for cut in cuts(len(raw), 1):
        p.write_bytes(raw[:cut])
        try:
            s = load_session(p)
        except SessionFormatError as e:
            assert cut < data_start, (cut, str(e))
            continue
        loaded += 1
        ok_mat = check_device(s, mat, ends_mat, 8, cut, f"cut {cut}")
        ok_imu = check_device(s.streams["imu"], imu, ends_imu, 8, cut, f"cut {cut}, imu")
        assert lost_note(cut, len(raw), ok_mat) in s.notes, (cut, s.notes)
        assert "stream imu: " + lost_note(cut, len(raw), ok_imu) in s.notes, (cut, s.notes)
        if cut >= data_start:
            assert s.streams["imu"].counters["dropped_frames"] == 5 and s.counters["dropped_frames"] == 2, cut
    assert loaded > 600  # the last 600 bytes at least: imu frames there


# ---------------------------------------------------------------------- the file's layout
@pytest.mark.parametrize(("n", "chunk_frames", "n_imu"), [(0, 8, 0), (1, 8, 1), (255, 1, 0), (257, 1, 0),
                                                          (1000, 8, 300), (3000, 256, 77)])
def test_all_metadata_precedes_the_data_and_chunks_are_in_frame_order(tmp_path: Path, n: int, chunk_frames: int,
                                                                      n_imu: int) -> None:
    p = write(tmp_path / "s.h5", mat_data(n), imu_data(n_imu) if n_imu else None, chunk_frames)
    spans: list[tuple[int, int]] = []  # (offset, size) of every piece of data HDF5 stores

    def visit(_name: str, obj: object) -> None:
        if isinstance(obj, h5py.Dataset) and obj.chunks is not None:
            obj.id.chunk_iter(lambda c: spans.append((int(c.byte_offset), int(c.size))))
        elif isinstance(obj, h5py.Dataset) and obj.id.get_offset() is not None:
            spans.append((int(obj.id.get_offset()), int(obj.id.get_storage_size())))

    with h5py.File(p, "r") as f:
        f.visititems(visit)
    size = p.stat().st_size
    start = min(o for o, _ in spans)
    # every byte from the first stored data to the end of the file is data: no metadata among the frames
    assert sum(s for _, s in spans) == size - start
    assert max(o + s for o, s in spans) == size
    # within each device, chunk k of every dataset lies before chunk k + 1 of any
    for group, kind, m in (("/", "psm", n), ("/streams/imu", "imu", n_imu)):
        if m:
            per = chunk_ends(p, group, FRAME_SETS[kind])
            for a in range(0, max(m - chunk_frames, 0), chunk_frames):
                assert max(e[a] for e in per.values()) <= min(e[a + chunk_frames] for e in per.values()), (group, a)


def test_a_repaired_file_keeps_the_layout(tmp_path: Path) -> None:
    d, p, journal = _closed_keeping_journal(tmp_path, 90)
    shutil.copyfile(journal, journal_path(p))
    p.unlink()
    s = repair_session(p)
    assert s.n_frames == 90
    raw = p.read_bytes()
    with h5py.File(p, "r") as f:
        c = int(f["counts"].chunks[0])  # repair writes the default chunking
    for back in (1, 50, 200, 1000):
        cutp = tmp_path / f"cut{back}.h5"
        cutp.write_bytes(raw[:-back])
        ok = check_device(load_session(cutp), d, chunk_ends(p, "/", FRAME_SETS["psm"]), c, len(raw) - back,
                          f"{back} bytes short")
        assert not ok.all()


# ---------------------------------------------------------------------- the superblock
def _rot(x: int, k: int) -> int:
    return ((x << k) | (x >> (32 - k))) & 0xFFFFFFFF


def lookup3(data: bytes, init: int = 0) -> int:
    """Bob Jenkins' lookup3 ``hashlittle`` (HDF5's metadata checksum), written from its published description."""
    m = 0xFFFFFFFF
    a = b = c = (0xDEADBEEF + len(data) + init) & m
    rest = len(data)
    i = 0
    word = lambda j: int.from_bytes(data[j : j + 4].ljust(4, b"\0"), "little")  # noqa: E731
    while rest > 12:
        a, b, c = (a + word(i)) & m, (b + word(i + 4)) & m, (c + word(i + 8)) & m
        a = ((a - c) & m) ^ _rot(c, 4); c = (c + b) & m  # noqa: E702
        b = ((b - a) & m) ^ _rot(a, 6); a = (a + c) & m  # noqa: E702
        c = ((c - b) & m) ^ _rot(b, 8); b = (b + a) & m  # noqa: E702
        a = ((a - c) & m) ^ _rot(c, 16); c = (c + b) & m  # noqa: E702
        b = ((b - a) & m) ^ _rot(a, 19); a = (a + c) & m  # noqa: E702
        c = ((c - b) & m) ^ _rot(b, 4); b = (b + a) & m  # noqa: E702
        rest -= 12
        i += 12
    if rest == 0:
        return c
    tail = data[i:].ljust(12, b"\0")
    a = (a + int.from_bytes(tail[0:4], "little")) & m
    b = (b + int.from_bytes(tail[4:8], "little")) & m
    c = (c + int.from_bytes(tail[8:12], "little")) & m
    c = (c ^ b) - _rot(b, 14) & m
    a = (a ^ c) - _rot(c, 11) & m
    b = (b ^ a) - _rot(a, 25) & m
    c = (c ^ b) - _rot(b, 16) & m
    a = (a ^ c) - _rot(c, 4) & m
    b = (b ^ a) - _rot(a, 14) & m
    c = (c ^ b) - _rot(b, 24) & m
    return c


def forge_eof(raw: bytes, eof: int) -> bytes:
    """``raw`` (superblock version 2 or 3, 8-byte offsets) with its end-of-file address set to ``eof``."""
    assert raw[8] in (2, 3) and raw[9] == 8
    sb = bytearray(raw[:48])
    assert lookup3(bytes(sb[:44])) == int.from_bytes(sb[44:48], "little")  # the checksum is the one HDF5 wrote
    sb[28:36] = eof.to_bytes(8, "little")
    sb[44:48] = lookup3(bytes(sb[:44])).to_bytes(4, "little")
    return bytes(sb) + raw[48:]


def test_a_forged_recorded_size_is_refused(tmp_path: Path) -> None:
    good = write(tmp_path / "good.h5", mat_data(100))
    raw = good.read_bytes()
    p = tmp_path / "forged.h5"
    p.write_bytes(forge_eof(raw, len(raw))[:-10])  # the same size, checksum recomputed: still an honest cut
    assert load_session(p).n_frames == 100
    p.write_bytes(forge_eof(raw, 1 << 40)[:-10])  # a terabyte its datasets do not claim
    with pytest.raises(SessionFormatError, match=r"forged\.h5: .*records 1099511627776 .*not a session file cut"):
        load_session(p)
    p.write_bytes(forge_eof(raw, len(raw) + 100_000))  # a full file that claims a longer one
    with pytest.raises(SessionFormatError, match=r"forged\.h5: .*not a session file cut short"):
        load_session(p)


@pytest.mark.parametrize("libver", ["earliest", "v108", "latest"])  # superblock versions 0, 2, 3
def test_recorded_size_reads_each_superblock_version(tmp_path: Path, libver: str) -> None:
    p = tmp_path / "x.h5"
    with h5py.File(p, "w", libver=libver) as f:
        f.create_dataset("x", data=np.arange(1000.0))
    raw = p.read_bytes()
    assert raw[8] == {"earliest": 0, "v108": 2, "latest": 3}[libver]
    assert recorded_size(raw[:64]) == len(raw)  # HDF5 writes exactly the size it records
    assert recorded_size(b"not an HDF5 file" * 4) is None
    assert recorded_size(raw[:12]) is None


# ---------------------------------------------------------------------- close checks the file before the journal goes
def _corrupting_fsync(monkeypatch: pytest.MonkeyPatch, dataset: str, chunk: int) -> None:
    """Flip a byte of one chunk of the file close() has just written, as a failing disk would, before its check."""
    real = psmat._atomic.fsync_file

    def fsync_then_damage(path: Path) -> None:
        with h5py.File(path, "r") as f:
            info = f[dataset].id.get_chunk_info_by_coord((chunk * 8,) + (0,) * (f[dataset].ndim - 1))
        with open(path, "r+b") as fh:
            fh.seek(int(info.byte_offset) + 1)
            b = fh.read(1)[0]
            fh.seek(int(info.byte_offset) + 1)
            fh.write(bytes([b ^ 0x01]))
        real(path)

    monkeypatch.setattr(psmat._atomic, "fsync_file", fsync_then_damage)  # the writer fsyncs through it


def test_close_keeps_the_journal_when_the_written_file_differs(tmp_path: Path,
                                                               monkeypatch: pytest.MonkeyPatch) -> None:
    d = mat_data(50)
    p = tmp_path / "s.h5"
    w = SessionWriter(p, (4, 4), DEVICE, CAL, META, chunk_frames=8, background=False)
    append(w, d, 7)
    _corrupting_fsync(monkeypatch, "/seq", 2)
    with pytest.raises(RuntimeError, match=r"s\.h5: the session could not be completed \(.*s\.h5\.partial: "
                                           r"/seq frames 16\.\.23 .*the journal .*s\.h5\.journal was kept"):
        w.close()
    assert not p.exists() and not (tmp_path / "s.h5.partial").exists() and journal_path(p).exists()
    monkeypatch.undo()
    s = load_session(p)  # every frame, from the journal
    assert s.recovered and s.n_frames == 50
    np.testing.assert_array_equal(s.counts, d["frames"])
    np.testing.assert_array_equal(s.seq, d["seq"])


def test_a_failed_overwrite_leaves_the_old_file(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    old = mat_data(30, seed=9)
    p = write(tmp_path / "s.h5", old)
    before = p.read_bytes()
    w = SessionWriter(p, (5, 3), IMU_DEV, kind="imu", chunk_frames=8, background=False, overwrite=True)
    append(w, imu_data(20), 4)
    _corrupting_fsync(monkeypatch, "/angles", 0)
    with pytest.raises(RuntimeError, match=r"/angles frames 0\.\.7"):
        w.close()
    assert p.read_bytes() == before and journal_path(p).exists()

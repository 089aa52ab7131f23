"""docs/spec.md §6 integrity promises: a damaged byte costs at most its journal record or HDF5 chunk.

Damage is made by flipping bytes of real files written by :class:`psmat.io.SessionWriter`:
journal records are located from the journal header (fixed-size records), HDF5 chunks from
HDF5's own chunk index (``get_chunk_info``). Every check compares the loaded session with
the arrays that were written.
"""

from __future__ import annotations

import json
import re
import shutil
import zlib
from pathlib import Path

import h5py
import numpy as np
import pytest

from psmat.cli import main
from psmat.io import SessionFormatError, SessionWriter, info, journal_path, load_session, save_product

DEVICE = {"serial": "0000A1B2", "r_o": 2200.0, "v_ref": 3.3, "bits": 12, "fw": "0.1.0", "protocol": 2, "rate": 100}
CAL = {"serial": "0000A1B2", "r_adc": 6.9e6, "r_mux": 145.0}
META = {"subject": "S07", "trial": 2}
PER_FRAME = ("host_time_s", "valid", "seq", "device_time_us")


def data(n: int, shape: tuple[int, ...] = (4, 4)) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(n)
    return {
        "frames": rng.integers(0, 4096, size=(n, *shape), dtype=np.uint16),
        "t": 20.0 + np.arange(n) * 0.01,
        "valid": np.ones(n, bool),
        "seq": np.arange(n, dtype=np.int64) + 7,
        "dt": np.arange(n, dtype=np.int64) * 10_000,
    }


def write_complete(path: Path, d: dict[str, np.ndarray], chunk_frames: int = 8) -> Path:
    with SessionWriter(path, d["frames"].shape[1:], DEVICE, CAL, META, chunk_frames=chunk_frames) as w:
        w.append(d["frames"], d["t"], d["valid"], seq=d["seq"], device_time_us=d["dt"])
        w.set_counters(dropped_frames=3, bytes_discarded=11)
    return path


def journal_only(tmp_path: Path, d: dict[str, np.ndarray], counters_after: int | None = None) -> Path:
    """What a writer killed after its last append leaves: the journal (copied while the writer is open)."""
    w = SessionWriter(tmp_path / "live.h5", d["frames"].shape[1:], DEVICE, CAL, META, background=False)
    try:
        n = d["frames"].shape[0]
        cut = n if counters_after is None else counters_after
        w.append(d["frames"][:cut], d["t"][:cut], d["valid"][:cut], seq=d["seq"][:cut], device_time_us=d["dt"][:cut])
        if counters_after is not None:
            w.set_counters(dropped_frames=5)
            w.append(d["frames"][cut:], d["t"][cut:], d["valid"][cut:], seq=d["seq"][cut:],
                     device_time_us=d["dt"][cut:])
        dst = tmp_path / "killed.h5"
        shutil.copyfile(journal_path(w.path), journal_path(dst))
    finally:
        w.close()
    return dst


def record_offset(jpath: Path, k: int) -> tuple[int, int]:
    """Byte offset of journal record ``k`` and the record size, from the journal header."""
    raw = jpath.read_bytes()
    hlen = int.from_bytes(raw[8:12], "little")
    rsize = int(json.loads(raw[12 : 12 + hlen])["record_bytes"])
    n = (len(raw) - 12 - hlen) // rsize  # whole records after the header
    return len(raw) - n * rsize + k * rsize, rsize


def flip(path: Path, offset: int, mask: int = 0xFF) -> None:
    with open(path, "r+b") as fh:
        fh.seek(offset)
        b = fh.read(1)[0]
        fh.seek(offset)
        fh.write(bytes([b ^ mask]))


def chunk_offsets(path: Path, name: str) -> list[tuple[int, int, int]]:
    """(first frame, byte offset, byte size) of each stored chunk of dataset ``name``."""
    with h5py.File(path, "r") as f:
        ds = f[name]
        out = []
        for i in range(ds.id.get_num_chunks()):
            info = ds.id.get_chunk_info(i)
            out.append((int(info.chunk_offset[0]), int(info.byte_offset), int(info.size)))
    return sorted(out)


# ---------------------------------------------------------------------- journal: resync past a bad record
def test_a_damaged_journal_record_costs_only_that_record(tmp_path: Path) -> None:
    d = data(3000)
    p = journal_only(tmp_path, d)
    off, rsize = record_offset(journal_path(p), 1500)
    flip(journal_path(p), off + rsize // 2)  # one byte in the middle of frame 1500's record
    s = load_session(p)
    keep = np.arange(3000) != 1500
    assert s.n_frames == 2999 and s.recovered and not s.complete
    np.testing.assert_array_equal(s.counts, d["frames"][keep])
    np.testing.assert_array_equal(s.host_time_s, d["t"][keep])
    np.testing.assert_array_equal(s.seq, d["seq"][keep])
    note = [n for n in s.notes if "CRC" in n]
    assert len(note) == 1 and re.search(r"\b1 journal record\b", note[0]) and re.search(r"\b1500\b", note[0])
    assert not any("incomplete last record" in n for n in s.notes)


def test_damaged_records_anywhere_are_each_skipped(tmp_path: Path) -> None:
    d = data(100)
    p = journal_only(tmp_path, d, counters_after=60)  # records: frames 0..59, counters, frames 60..99
    j = journal_path(p)
    for rec in (0, 60, 99):  # the first frame, the counters record, frame 98
        off, rsize = record_offset(j, rec)
        flip(j, off + rsize - 1)  # the CRC's last byte
    with open(j, "ab") as fh:
        fh.write(b"\x00\x01torn")  # and a torn last record
    s = load_session(p)
    keep = np.ones(100, bool)
    keep[[0, 98]] = False
    assert s.n_frames == 98
    np.testing.assert_array_equal(s.counts, d["frames"][keep])
    np.testing.assert_array_equal(s.device_time_us, d["dt"][keep])
    assert s.counters["dropped_frames"] == 0  # the only counters record was damaged
    note = " ".join(s.notes)
    assert re.search(r"\b3 journal records\b", note) and re.search(r"\b0\b", note) and re.search(r"\b98\b", note)
    assert "6 bytes" in note  # the torn tail


def test_any_flipped_journal_byte_is_reported_or_costs_one_record(tmp_path: Path) -> None:
    d = data(20)
    p = journal_only(tmp_path, d, counters_after=10)  # frames 0..9, counters (dropped 5), frames 10..19
    j = journal_path(p)
    raw = j.read_bytes()
    returned = raised = 0
    for off in range(0, len(raw), 3):
        damaged = bytearray(raw)
        damaged[off] ^= 0xFF
        j.write_bytes(bytes(damaged))
        try:
            s = load_session(p)
        except SessionFormatError as e:
            assert "killed.h5" in str(e) and "\n" not in str(e), (off, str(e))
            raised += 1
            continue
        returned += 1
        kept = np.isin(d["seq"], s.seq)  # sequence numbers are unique: which frames came back
        lost_counters = s.counters["dropped_frames"] == 0
        assert s.n_frames + lost_counters >= 19 and s.n_frames == kept.sum(), off  # at most one record lost
        np.testing.assert_array_equal(s.counts, d["frames"][kept], err_msg=f"offset {off}")
        np.testing.assert_array_equal(s.host_time_s, d["t"][kept], err_msg=f"offset {off}")
        np.testing.assert_array_equal(s.valid, d["valid"][kept], err_msg=f"offset {off}")
        np.testing.assert_array_equal(s.device_time_us, d["dt"][kept], err_msg=f"offset {off}")
        assert s.counters["dropped_frames"] in (0, 5), off
        assert s.metadata == META and s.calibration == CAL and s.device["serial"] == DEVICE["serial"], off
    assert returned and raised


# ---------------------------------------------------------------------- HDF5: checksummed chunks
def test_frame_data_carry_checksums(tmp_path: Path) -> None:
    p = write_complete(tmp_path / "c.h5", data(20))
    with h5py.File(p, "r") as f:
        for name in ("counts", *PER_FRAME, "counters"):
            assert f[name].fletcher32, name


@pytest.mark.parametrize("name", ["counts", *PER_FRAME])
def test_a_flipped_byte_in_a_chunk_marks_its_frames_invalid(tmp_path: Path, name: str) -> None:
    d = data(40)
    p = write_complete(tmp_path / "f.h5", d, chunk_frames=8)
    first, off, size = chunk_offsets(p, name)[2]  # frames 16..23
    flip(p, off + size // 2)
    s = load_session(p)
    bad = np.zeros(40, bool)
    bad[first : first + 8] = True
    assert first == 16 and s.n_frames == 40 and s.complete
    np.testing.assert_array_equal(s.valid, ~bad)
    # the damaged dataset's rows hold its "unknown" value; the other datasets lose nothing
    lost = {"counts": 0, "host_time_s": np.nan, "seq": -1, "device_time_us": -1}
    for col, got, want in (("counts", s.counts, d["frames"]), ("host_time_s", s.host_time_s, d["t"]),
                           ("seq", s.seq, d["seq"]), ("device_time_us", s.device_time_us, d["dt"])):
        np.testing.assert_array_equal(got, np.where(_rows(bad, got), lost[col], want) if col == name else want,
                                      err_msg=col)
    note = [n for n in s.notes if name in n]
    assert len(note) == 1 and "16..23" in note[0]


def test_every_chunk_carries_a_crc32_bound_to_its_dataset_and_position(tmp_path: Path) -> None:
    """The CRC-32 tables, recomputed here with zlib from the arrays that were written (docs/spec.md §6)."""
    d = data(20)
    p = write_complete(tmp_path / "crc.h5", d, chunk_frames=8)
    written = {"counts": d["frames"], "host_time_s": d["t"], "valid": d["valid"].astype(np.uint8), "seq": d["seq"],
               "device_time_us": d["dt"]}
    with h5py.File(p, "r") as f:
        for name, arr in written.items():
            t = f["crc32"][name]
            assert t.dtype == np.dtype("<u4") and t.compression is None and not t.fletcher32 and t.chunks is None
            assert int(t.attrs["chunk_frames"]) == 8
            want = [zlib.crc32(f"/{name}".encode() + b"\0" + k.to_bytes(8, "little")
                               + arr[8 * k : 8 * k + 8].astype(arr.dtype.newbyteorder("<")).tobytes())
                    for k in range(3)]  # frames 0..7, 8..15, 16..19
            assert t[()].tolist() == want, name
        counters = np.array([3, 0, 0, 11], "<i8")
        assert int(f["counters"].attrs["crc32"]) == zlib.crc32(b"/counters\0" + bytes(8) + counters.tobytes())


@pytest.mark.parametrize("name", ["counts", "seq"])
def test_a_damaged_crc32_entry_costs_its_chunk_only(tmp_path: Path, name: str) -> None:
    d = data(40)
    p = write_complete(tmp_path / "e.h5", d, chunk_frames=8)
    with h5py.File(p, "r") as f:
        at = f["crc32"][name].id.get_offset() + 4 * 3  # entry 3: frames 24..31
    flip(p, at + 1, mask=0x10)
    s = load_session(p)
    bad = (np.arange(40) >= 24) & (np.arange(40) < 32)
    np.testing.assert_array_equal(s.valid, ~bad)
    np.testing.assert_array_equal(s.counts[~bad], d["frames"][~bad])
    note = [n for n in s.notes if f"/{name}:" in n]
    assert len(note) == 1 and "24..31" in note[0]


def test_a_file_without_crc32_tables_loads_and_says_so(tmp_path: Path) -> None:
    """As psmat wrote it before the CRC-32 tables: still loads, with a note of what it cannot see."""
    d = data(20)
    p = write_complete(tmp_path / "old.h5", d, chunk_frames=8)
    with h5py.File(p, "r+") as f:
        del f["crc32"]
        del f["counters"].attrs["crc32"]
    s = load_session(p)
    assert s.valid.all() and s.counters["dropped_frames"] == 3
    np.testing.assert_array_equal(s.counts, d["frames"])
    assert len(s.notes) == 1 and "Fletcher-32 only" in s.notes[0] and "00 00" in s.notes[0]


def _rows(mask: np.ndarray, like: np.ndarray) -> np.ndarray:
    return mask.reshape(-1, *([1] * (like.ndim - 1)))


def test_a_flipped_bit_making_a_count_above_12_bits_is_never_valid(tmp_path: Path) -> None:
    d = data(300, shape=(16, 16))
    d["frames"] %= 4096
    p = write_complete(tmp_path / "i.h5", d, chunk_frames=256)
    first, off, size = chunk_offsets(p, "counts")[0]
    flip(p, off + 2 * 16 * 16 * 100 + 1)  # the high byte of cell (0, 0) of frame 100
    s = load_session(p)
    assert s.counts[s.valid].max() < 4096  # nothing above 12 bits is returned as valid
    assert not s.valid[100] and s.valid[256:].all()
    np.testing.assert_array_equal(s.counts[256:], d["frames"][256:])


# ---------------------------------------------------------------------- every error is a SessionFormatError
def test_any_flipped_byte_is_reported_or_harmless(tmp_path: Path) -> None:
    """Flip bytes across a whole small file: a clear error, or a session whose valid frames are true."""
    d = data(24)
    good = write_complete(tmp_path / "good.h5", d, chunk_frames=8)
    cop = np.linspace(-3.0, 3.0, 48).reshape(24, 2)
    save_product(good, "cop", cop, {"variant": "CHC"}, "cm")
    raw = good.read_bytes()
    p = tmp_path / "fuzz.h5"
    returned = raised = 0
    for off in range(0, len(raw), 7):
        damaged = bytearray(raw)
        damaged[off] ^= 0xFF
        p.write_bytes(bytes(damaged))
        try:
            s = load_session(p)
        except SessionFormatError as e:
            assert "fuzz.h5" in str(e) and "\n" not in str(e), (off, str(e))
            raised += 1
            continue
        returned += 1
        v = s.valid
        assert s.n_frames == 24, off
        np.testing.assert_array_equal(s.counts[v], d["frames"][v], err_msg=f"offset {off}")
        np.testing.assert_array_equal(s.host_time_s[v], d["t"][v], err_msg=f"offset {off}")
        if v.any():  # (with every frame lost, seq and device_time_us may be all unknown: None)
            np.testing.assert_array_equal(s.seq[v], d["seq"][v], err_msg=f"offset {off}")
            np.testing.assert_array_equal(s.device_time_us[v], d["dt"][v], err_msg=f"offset {off}")
        assert s.metadata == META and s.calibration == CAL and s.device["serial"] == DEVICE["serial"], off
        if s.counters:
            assert s.counters["dropped_frames"] == 3 and s.counters["bytes_discarded"] == 11, off
        else:
            assert any(n.startswith("/counters: damaged") for n in s.notes), off
        if "cop" in s.products:
            np.testing.assert_array_equal(s.products["cop"].data, cop, err_msg=f"offset {off}")
            assert s.products["cop"].params == {"variant": "CHC"} and s.products["cop"].unit == "cm", off
        else:
            assert any("product 'cop' damaged" in n for n in s.notes), off
    assert returned and raised  # both outcomes happened: the flips reached data and metadata


def test_info_on_a_damaged_file_is_one_line_and_exit_1(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    p = write_complete(tmp_path / "root.h5", data(10))
    with h5py.File(p, "r") as f:
        root = h5py.h5o.get_info(f.id).addr  # the root group's object header (its attributes)
    flip(p, root + 20)
    assert main(["info", str(p)]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("psmat info:") and "root.h5" in err[0]


def test_a_damaged_journal_header_is_one_clear_error(tmp_path: Path) -> None:
    p = journal_only(tmp_path, data(10))
    raw = journal_path(p).read_bytes()
    hlen = int.from_bytes(raw[8:12], "little")
    assert b'"subject": "S07"' in raw[12 : 12 + hlen]
    flip(journal_path(p), 12 + raw[12 : 12 + hlen].index(b"S07") + 2, mask=0x01)  # "S07" -> "S06": still JSON
    with pytest.raises(SessionFormatError, match=r"killed\.h5.*journal header damaged"):
        load_session(p)


def test_close_checks_the_journal_it_reads_back(tmp_path: Path) -> None:
    """Damage to the journal while recording: close() keeps the journal, the loader skips the record."""
    d = data(50)
    p = tmp_path / "c.h5"
    w = SessionWriter(p, (4, 4), DEVICE, CAL, META, background=False)
    w.append(d["frames"], d["t"], d["valid"], seq=d["seq"], device_time_us=d["dt"])
    off, rsize = record_offset(journal_path(p), 20)
    flip(journal_path(p), off + 40)
    with pytest.raises(RuntimeError, match=r"c\.h5.*journal damaged.*49 of 50 frames.*journal .* was kept"):
        w.close()
    assert not p.exists() and journal_path(p).exists()
    s = load_session(p)
    keep = np.arange(50) != 20
    assert s.n_frames == 49 and s.recovered
    np.testing.assert_array_equal(s.counts, d["frames"][keep])
    assert any("frame(s) 20 (write order)" in n for n in s.notes)


def test_info_csv_to_an_unwritable_place_is_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    p = write_complete(tmp_path / "ok.h5", data(5))
    assert main(["info", str(p), "--csv", str(tmp_path / "no_such_dir" / "out.csv")]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("psmat info:") and "no_such_dir" in err[0]


def test_lost_host_times_leave_duration_and_rate_defined(tmp_path: Path) -> None:
    d = data(40)  # t = 20 s + k * 10 ms: 100 Hz
    p = write_complete(tmp_path / "t.h5", d, chunk_frames=8)
    first, off, size = chunk_offsets(p, "host_time_s")[0]  # frames 0..7
    flip(p, off + 3)
    s = load_session(p)
    assert first == 0 and np.isnan(s.host_time_s[:8]).all() and not s.valid[:8].any()
    assert s.duration_s == pytest.approx(0.31, abs=1e-9)  # frames 8..39
    assert s.rate_hz == pytest.approx(100.0, rel=1e-9)
    assert "100.00 Hz" in info(s)


def test_a_format_1_file_still_loads_and_says_it_is_unchecked(tmp_path: Path) -> None:
    """Format 1 (before the checksums): no Fletcher-32, variable-length strings, /committed."""
    d = data(12)
    p = tmp_path / "v1.h5"
    with h5py.File(p, "w", libver="latest") as f:
        f.attrs.update({"format": "psmat-session", "format_version": 1, "kind": "psm", "frame_dataset": "counts",
                        "frame_shape": [4, 4], "complete": 1, "n_frames": 12, "created_utc": "2024-05-01T10:00:00"})
        f.create_dataset("counts", data=d["frames"], chunks=(8, 4, 4), maxshape=(None, 4, 4))
        for name, arr in (("host_time_s", d["t"]), ("valid", d["valid"].astype(np.uint8)), ("seq", d["seq"]),
                          ("device_time_us", d["dt"])):
            f.create_dataset(name, data=arr, chunks=(1024,), maxshape=(None,))
        f["committed"] = np.array([12])
        f["counters"] = np.array([1, 2, 3, 4])
        f["counters"].attrs["names"] = ["dropped_frames", "bad_frames", "resyncs", "bytes_discarded"]
        f.create_group("device").attrs["json"] = json.dumps(DEVICE)
        f.create_group("metadata").attrs["json"] = json.dumps(META)
    s = load_session(p)
    assert s.format_version == 1 and s.complete and s.n_frames == 12 and s.valid.all()
    np.testing.assert_array_equal(s.counts, d["frames"])
    np.testing.assert_array_equal(s.seq, d["seq"])
    assert s.device == DEVICE and s.metadata == META and s.calibration is None
    assert s.counters == {"dropped_frames": 1, "bad_frames": 2, "resyncs": 3, "bytes_discarded": 4}
    assert any("carry no checksums" in n and "counts" in n for n in s.notes)


# ---------------------------------------------------------------------- frames=False: metadata and checks only
def test_without_frames_the_same_session_but_no_frame_read(tmp_path: Path) -> None:
    d = data(40)
    p = write_complete(tmp_path / "m.h5", d, chunk_frames=8)
    whole, bare = load_session(p), load_session(p, frames=False)
    assert whole.n_frames == 40 and bare.n_frames == 0
    assert bare.counts.shape == (0, 4, 4) and bare.counts.dtype == whole.counts.dtype
    assert bare.valid.shape == bare.host_time_s.shape == (0,)
    for field in ("metadata", "device", "calibration", "counters", "complete", "created_utc", "format_version",
                  "kind", "notes"):
        assert getattr(bare, field) == getattr(whole, field), field
    # a damaged chunk is seen only by reading it: the full load notes it, the bare one cannot
    first, off, size = chunk_offsets(p, "counts")[1]
    flip(p, off + size // 2)
    assert any("8..15" in n for n in load_session(p).notes)
    assert load_session(p, frames=False).notes == []
    # what is wrong with the file's structure is refused as by the full load
    bad = tmp_path / "bad.h5"
    bad.write_bytes(b"\x89HDF\r\n\x1a\n" + b"\0" * 100)
    for frames in (True, False):
        with pytest.raises(SessionFormatError, match="bad.h5"):
            load_session(bad, frames=frames)

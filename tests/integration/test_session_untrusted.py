"""A session file received from elsewhere never gives back false data (docs/spec.md §6).

Every file here is crafted from a real one written by :class:`psmat.io.SessionWriter`, with
h5py (external storage, virtual datasets, links, other dtypes and shapes, absurd declared
frame counts) or by rewriting its bytes where HDF5's own chunk index says a chunk lies
(``00 00`` <-> ``FF FF`` words, which Fletcher-32 cannot see, and whole chunks moved). Each
change is first shown to get past plain HDF5 (h5py reads it without complaint), then the
loader must refuse the file with one :class:`SessionFormatError` naming it, or load the
damaged chunk's frames as invalid with a note, the other frames as written.
"""

from __future__ import annotations

import json
import tracemalloc
import zlib
from collections.abc import Callable
from pathlib import Path

import h5py
import numpy as np
import pytest

from psmat.cli import main
from psmat.io import SessionFormatError, SessionWriter, journal_path, load_session, save_product
from psmat.io.session import Journal

DEVICE = {"serial": "0000A1B2", "r_o": 2200.0, "v_ref": 3.3, "bits": 12, "fw": "0.1.0", "protocol": 2, "rate": 128}
META = {"subject": "S07", "trial": 2}
PER_FRAME = ("host_time_s", "valid", "seq", "device_time_us")
CHUNK = 8


def data(n: int, shape: tuple[int, ...] = (4, 4), seed: int = 0) -> dict[str, np.ndarray]:
    """Frames with zero cells, host times on a 1/128 s grid, some invalid rows: every dataset has 00 00 words."""
    rng = np.random.default_rng(seed)
    frames = rng.integers(1, 4096, size=(n, *shape), dtype=np.uint16)
    frames[::3, 0] = 0
    k = np.arange(n)
    valid = (k % CHUNK != 2) & (k % CHUNK != 3) & (k % (3 * CHUNK) != 13)  # invalid pairs: 00 00 words
    return {"frames": frames, "t": 20.0 + np.arange(n) / 128.0, "valid": valid,
            "seq": np.arange(n, dtype=np.int64) + 7, "dt": np.arange(n, dtype=np.int64) * 7812}


def write(path: Path, d: dict[str, np.ndarray]) -> Path:
    with SessionWriter(path, d["frames"].shape[1:], DEVICE, None, META, chunk_frames=CHUNK) as w:
        w.append(d["frames"], d["t"], d["valid"], seq=d["seq"], device_time_us=d["dt"])
        w.set_counters(dropped_frames=3, bytes_discarded=11)
    return path


def columns(d: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    return {"counts": d["frames"], "host_time_s": d["t"], "valid": d["valid"].astype(np.uint8), "seq": d["seq"],
            "device_time_us": d["dt"]}


def strip_crc(f: h5py.File) -> None:
    """Make the file look as an older psmat wrote it: no CRC-32 tables."""
    if "crc32" in f:
        del f["crc32"]


def chunks(path: Path, name: str) -> list[tuple[int, int, int]]:
    """(first frame, byte offset, stored bytes) of each chunk of ``name``, from HDF5's chunk index."""
    with h5py.File(path, "r") as f:
        ds = f[name]
        return sorted((int(i.chunk_offset[0]), int(i.byte_offset), int(i.size))
                      for i in (ds.id.get_chunk_info(k) for k in range(ds.id.get_num_chunks())))


def assert_one_error(p: Path, *words: str) -> str:
    with pytest.raises(SessionFormatError) as e:
        load_session(p)
    msg = str(e.value)
    assert p.name in msg and "\n" not in msg, msg
    for w in words:
        assert w in msg, (w, msg)
    return msg


# ---------------------------------------------------------------------- storage that is not in the file
def _external(f: h5py.File, tmp: Path) -> None:
    text = tmp / "passwd"
    text.write_bytes((b"root:x:0:0:root:/root:/bin/bash\ndaemon:x:1:1::/usr/sbin:/usr/sbin/nologin\n" * 8)[:512])
    del f["counts"]
    f.create_dataset("counts", shape=(16, 4, 4), dtype="<u2", external=[(str(text), 0, 512)])


def _virtual(f: h5py.File, tmp: Path) -> None:
    with h5py.File(tmp / "source.h5", "w") as g:
        g["x"] = np.full((16, 4, 4), 1234, np.uint16)
    layout = h5py.VirtualLayout(shape=(16, 4, 4), dtype="<u2")
    layout[:] = h5py.VirtualSource(str(tmp / "source.h5"), "x", shape=(16, 4, 4))
    del f["counts"]
    f.create_virtual_dataset("counts", layout)


def _soft(f: h5py.File, tmp: Path) -> None:
    f.move("counts", "elsewhere")
    f["counts"] = h5py.SoftLink("/elsewhere")


def _external_link(f: h5py.File, tmp: Path) -> None:
    with h5py.File(tmp / "other.h5", "w") as g:
        g.create_dataset("counts", data=np.full((16, 4, 4), 99, np.uint16), chunks=(8, 4, 4), fletcher32=True)
    del f["counts"]
    f["counts"] = h5py.ExternalLink(str(tmp / "other.h5"), "/counts")


def _gzip(f: h5py.File, tmp: Path) -> None:
    arr = f["counts"][()]
    del f["counts"]
    f.create_dataset("counts", data=arr, chunks=(8, 4, 4), maxshape=(None, 4, 4), compression="gzip")


def _named_type(f: h5py.File, tmp: Path) -> None:
    f["products/u16"] = np.dtype("<u2")


CRAFTED: dict[str, tuple[Callable[[h5py.File, Path], None], str]] = {
    "external storage": (_external, "external storage"),
    "virtual dataset": (_virtual, "virtual dataset"),
    "soft link": (_soft, "soft link"),
    "external link": (_external_link, "external link"),
    "gzip filter": (_gzip, "filter"),
    "named datatype": (_named_type, "not a group or a dataset"),
}


@pytest.mark.parametrize("case", sorted(CRAFTED))
def test_data_not_stored_in_the_file_is_refused(tmp_path: Path, case: str, capsys: pytest.CaptureFixture[str]) -> None:
    craft, words = CRAFTED[case]
    p = write(tmp_path / "recv.h5", data(16))
    with h5py.File(p, "r+") as f:
        strip_crc(f)  # as an older psmat wrote it: only the check of what the file holds stands in the way
        craft(f, tmp_path)
    with h5py.File(p, "r") as f:  # plain HDF5 reads it as frames
        assert f["counts"].shape == (16, 4, 4) or case == "named datatype"
        if case != "named datatype":
            f["counts"][()]
    msg = assert_one_error(p, words)
    assert case == "named datatype" or "/counts" in msg
    csv = tmp_path / "out.csv"
    assert main(["info", str(p), "--csv", str(csv)]) == 1 and not csv.exists()
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "recv.h5" in err[0]


def test_external_storage_in_a_stream_is_refused_for_the_whole_file(tmp_path: Path) -> None:
    p = tmp_path / "two.h5"
    with SessionWriter(p, (4, 4), DEVICE, metadata=META, chunk_frames=CHUNK) as w:
        imu = w.add_stream("imu", kind="imu", shape=(5, 3), device={"serial": "IMU1"})
        w.append(np.zeros((4, 4, 4)), np.arange(4.0), np.ones(4, bool))
        imu.append(np.zeros((2, 5, 3)), np.arange(2.0), np.ones(2, bool))
    text = tmp_path / "text"
    text.write_bytes(b"x" * 120)
    with h5py.File(p, "r+") as f:
        del f["streams/imu/angles"]
        f["streams/imu"].create_dataset("angles", shape=(2, 5, 3), dtype="<f4", external=[(str(text), 0, 120)])
    assert_one_error(p, "/streams/imu/angles", "external storage")


# ---------------------------------------------------------------------- dtype, rank and shape against the kind
def _replace(name: str, make: Callable[[dict[str, np.ndarray]], np.ndarray], **attrs: object):
    def craft(f: h5py.File, d: dict[str, np.ndarray]) -> None:
        arr = make(d)
        del f[name]
        if arr.dtype.kind in "SV" or arr.ndim == 0 or 0 in arr.shape[1:]:
            f.create_dataset(name, data=arr)
        else:
            f.create_dataset(name, data=arr, chunks=(CHUNK, *arr.shape[1:]), maxshape=(None, *arr.shape[1:]))
        for k, v in attrs.items():
            f.attrs[k] = v
    return craft


WRONG: dict[str, Callable[[h5py.File, dict[str, np.ndarray]], None]] = {
    "float counts": _replace("counts", lambda d: d["frames"].astype(np.float32)),
    "int8 counts": _replace("counts", lambda d: d["frames"].astype(np.int8)),
    "bytes counts": _replace("counts", lambda d: d["frames"].reshape(16, -1).view("S2")),
    "compound counts": _replace("counts", lambda d: d["frames"].view([("a", "<u2")])[..., 0]),
    "frames (256,)": _replace("counts", lambda d: np.zeros((16, 256), np.uint16)),
    "frames (1, 1)": _replace("counts", lambda d: np.zeros((16, 1, 1), np.uint16)),
    "frames (16, 0) declared": _replace("counts", lambda d: np.zeros((16, 16, 0), np.uint16),
                                       frame_shape=np.array([16, 0])),
    "frames (16, 16) in an imu file": _replace("counts", lambda d: np.zeros((16, 16, 16), np.uint16),
                                               kind=b"imu", frame_shape=np.array([16, 16])),
    "imu angles of 16 x 16 counts": _replace("angles", lambda d: np.zeros((16, 16, 16), np.uint16),
                                             kind=b"imu", frame_dataset=b"angles", frame_shape=np.array([16, 16])),
    "float valid": _replace("valid", lambda d: d["valid"].astype(np.float64)),
    "int32 seq": _replace("seq", lambda d: d["seq"].astype(np.int32)),
    "host times of rank 2": _replace("host_time_s", lambda d: np.stack([d["t"], d["t"]], axis=1)),
    "one frame short": _replace("device_time_us", lambda d: d["dt"][:-1]),
    "n_frames 17": _replace("seq", lambda d: d["seq"], n_frames=np.int64(17)),
}


@pytest.mark.parametrize("case", sorted(WRONG))
def test_datasets_must_have_the_kinds_dtype_rank_and_shape(tmp_path: Path, case: str) -> None:
    d = data(16)
    p = write(tmp_path / "kind.h5", d)
    with h5py.File(p, "r+") as f:
        strip_crc(f)  # no CRC table to disagree: the kind alone must decide
        if "imu angles" in case:
            f.move("counts", "angles")
        WRONG[case](f, d)
    assert_one_error(p)


# ---------------------------------------------------------------------- declared frames that are not there
def _claim(p: Path, declared: int, layout: str) -> None:
    with h5py.File(p, "r+") as f:
        strip_crc(f)
        for name in ("counts", *PER_FRAME):
            if layout == "chunked":  # the extent grows, no chunk is written
                f[name].resize(declared, axis=0)
            else:  # contiguous datasets of that extent, never written
                ds = f[name]
                shape, dt = (declared, *ds.shape[1:]), ds.dtype
                del f[name]
                f.create_dataset(name, shape=shape, dtype=dt)
        f.attrs["n_frames"] = np.int64(declared)


@pytest.mark.parametrize("layout", ["chunked", "contiguous"])
@pytest.mark.parametrize("declared", [2_000_000, 100_000_000])
def test_frames_declared_but_not_stored_are_refused_with_little_memory(tmp_path: Path, declared: int,
                                                                       layout: str) -> None:
    p = write(tmp_path / "big.h5", data(16, shape=(16, 16)))
    _claim(p, declared, layout)
    assert p.stat().st_size < 64_000  # a few kB that claim 1 GB and more
    tracemalloc.start()
    try:
        msg = assert_one_error(p, "stores")
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 8 * 2**20, (peak, msg)  # what was allocated while loading: nothing like the claimed frames


# ---------------------------------------------------------------------- what Fletcher-32 cannot see
def _aligned_words(raw: bytes, start: int, size: int) -> list[int]:
    """File offsets of the 16-bit words 00 00 or FF FF of a chunk's data (Fletcher-32 sums aligned words)."""
    w = np.frombuffer(raw[start : start + size - 4], dtype=">u2")  # the last 4 bytes: the checksum
    return [start + 2 * int(k) for k in np.flatnonzero((w == 0) | (w == 0xFFFF))]


def swap_unseen_word(p: Path, name: str, off: int, size: int, rng: np.random.Generator) -> int:
    """Turn a 00 00 word of the chunk at ``off`` into FF FF (or back) where Fletcher-32 misses it; its offset.

    Fletcher-32 sums words modulo 65535, where 0x0000 and 0xFFFF are equal; HDF5's partial
    reductions still tell them apart at some positions, so the words are tried in a seeded
    order and the first one plain HDF5 reads back changed, without complaint, is kept.
    """
    good = p.read_bytes()
    with h5py.File(p, "r") as f:
        want = f[name][()]
    for at in rng.permutation(_aligned_words(good, off, size)):
        at = int(at)
        raw = bytearray(good)
        raw[at : at + 2] = b"\xff\xff" if raw[at : at + 2] == b"\x00\x00" else b"\x00\x00"
        p.write_bytes(bytes(raw))
        with h5py.File(p, "r") as f:
            try:
                got = f[name][()]
            except OSError:  # Fletcher-32 saw this one
                continue
        assert not np.array_equal(got, want)
        return at
    raise AssertionError(f"every 00 00 / FF FF word of {name} at {off} is seen by Fletcher-32")


@pytest.mark.parametrize("seed", [0, 1, 2])
@pytest.mark.parametrize("name", ["counts", *PER_FRAME])
def test_a_00_ff_word_swap_costs_its_chunk(tmp_path: Path, name: str, seed: int) -> None:
    n = 40
    d = data(n, seed=seed)
    p = write(tmp_path / "w.h5", d)
    rng = np.random.default_rng(seed)
    table = chunks(p, name)
    first, off, size = table[int(rng.integers(len(table)))]
    swap_unseen_word(p, name, off, size, rng)  # plain HDF5 returns the changed values as they are
    s = load_session(p)
    bad = np.zeros(n, bool)
    bad[first : first + CHUNK] = True
    np.testing.assert_array_equal(s.valid, d["valid"] & ~bad)
    np.testing.assert_array_equal(s.counts[~bad], d["frames"][~bad])
    np.testing.assert_array_equal(s.host_time_s[~bad], d["t"][~bad])
    np.testing.assert_array_equal(s.seq[~bad], d["seq"][~bad])
    np.testing.assert_array_equal(s.device_time_us[~bad], d["dt"][~bad])
    note = [x for x in s.notes if f"/{name}:" in x]
    assert len(note) == 1 and f"{first}..{first + CHUNK - 1}" in note[0], s.notes


@pytest.mark.parametrize("name", ["counts", *PER_FRAME])
def test_chunks_swapped_between_positions_cost_their_frames(tmp_path: Path, name: str) -> None:
    n = 40
    d = data(n, seed=5)
    p = write(tmp_path / "s.h5", d)
    table = chunks(p, name)
    (a, oa, sa), (b, ob, sb) = table[1], table[3]
    assert sa == sb
    raw = bytearray(p.read_bytes())
    raw[oa : oa + sa], raw[ob : ob + sb] = raw[ob : ob + sb], raw[oa : oa + sa]
    p.write_bytes(bytes(raw))
    want = columns(d)[name]
    with h5py.File(p, "r") as f:  # each chunk carries its own Fletcher-32: plain HDF5 reads them moved
        got = f[name][()]
    np.testing.assert_array_equal(got[a : a + CHUNK], want[b : b + CHUNK])
    s = load_session(p)
    bad = np.zeros(n, bool)
    bad[a : a + CHUNK] = bad[b : b + CHUNK] = True
    np.testing.assert_array_equal(s.valid, d["valid"] & ~bad)
    np.testing.assert_array_equal(s.counts[~bad], d["frames"][~bad])
    np.testing.assert_array_equal(s.seq[~bad], d["seq"][~bad])
    note = [x for x in s.notes if f"/{name}:" in x]
    assert len(note) == 1 and f"{a}..{a + CHUNK - 1}, {b}..{b + CHUNK - 1}" in note[0], s.notes


def test_a_00_ff_word_swap_in_the_counters_or_a_product_is_seen(tmp_path: Path) -> None:
    p = write(tmp_path / "c.h5", data(16))
    cop = np.linspace(-3.0, 3.0, 32).reshape(16, 2)  # float64: 00 00 words in the low mantissa bytes
    save_product(p, "cop", cop, {"variant": "CHC"}, "cm")
    rng = np.random.default_rng(4)
    for name in ("counters", "products/cop"):
        (_, off, size), *_ = chunks(p, name)
        swap_unseen_word(p, name, off, size, rng)
    with h5py.File(p, "r") as f:  # plain HDF5 returns both changed
        assert f["counters"][()].tolist() != [3, 0, 0, 11] and not np.array_equal(f["products/cop"][()], cop)
    s = load_session(p)
    assert s.counters == {} and any(x.startswith("/counters: damaged") for x in s.notes)
    assert "cop" not in s.products and any("product 'cop' damaged" in x for x in s.notes)


# ---------------------------------------------------------------------- crafted journal headers
def _journal(tmp_path: Path) -> Path:
    """The journal of a killed recording of 6 frames (copied while the writer is open)."""
    d = data(6)
    w = SessionWriter(tmp_path / "live.h5", (4, 4), DEVICE, None, META, background=False)
    try:
        w.append(d["frames"], d["t"], d["valid"], seq=d["seq"], device_time_us=d["dt"])
        dst = tmp_path / "killed.h5"
        journal_path(dst).write_bytes(journal_path(w.path).read_bytes())
    finally:
        w.close()
    return dst


def _rewrite_header(jpath: Path, **changes: object) -> None:
    raw = jpath.read_bytes()
    hlen = int.from_bytes(raw[8:12], "little")
    doc = json.loads(raw[12 : 12 + hlen])
    doc.update(changes)
    hb = json.dumps(doc).encode()
    jpath.write_bytes(raw[:8] + len(hb).to_bytes(4, "little") + hb + zlib.crc32(hb).to_bytes(4, "little")
                      + raw[12 + hlen + 4 :])


HEADERS: dict[str, dict[str, object]] = {
    "negative frame shape": {"frame_shape": [-1, 16]},
    "zero in the frame shape": {"frame_shape": [4, 0]},
    "psm frame of rank 1": {"frame_shape": [16]},
    "unknown kind": {"kind": "eeg"},
    "imu of 4 x 4": {"kind": "imu", "frame_dtype": "<f4"},
    "float psm counts": {"frame_dtype": "<f4"},
    "lsl of float32 samples": {"kind": "lsl", "frame_shape": [16], "frame_dtype": "<f4"},
    "lsl frame of rank 2": {"kind": "lsl", "frame_dtype": "<f8"},
    "4 GiB records": {"frame_shape": [65536, 32768], "payload_bytes": 2**32, "record_bytes": 2**32 + 36},
    "zero chunk frames": {"chunk_frames": 0},
    "boolean chunk frames": {"chunk_frames": True},
    "device a list": {"device": [1, 2]},
    "stream name a path": {"stream": "../evil"},
    "format version 99": {"format_version": 99},
    "another record size": {"record_bytes": 100},
}


@pytest.mark.parametrize("case", sorted(HEADERS))
def test_a_journal_header_with_a_good_crc_is_still_checked_field_by_field(tmp_path: Path, case: str) -> None:
    p = _journal(tmp_path)
    _rewrite_header(journal_path(p), **HEADERS[case])
    with pytest.raises(SessionFormatError, match="journal header is not a psmat journal header"):
        Journal.open(journal_path(p))
    assert_one_error(p, "journal")


def test_a_journal_header_length_beyond_the_file_is_not_read(tmp_path: Path) -> None:
    p = _journal(tmp_path)
    j = journal_path(p)
    raw = bytearray(j.read_bytes())
    raw[8:12] = (2**32 - 16).to_bytes(4, "little")
    j.write_bytes(bytes(raw))
    tracemalloc.start()
    try:
        with pytest.raises(SessionFormatError, match="truncated"):
            Journal.open(j)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 8 * 2**20, peak


def test_an_unwritten_product_is_refused_also_in_a_file_marked_incomplete(tmp_path: Path) -> None:
    p = write(tmp_path / "prod.h5", data(16))
    with h5py.File(p, "r+") as f:
        f["products"].create_dataset("huge", shape=(100_000_000,), dtype="<f8", chunks=(65536,), fletcher32=True)
        f.attrs["complete"] = np.uint8(0)  # an interrupted format-1 file is read with fewer demands on its frames
        f.attrs["format_version"] = 1
    tracemalloc.start()
    try:
        assert_one_error(p, "/products/huge", "stores")
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 8 * 2**20, peak

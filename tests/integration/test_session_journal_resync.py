"""A crash journal resynchronises after inserted or deleted bytes and says which frames are lost.

Records are found by their own framing and CRC, not by their position (docs/spec.md §6): a byte
deleted inside record k costs frame k only, bytes inserted between records cost nothing, a
flipped byte costs its record — and the note names exactly the frames (write order) that are gone.
Seeded sweeps over every kind of damage: insert, delete, flip, 00<->FF words, truncation.
"""

from __future__ import annotations

import json
import random
import shutil
from pathlib import Path

import numpy as np
import pytest

from psmat.io import SessionWriter, journal_path, load_session

N = 120  # frames in the journal
SHAPE = (8, 8)


def frames(n: int) -> np.ndarray:
    k = np.arange(n)[:, None]
    return ((k * 13 + np.arange(SHAPE[0] * SHAPE[1])[None, :] * 5) % 4096).astype(np.uint16).reshape(n, *SHAPE)


@pytest.fixture(scope="module")
def journal(tmp_path_factory: pytest.TempPathFactory) -> tuple[bytes, int, int]:
    """A journal of N frames (every append returned) as bytes, its body offset and record size."""
    d = tmp_path_factory.mktemp("journal")
    path = d / "live.h5"
    w = SessionWriter(path, SHAPE, device={"serial": "RESYNC"}, chunk_frames=16)
    k = np.arange(N)
    for a in range(0, N, 10):
        s = slice(a, a + 10)
        w.append(frames(N)[s], 100.0 + k[s] * 0.01, k[s] % 11 != 5, seq=k[s] + 7, device_time_us=k[s] * 10_000)
    w.flush()
    raw = journal_path(path).read_bytes()
    w.close()
    hlen = int.from_bytes(raw[8:12], "little")
    record = json.loads(raw[12:12 + hlen])["record_bytes"]
    body = 12 + hlen + 4
    assert len(raw) == body + N * record  # the reference: one record per frame, nothing else
    return raw, body, record


def load_damaged(tmp_path: Path, raw: bytes):
    path = tmp_path / "damaged.h5"
    journal_path(path).write_bytes(raw)
    return load_session(path)


def check(s, lost: set[int]) -> None:
    """``s`` holds every frame but ``lost`` (write order), each intact, and its note names ``lost``."""
    keep = np.array([k for k in range(N) if k not in lost])
    np.testing.assert_array_equal(s.counts, frames(N)[keep])
    np.testing.assert_array_equal(s.seq, keep + 7)
    np.testing.assert_array_equal(s.host_time_s, 100.0 + keep * 0.01)
    np.testing.assert_array_equal(s.valid, keep % 11 != 5)
    note = " ".join(s.notes)
    if lost:
        (k,) = lost
        assert f"frame(s) {k} (write order) lost" in note, s.notes
    else:
        assert "(write order) lost" not in note, s.notes


def test_a_deleted_byte_costs_the_frame_it_sat_in(journal, tmp_path: Path) -> None:
    raw, body, rec = journal
    rnd = random.Random(1)
    for _ in range(12):
        k = rnd.randrange(N - 1)  # not the last record: that one becomes a torn tail
        off = body + k * rec + rnd.randrange(rec)
        check(load_damaged(tmp_path, raw[:off] + raw[off + 1:]), {k})


def test_inserted_bytes_between_records_cost_nothing_and_inside_a_record_cost_it(journal, tmp_path: Path) -> None:
    raw, body, rec = journal
    rnd = random.Random(2)
    for _ in range(10):
        k = rnd.randrange(1, N)
        junk = bytes(rnd.randrange(256) for _ in range(rnd.randrange(1, 3 * rec)))
        at = body + k * rec  # a boundary: record k-1 ends, record k begins
        s = load_damaged(tmp_path, raw[:at] + junk + raw[at:])
        check(s, set())
        if len(junk) >= rec // 2:  # a span shorter than half a record is not counted as a record
            assert any("held no record" in n for n in s.notes), s.notes
        off = body + k * rec + rnd.randrange(1, rec)  # inside record k
        check(load_damaged(tmp_path, raw[:off] + junk[: rec // 3] + raw[off:]), {k})


def test_flips_and_word_swaps_cost_their_record(journal, tmp_path: Path) -> None:
    raw, body, rec = journal
    rnd = random.Random(3)
    for _ in range(12):
        k = rnd.randrange(N)
        off = body + k * rec + rnd.randrange(rec - 1)
        b = bytearray(raw)
        if rnd.random() < 0.5:
            b[off] ^= 1 << rnd.randrange(8)
        else:  # 00 00 <-> FF FF: what Fletcher-32 cannot see
            b[off:off + 2] = b"\xff\xff" if b[off:off + 2] != b"\xff\xff" else b"\x00\x00"
        check(load_damaged(tmp_path, bytes(b)), {k})


def test_a_truncated_journal_keeps_every_whole_record(journal, tmp_path: Path) -> None:
    raw, body, rec = journal
    for cut in (body + 5 * rec, body + 5 * rec + 1, body + 77 * rec - 1, len(raw) - 1):
        s = load_damaged(tmp_path, raw[:cut])
        n = (cut - body) // rec
        np.testing.assert_array_equal(s.counts, frames(N)[:n])
        assert ("incomplete last record" in " ".join(s.notes)) == ((cut - body) % rec != 0)


def test_random_bytes_cost_linear_time_and_give_no_frame(journal, tmp_path: Path) -> None:
    """A body of noise (or of zeros, every offset a framing candidate) yields no frame and ends."""
    raw, body, rec = journal
    rnd = np.random.default_rng(4)
    for filler in (rnd.integers(0, 256, 200 * rec, dtype=np.uint8).tobytes(), bytes(200 * rec)):
        s = load_damaged(tmp_path, raw[:body] + filler)
        assert s.n_frames == 0


def test_frames_around_a_damaged_span_keep_their_order(journal, tmp_path: Path) -> None:
    """Three records overwritten by noise of the same length: exactly those three frames are lost."""
    raw, body, rec = journal
    b = bytearray(raw)
    b[body + 40 * rec: body + 43 * rec] = np.random.default_rng(5).integers(0, 256, 3 * rec, dtype=np.uint8).tobytes()
    s = load_damaged(tmp_path, bytes(b))
    keep = np.array([k for k in range(N) if not 40 <= k < 43])
    np.testing.assert_array_equal(s.seq, keep + 7)
    assert "frame(s) 40..42 (write order) lost" in " ".join(s.notes)


def test_repair_keeps_the_journal_copy_untouched(journal, tmp_path: Path) -> None:
    """Reading a damaged journal never modifies it."""
    raw, body, rec = journal
    damaged = raw[:body + 3 * rec + 9] + raw[body + 3 * rec + 10:]
    s = load_damaged(tmp_path, damaged)
    assert s.n_frames == N - 1
    assert journal_path(tmp_path / "damaged.h5").read_bytes() == damaged
    shutil.rmtree(tmp_path, ignore_errors=True)

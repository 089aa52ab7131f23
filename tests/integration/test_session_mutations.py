"""Seeded mutation sweeps over a finished session file: never a wrong frame returned as valid.

Inserted, deleted and flipped bytes and 00<->FF words anywhere in the HDF5 file: the loader either
refuses the file with one SessionFormatError or returns frames of which every one marked valid is
exactly the frame written under its sequence number (docs/spec.md §6).
"""

from __future__ import annotations

import random
from pathlib import Path

import numpy as np
import pytest

from psmat.io import SessionFormatError, SessionWriter, load_session

N, SHAPE = 300, (8, 8)


def frames(n: int) -> np.ndarray:
    k = np.arange(n)[:, None]
    return ((k * 29 + np.arange(64)[None, :] * 3) % 4096).astype(np.uint16).reshape(n, *SHAPE)


@pytest.fixture(scope="module")
def finished(tmp_path_factory: pytest.TempPathFactory) -> bytes:
    path = tmp_path_factory.mktemp("mut") / "s.h5"
    k = np.arange(N)
    with SessionWriter(path, SHAPE, device={"serial": "MUT"}, chunk_frames=32) as w:
        w.append(frames(N), 10.0 + k * 0.01, np.ones(N, bool), seq=k + 1000, device_time_us=k * 10_000)
    return path.read_bytes()


def _mutate(raw: bytes, rnd: random.Random, how: str) -> bytes:
    at = rnd.randrange(len(raw) - 2)
    if how == "delete":
        return raw[:at] + raw[at + 1:]
    if how == "insert":
        return raw[:at] + bytes([rnd.randrange(256)]) + raw[at:]
    b = bytearray(raw)
    if how == "flip":
        b[at] ^= 1 << rnd.randrange(8)
    else:  # 00 00 <-> FF FF
        b[at:at + 2] = b"\xff\xff" if b[at:at + 2] != b"\xff\xff" else b"\x00\x00"
    return bytes(b)


@pytest.mark.parametrize("how", ["delete", "insert", "flip", "word"])
def test_no_mutation_returns_a_wrong_valid_frame(finished: bytes, tmp_path: Path, how: str) -> None:
    rnd = random.Random({"delete": 1, "insert": 2, "flip": 3, "word": 4}[how])
    want = frames(N)
    outcomes = {"refused": 0, "loaded": 0}
    for trial in range(60):
        path = tmp_path / f"m{trial}.h5"
        path.write_bytes(_mutate(finished, rnd, how))
        try:
            s = load_session(path, use_journal=False)
        except SessionFormatError:
            outcomes["refused"] += 1
            continue
        outcomes["loaded"] += 1
        ok = np.asarray(s.valid, bool)
        if s.seq is None:  # the sequence numbers themselves were lost: nothing may be valid
            assert not ok.any()
            continue
        seq = np.asarray(s.seq)
        idx = seq[ok] - 1000
        assert ((idx >= 0) & (idx < N)).all(), (how, trial, s.notes)
        np.testing.assert_array_equal(s.counts[ok], want[idx], err_msg=f"{how} trial {trial}: {s.notes}")
    assert sum(outcomes.values()) == 60

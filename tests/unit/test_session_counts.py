"""Invalid and lost frames are counted from the rows a recording stores, the same way everywhere.

``psmat record``'s summary, ``psmat info`` and the counters stored in the file
(:class:`psmat.acquire.SessionRecorder`) all use :class:`psmat.io.RowTally`; here
they are compared with counts made by hand from the frames that were sent.
"""

from __future__ import annotations

import re
import time
from pathlib import Path

import numpy as np
import pytest

from psmat.acquire import open_device
from psmat.cli import main
from psmat.io import RowTally, SessionWriter, load_session, row_counts
from psmat.protocol import encode_v2
from psmat.twin import Faults, SerialTwin
from hang_guard import HANG_GUARD_S


def _frame(i: int) -> np.ndarray:
    return np.full((16, 16), i, np.uint16)


def _corrupt(packet: bytes) -> bytes:
    """A v2 frame whose header is intact and whose CRC fails: an invalid row."""
    b = bytearray(packet)
    b[40] ^= 0x01
    return bytes(b)


def _wait_until(condition, timeout: float = HANG_GUARD_S) -> None:
    deadline = time.monotonic() + timeout
    while not condition() and time.monotonic() < deadline:
        time.sleep(0.01)
    assert condition(), f"condition still false after the {timeout:g} s hang guard"


def test_rows_decoded_before_recording_are_not_the_recordings(tmp_path: Path) -> None:
    p = tmp_path / "r.h5"
    dev = open_device("loop://", identify=False)
    try:
        with SessionWriter(p, (16, 16), {"serial": "LOOP"}) as w:
            dev.record_to(w)
            for i in (0, 1):  # before start: decoded, not buffered, not recorded
                dev.serial.write(_corrupt(encode_v2(_frame(i), i, 0)))
            _wait_until(lambda: dev.stats.invalid == 2)
            dev.start()
            # sent: seq 10, 11, 12, 13 (corrupted), 14, then 15 and 16 never arrive, 17
            for seq in (10, 11, 12, 13, 14, 17):
                pkt = encode_v2(_frame(seq), seq, 1000 * seq)
                dev.serial.write(_corrupt(pkt) if seq == 13 else pkt)
            _wait_until(lambda: dev.stats.frames + dev.stats.invalid == 2 + 6)
            dev.stop_recording()
    finally:
        dev.close()
    s = load_session(p)
    assert s.n_frames == 6 and s.valid.tolist() == [True, True, True, False, True, True]
    # by hand: one invalid row after start; seq 13's place is taken by that row; 15 and 16 have none
    assert s.counters["bad_frames"] == 1 and s.counters["dropped_frames"] == 2
    rc = row_counts(s)
    assert (rc.frames, rc.invalid, rc.lost, rc.first_seq, rc.last_seq) == (6, 1, 2, 10, 17)


def test_a_tally_fed_in_batches_counts_as_one_fed_at_once() -> None:
    rng = np.random.default_rng(3)
    n = 500
    sent = np.cumsum(rng.integers(1, 4, n))  # gaps of 0..2 frames
    valid = rng.random(n) > 0.1
    seq = np.where(valid, sent, -1)
    # by hand: frames between numbered rows that no row stands for
    known = np.flatnonzero(seq >= 0)
    lost = sum(max(int(seq[j] - seq[i]) - int(j - i), 0) for i, j in zip(known[:-1], known[1:]))
    whole = RowTally().add(valid, seq).counts
    t = RowTally()
    for part in np.array_split(np.arange(n), 17):
        t.add(valid[part], seq[part])
    assert whole == t.counts
    assert (whole.invalid, whole.lost, whole.restarts) == (int((~valid).sum()), lost, 0)


def test_sequence_numbers_wrap_and_restart() -> None:
    top = 2**32 - 2
    rc = RowTally().add(np.ones(5, bool), np.array([top, top + 1, 1, 2, 0]) % 2**32).counts
    # top, 2**32 - 1, (0 lost), 1, 2, then 0: the device restarted
    assert (rc.lost, rc.restarts) == (1, 1)
    assert RowTally().add(np.ones(3, bool), None).counts.lost is None  # no sequence numbers: unknown


def _numbers(pattern: str, text: str) -> tuple[int, ...]:
    m = re.search(pattern, text)
    assert m, (pattern, text)
    return tuple(int(x) for x in m.groups())


@pytest.mark.parametrize("seed", [1, 2])
def test_record_and_info_agree_on_a_noisy_link(tmp_path: Path, capsys: pytest.CaptureFixture[str], seed: int) -> None:
    out = tmp_path / "noisy.h5"
    with SerialTwin("psm", faults=Faults(bit_flip=2e-4, drop_byte=5e-4, seed=seed)) as twin:
        assert main(["record", twin.port, "--seconds", "2", "-o", str(out)]) == 0
    rec = capsys.readouterr().out
    n, bad, lost = _numbers(r"(\d+) frames recorded, (\d+) invalid, (\d+) lost on the wire", rec)
    assert main(["info", str(out)]) == 0
    text = capsys.readouterr().out
    assert _numbers(r"frames\s+(\d+),", text) == (n,)
    assert _numbers(r"invalid\s+(\d+) frames", text) == (bad,)
    assert _numbers(r"lost\s+(\d+) frames", text) == (lost,)
    assert bad > 0 and lost > 0  # the link lost and spoiled frames (how many: the seed and the machine's pace)
    s = load_session(out)
    # by hand, from the stored rows
    assert bad == int((~s.valid).sum())
    known = np.flatnonzero(s.seq >= 0)
    assert lost == sum(max(int(s.seq[j] - s.seq[i]) - int(j - i), 0) for i, j in zip(known[:-1], known[1:]))
    assert s.counters["bad_frames"] == bad and s.counters["dropped_frames"] == lost

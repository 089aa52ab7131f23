"""Device profile and events (markers) of a session: stored, crash-safe, checked (docs/spec.md §6).

Real files throughout: the writer's journals on disk, a writer process killed with SIGKILL,
bytes flipped in the journal and in the finished HDF5 file at offsets found from the format
(the events journal's record size, HDF5's own chunk index).
"""

from __future__ import annotations

import json
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

from psmat.io import SessionFormatError, SessionWriter, journal_path, load_session, repair_session, save_product
from conftest import child_preexec

PROFILE = {"name": "psm16", "kind": "psm", "shape": [4, 3], "pitch_cm": 2.0, "rate_hz": 100,
           "geometry": {"origin_cm": [0.0, 0.0], "x": "+columns", "y": "+rows"}}
LABELS = ["start", "Ωμέγα: eyes closed", "目を閉じる", "pied gauche 👣", 'comma, "quote"\nnewline', ""]
HEADER_BYTES = 16  # magic, length and CRC around the events journal's JSON header
RECORD = 220  # one event record: tag, length, 6 zero bytes, float64 time, 200 label bytes, CRC-32


def frame(k: int) -> np.ndarray:
    return ((k * 5 + np.arange(12)) % 4096).astype(np.uint16).reshape(4, 3)


def write(path: Path, events: list[tuple[float, str]], n: int = 20, profile: dict | None = PROFILE,
          **kw) -> None:
    with SessionWriter(path, (4, 3), device={"serial": "EV1"}, profile=profile, chunk_frames=8, **kw) as w:
        for k in range(n):
            w.append(frame(k), 100.0 + 0.01 * k, True, seq=k)
        for t, label in events:
            w.add_event(t, label)


def events_journal(path: Path) -> Path:
    return path.with_name(path.name + ".events.journal")


def header_len(ej: Path) -> int:
    return HEADER_BYTES + int.from_bytes(ej.read_bytes()[8:12], "little")


# ---------------------------------------------------------------------- round trip
def test_profile_and_events_round_trip_sorted_by_time_in_plain_hdf5(tmp_path) -> None:
    path = tmp_path / "s.h5"
    events = [(100.05, LABELS[1]), (100.01, LABELS[0]), (100.15, LABELS[2]), (100.05, LABELS[3]),
              (99.0, LABELS[4]), (100.2, LABELS[5])]
    write(path, events)
    s = load_session(path)
    assert s.profile == PROFILE
    # sorted by time; two events of one time keep the order they were added in
    assert s.events == [(99.0, LABELS[4]), (100.01, LABELS[0]), (100.05, LABELS[1]), (100.05, LABELS[3]),
                        (100.15, LABELS[2]), (100.2, LABELS[5])]
    assert s.notes == [] and not events_journal(path).exists() and not journal_path(path).exists()
    with h5py.File(path, "r") as f:  # what another HDF5 reader sees
        assert json.loads(f["profile"].attrs["json"]) == PROFILE
        assert f["profile"].attrs["pitch_cm"] == 2.0 and f["profile"].attrs["name"] == b"psm16"
        t, lab = f["events/host_time_s"], f["events/label_utf8"]
        assert t.dtype == np.float64 and lab.dtype == np.uint8 and t.fletcher32 and lab.fletcher32
        assert t.attrs["unit"] == b"s"
        assert bytes(lab[2]).rstrip(b"\0").decode("utf-8") == LABELS[1]
        assert lab.shape == (6, max(len(x.encode("utf-8")) for x in LABELS))
        assert f["events/crc32/host_time_s"].shape == (1,)


def test_no_profile_and_no_events_load_as_none_and_empty(tmp_path) -> None:
    path = tmp_path / "s.h5"
    write(path, [], profile=None)
    s = load_session(path)
    assert s.profile is None and s.events == []
    with h5py.File(path, "r") as f:
        assert "events" not in f and "profile" not in f


def test_a_journal_without_profile_loads_and_the_journal_carries_it_when_given(tmp_path) -> None:
    """A journal of a psmat before profiles has no ``profile`` key: it loads with None."""
    for profile in (None, PROFILE):
        path = tmp_path / f"j{profile is None}.h5"
        w = SessionWriter(path, (4, 3), device={"serial": "EV1"}, profile=profile)
        try:
            w.append(frame(0), 1.0, True)
            w.add_event(1.5, "während")
            raw = journal_path(path).read_bytes()
            head = json.loads(raw[12:12 + int.from_bytes(raw[8:12], "little")])
            assert ("profile" in head) == (profile is not None)
            s = load_session(path)  # the file is not there yet: the journals are read
            assert s.recovered and s.profile == profile and s.events == [(1.5, "während")]
        finally:
            w.close()
        assert load_session(path).profile == profile


def test_products_saved_later_and_repair_keep_profile_and_events(tmp_path) -> None:
    path = tmp_path / "s.h5"
    write(path, [(100.0, "a"), (100.1, "b")])
    save_product(path, "cop", np.zeros((20, 2)), {"method": "test"}, "cm")
    s = load_session(path)
    assert s.events == [(100.0, "a"), (100.1, "b")] and s.profile == PROFILE and "cop" in s.products


# ---------------------------------------------------------------------- bad input
@pytest.mark.parametrize("label, n_bytes", [("x" * 201, 201), ("é" * 100 + "a", 201), ("👣" * 51, 204)])
def test_a_label_over_200_bytes_is_one_value_error_and_nothing_stored(tmp_path, label, n_bytes) -> None:
    path = tmp_path / "s.h5"
    with SessionWriter(path, (4, 3), device={}) as w:
        w.append(frame(0), 0.0, True)
        w.add_event(0.0, "é" * 100)  # exactly 200 bytes: accepted
        with pytest.raises(ValueError) as err:
            w.add_event(0.1, label)
        msg = str(err.value)
        assert "\n" not in msg and "200 bytes" in msg and str(n_bytes) in msg
    assert load_session(path).events == [(0.0, "é" * 100)]


@pytest.mark.parametrize("t, label, exc", [(float("nan"), "a", ValueError), (float("inf"), "a", ValueError),
                                           (True, "a", TypeError), ("1.0", "a", TypeError),
                                           (1.0, b"bytes", TypeError), (1.0, "a\0b", ValueError)])
def test_bad_events_are_refused(tmp_path, t, label, exc) -> None:
    with SessionWriter(tmp_path / "s.h5", (4, 3), device={}) as w:
        with pytest.raises(exc):
            w.add_event(t, label)
        assert w.n_events == 0


def test_events_after_close_and_a_stream_named_events_are_refused(tmp_path) -> None:
    w = SessionWriter(tmp_path / "s.h5", (4, 3), device={})
    with pytest.raises(ValueError, match="reserved"):
        w.add_stream("events", kind="imu", shape=(5, 3), device={})
    w.close()
    with pytest.raises(ValueError, match="closed"):
        w.add_event(1.0, "late")


def test_an_events_journal_left_at_the_path_needs_overwrite(tmp_path) -> None:
    path = tmp_path / "s.h5"
    events_journal(path).write_bytes(b"left over")
    with pytest.raises(FileExistsError):
        SessionWriter(path, (4, 3), device={})
    write(path, [(1.0, "new")], overwrite=True)
    assert load_session(path).events == [(1.0, "new")] and not events_journal(path).exists()


# ---------------------------------------------------------------------- threads
def test_events_from_several_threads_while_frames_are_appended(tmp_path) -> None:
    path = tmp_path / "s.h5"
    with SessionWriter(path, (4, 3), device={}, chunk_frames=16) as w:
        def mark(i: int) -> None:
            for k in range(40):
                w.add_event(i * 1000.0 + k, f"thread {i} event {k}")

        threads = [threading.Thread(target=mark, args=(i,)) for i in range(4)]
        for th in threads:
            th.start()
        for k in range(400):
            w.append(frame(k), float(k), True)
        for th in threads:
            th.join()
    s = load_session(path)
    want = sorted(((i * 1000.0 + k, f"thread {i} event {k}") for i in range(4) for k in range(40)))
    assert s.events == want and s.n_frames == 400


# ---------------------------------------------------------------------- a killed writer
WRITER = textwrap.dedent(
    """
    import os, sys
    import numpy as np
    from psmat.io import SessionWriter

    path, progress, profile = sys.argv[1], sys.argv[2], sys.argv[3]
    fd = os.open(progress, os.O_WRONLY | os.O_CREAT | os.O_APPEND)
    w = SessionWriter(path, (4, 3), device={"serial": "KILL"}, profile={"name": profile, "pitch_cm": 4.0},
                      flush_interval_s=1e6, flush_frames=10**9)
    k = 0
    while True:
        w.append(((k * 5 + np.arange(12)) % 4096).astype(np.uint16).reshape(4, 3), 10.0 + k * 0.01, True)
        if k % 7 == 0:
            w.add_event(10.0 + k * 0.01, "marker %d ✓" % k)
            os.write(fd, b"E %d\\n" % k)   # after add_event returned
        k += 1
    """
)


def test_a_writer_killed_with_sigkill_keeps_every_event_whose_add_event_returned(tmp_path) -> None:
    path = tmp_path / "k.h5"
    progress = tmp_path / "progress.txt"
    script = tmp_path / "writer.py"
    script.write_text(WRITER)
    with open(tmp_path / "stderr.txt", "wb") as err:
        proc = subprocess.Popen([sys.executable, str(script), str(path), str(progress), "psm8"], stderr=err,
                                preexec_fn=child_preexec())
    try:
        deadline = time.monotonic() + 60
        while (progress.read_bytes().count(b"E ") if progress.exists() else 0) < 30:
            assert proc.poll() is None, (tmp_path / "stderr.txt").read_text()
            assert time.monotonic() < deadline, "writer made no progress"
            time.sleep(0.005)
        proc.send_signal(signal.SIGKILL)
        proc.wait(10)
        assert proc.returncode == -signal.SIGKILL
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    acked = [int(line.split()[1]) for line in progress.read_text().splitlines() if line.startswith("E ")]
    s = load_session(path)
    assert not path.exists() and s.recovered and s.profile == {"name": "psm8", "pitch_cm": 4.0}
    got = {label: t for t, label in s.events}
    for k in acked:  # every acknowledged event, with its time and label
        assert got[f"marker {k} ✓"] == 10.0 + k * 0.01
    # at most the one event written but not yet logged when the kill came, and nothing invented
    assert len(s.events) - len(acked) in (0, 1)
    assert [t for t, _ in s.events] == sorted(t for t, _ in s.events)
    r = repair_session(path)
    assert r.complete and r.events == s.events and r.profile == s.profile
    assert not events_journal(path).exists() and not journal_path(path).exists()


# ---------------------------------------------------------------------- damage
@pytest.mark.parametrize("where", [0, 1, 5, 8, 12, 30, 215, 218])  # tag, length, pad, time, label, CRC
def test_a_flipped_byte_in_an_event_record_costs_that_event_only(tmp_path, where) -> None:
    path = tmp_path / "s.h5"
    w = SessionWriter(path, (4, 3), device={})
    try:
        w.append(frame(0), 0.0, True)
        for k in range(6):
            w.add_event(float(k), f"event {k}")
        ej = events_journal(path)
        raw = bytearray(ej.read_bytes())
        assert len(raw) == header_len(ej) + 6 * RECORD
        raw[header_len(ej) + 3 * RECORD + where] ^= 0x40  # the 4th event's record
        ej.write_bytes(bytes(raw))
        s = load_session(path)
        assert s.events == [(float(k), f"event {k}") for k in (0, 1, 2, 4, 5)]
        assert any("1 event record" in n and "damaged" in n for n in s.notes), s.notes
        # the writer reads its journal back before it makes the file: it refuses, keeping the journals
        with pytest.raises(RuntimeError, match="events journal"):
            w.close()
    finally:
        w.close()
    assert not path.exists() and ej.exists() and journal_path(path).exists()
    assert repair_session(path).events == [(float(k), f"event {k}") for k in (0, 1, 2, 4, 5)]


def test_a_cut_events_journal_loses_its_torn_last_record_only(tmp_path) -> None:
    path = tmp_path / "s.h5"
    w = SessionWriter(path, (4, 3), device={})
    try:
        for k in range(3):
            w.add_event(float(k), f"e{k}")
        ej = events_journal(path)
        ej.write_bytes(ej.read_bytes()[:-100])
        s = load_session(path)
        assert s.events == [(0.0, "e0"), (1.0, "e1")]
        assert any("incomplete last record" in n for n in s.notes), s.notes
    finally:
        with pytest.raises(RuntimeError):
            w.close()


def test_an_events_journal_of_another_recording_is_ignored(tmp_path) -> None:
    path, other = tmp_path / "s.h5", tmp_path / "o.h5"
    wo = SessionWriter(other, (4, 3), device={})
    wo.add_event(5.0, "other recording")
    w = SessionWriter(path, (4, 3), device={})
    try:
        w.append(frame(0), 0.0, True)
        events_journal(path).write_bytes(events_journal(other).read_bytes())
        s = load_session(path)
        assert s.events == [] and any("another recording" in n for n in s.notes)
    finally:
        wo.close()
        w.close()  # nothing added through w: its events journal is not read back


def _flip(path: Path, offset: int) -> None:
    with open(path, "r+b") as fh:
        fh.seek(offset)
        b = fh.read(1)[0]
        fh.seek(offset)
        fh.write(bytes([b ^ 0x10]))


@pytest.mark.parametrize("dataset", ["host_time_s", "label_utf8"])
def test_a_flipped_byte_in_the_files_events_costs_that_chunk_of_events_only(tmp_path, dataset) -> None:
    path = tmp_path / "s.h5"
    events = [(float(k), f"event number {k}") for k in range(150)]  # chunks of 64: 0..63, 64..127, 128..149
    write(path, events)
    with h5py.File(path, "r") as f:
        ds = f[f"events/{dataset}"]
        assert ds.chunks[0] == 64
        info = ds.id.get_chunk_info(1)  # HDF5's own index: where chunk 1 lies in the file
        offset = info.byte_offset + info.size // 2
    _flip(path, offset)
    s = load_session(path)
    assert s.events == events[:64] + events[128:]
    assert any("/events" in n and "64..127" in n for n in s.notes), s.notes
    assert s.n_frames == 20 and s.valid.all()  # the frames are not touched


def test_a_word_turned_from_0000_to_ffff_which_fletcher_32_misses_is_seen_by_the_crc(tmp_path) -> None:
    """Fletcher-32 sums 16-bit words mod 65535, where 0x0000 and 0xFFFF are one number."""
    path = tmp_path / "s.h5"
    events = [(float(k), f"e{k}") for k in range(150)]
    write(path, events)
    with h5py.File(path, "r") as f:
        info = f["events/host_time_s"].id.get_chunk_info(1)  # events 64..127; 64.0 is 00 00 .. 50 40
    with open(path, "r+b") as fh:
        fh.seek(info.byte_offset)
        assert fh.read(2) == b"\0\0"
        fh.seek(info.byte_offset)
        fh.write(b"\xff\xff")
    with h5py.File(path, "r") as f:  # HDF5's own checksum passes: only the CRC-32 can tell
        assert f["events/host_time_s"][64] != 64.0
    s = load_session(path)
    assert s.events == events[:64] + events[128:]


# ---------------------------------------------------------------------- untrusted files
def _edited(tmp_path: Path, edit) -> Path:
    path = tmp_path / "s.h5"
    write(path, [(1.0, "a"), (2.0, "b")])
    with h5py.File(path, "r+") as f:
        edit(f)
    return path


def test_an_external_link_in_events_is_refused(tmp_path) -> None:
    path = _edited(tmp_path, lambda f: f["events"].__setitem__("x", h5py.ExternalLink("/etc/passwd", "/d")))
    with pytest.raises(SessionFormatError, match="external link"):
        load_session(path)


def _gzip_labels(f: h5py.File) -> None:
    del f["events/label_utf8"]
    f["events"].create_dataset("label_utf8", data=np.zeros((2, 1), np.uint8), chunks=(2, 1), compression="gzip")


def _string_labels(f: h5py.File) -> None:
    del f["events/label_utf8"]
    f["events"].create_dataset("label_utf8", data=np.array([b"a", b"b"]))


@pytest.mark.parametrize("edit, says", [(_gzip_labels, "filter"), (_string_labels, "not plain numbers")])
def test_a_filtered_or_non_numeric_events_dataset_is_refused(tmp_path, edit, says) -> None:
    with pytest.raises(SessionFormatError, match=says):
        load_session(_edited(tmp_path, edit))


def test_events_of_the_wrong_shape_are_left_out_with_a_note(tmp_path) -> None:
    def float32(f: h5py.File) -> None:
        del f["events/host_time_s"]
        f["events"].create_dataset("host_time_s", data=np.array([1.0, 2.0], np.float32), chunks=(2,),
                                   fletcher32=True)

    s = load_session(_edited(tmp_path, float32))
    assert s.events == [] and s.n_frames == 20 and s.profile == PROFILE
    assert any("events damaged and left out" in n for n in s.notes), s.notes

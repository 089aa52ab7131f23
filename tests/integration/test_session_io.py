"""psmat.io.session (SessionWriter, load_session, ...): round trips, layout, products, CSV export, summary,
errors, threading."""

from __future__ import annotations

import csv
import json
import math
import threading
import time
from pathlib import Path

import h5py
import numpy as np
import pytest

from psmat.io import (
    COUNTER_NAMES,
    FORMAT_NAME,
    FORMAT_VERSION,
    Session,
    SessionFormatError,
    SessionWriter,
    export_csv,
    info,
    journal_path,
    load_session,
    save_product,
    save_products,
)

DEVICE = {"serial": "0000A1B2", "r_o": 2200.0, "v_ref": 3.3, "bits": 12, "fw": "0.1.0", "protocol": 2, "rate": 100}
CAL = {"format": "psmat-calibration", "serial": "0000A1B2", "r_adc": 6.9e6, "r_mux": 145.0, "r_o": 2200.0,
       "v_ref": 3.3, "bits": 12, "date": "2024-05-01", "notes": "bench"}
META = {"subject": "S07", "trial": 2, "condition": "eyes closed", "weight_kg": 71.5}


def psm_data(n: int, shape=(6, 5), seed=0):
    rng = np.random.default_rng(seed)
    frames = rng.integers(0, 4096, size=(n, *shape), dtype=np.uint16)
    t = 50.0 + np.arange(n) * 0.01 + rng.uniform(-1e-3, 1e-3, n)
    valid = rng.random(n) > 0.2
    seq = np.arange(n, dtype=np.int64) + 4_294_967_290  # past a uint32 wrap: unwrapped int64
    dev_t = np.arange(n, dtype=np.int64) * 10_000 + 123
    return frames, t, valid, seq, dev_t


def text(v) -> str:
    """A string attribute as a plain HDF5 reader gets it: fixed-length UTF-8, i.e. bytes in h5py."""
    assert isinstance(v, bytes), type(v)
    return v.decode("utf-8")


def write(path, frames, t, valid, seq=None, dev_t=None, batch=7, **kw):
    kw.setdefault("device", DEVICE)
    with SessionWriter(path, frames.shape[1:], **kw) as w:
        for a in range(0, frames.shape[0], batch):
            b = slice(a, a + batch)
            w.append(frames[b], t[b], valid[b], seq=None if seq is None else seq[b],
                     device_time_us=None if dev_t is None else dev_t[b])
    return path


# ---------------------------------------------------------------------- round trips
def test_psm_roundtrip_exact(tmp_path: Path) -> None:
    frames, t, valid, seq, dev_t = psm_data(103)
    p = write(tmp_path / "a.h5", frames, t, valid, seq, dev_t, calibration=CAL, metadata=META, chunk_frames=16)
    assert not journal_path(p).exists()  # removed on a clean close
    s = load_session(p)
    assert isinstance(s, Session) and s.kind == "psm" and s.complete and not s.recovered
    assert s.counts.dtype == np.uint16 and s.counts.shape == (103, 6, 5)
    np.testing.assert_array_equal(s.counts, frames)
    np.testing.assert_array_equal(s.host_time_s, t)
    np.testing.assert_array_equal(s.valid, valid)
    assert s.valid.dtype == bool
    np.testing.assert_array_equal(s.seq, seq)
    np.testing.assert_array_equal(s.device_time_us, dev_t)
    for k, v in DEVICE.items():
        assert s.device[k] == v
    assert s.device["shape"] == [6, 5]
    assert s.calibration == CAL and s.metadata == META
    assert s.counters == dict.fromkeys(COUNTER_NAMES, 0)
    assert s.products == {}


def test_calibration_object_with_to_dict(tmp_path: Path) -> None:
    from psmat import Calibration

    cal = Calibration(serial="0000A1B2", r_adc=6.9e6, r_mux=145.0, r_o=2200.0, v_ref=3.3, bits=12,
                      date="2024-05-01")
    frames, t, valid, *_ = psm_data(5)
    p = write(tmp_path / "c.h5", frames, t, valid, calibration=cal)
    s = load_session(p)
    assert s.calibration == cal.to_dict()
    assert Calibration.from_dict(s.calibration) == cal


def test_seq_absent_is_none_and_single_frame_append(tmp_path: Path) -> None:
    p = tmp_path / "v1.h5"
    f0 = np.arange(12, dtype=np.uint16).reshape(3, 4)
    with SessionWriter(p, (3, 4), device={"protocol": 1}) as w:
        w.append(f0, 1.5, True)  # one frame, no batch axis
        w.append(np.stack([f0 + 1, f0 + 2]), [1.6, 1.7], [False, True])
        assert w.n_frames == 3
    s = load_session(p)
    assert s.seq is None and s.device_time_us is None
    np.testing.assert_array_equal(s.counts, np.stack([f0, f0 + 1, f0 + 2]))
    np.testing.assert_array_equal(s.valid, [True, False, True])
    np.testing.assert_array_equal(s.host_time_s, [1.5, 1.6, 1.7])


def test_imu_and_daq_roundtrip(tmp_path: Path) -> None:
    rng = np.random.default_rng(3)
    ang = rng.uniform(-180, 180, size=(40, 5, 3)).astype(np.float32)
    t = np.arange(40) * 0.1
    v = np.ones(40, bool)
    p = write(tmp_path / "imu.h5", ang, t, v, kind="imu", device={"device": "imu", "rate": 10})
    s = load_session(p)
    assert s.kind == "imu" and s.counts.dtype == np.float32
    np.testing.assert_array_equal(s.counts, ang)
    with h5py.File(p, "r") as f:
        assert text(f["angles"].attrs["unit"]) == "deg" and "counts" not in f

    daq = rng.integers(0, 1024, size=(21, 10)).astype(np.uint16)
    p2 = write(tmp_path / "daq.h5", daq, np.arange(21) * 0.5, np.ones(21, bool), kind="daq", device={"device": "daq"})
    s2 = load_session(p2)
    assert s2.kind == "daq" and s2.counts.shape == (21, 10)
    np.testing.assert_array_equal(s2.counts, daq)


def test_layout_readable_with_plain_h5py(tmp_path: Path) -> None:
    frames, t, valid, seq, dev_t = psm_data(30)
    p = tmp_path / "l.h5"
    with SessionWriter(p, (6, 5), DEVICE, CAL, META, chunk_frames=8) as w:
        w.append(frames, t, valid, seq=seq, device_time_us=dev_t)
        w.set_counters(dropped_frames=4, resyncs=1)
    with h5py.File(p, "r") as f:
        assert text(f.attrs["format"]) == FORMAT_NAME and int(f.attrs["format_version"]) == FORMAT_VERSION == 2
        assert text(f.attrs["kind"]) == "psm" and int(f.attrs["complete"]) == 1 and int(f.attrs["n_frames"]) == 30
        assert "committed" not in f  # format 1's SWMR bookkeeping is gone
        np.testing.assert_array_equal(f.attrs["frame_shape"], [6, 5])
        d = f["counts"]
        assert d.dtype == np.uint16 and d.shape == (30, 6, 5)
        assert d.maxshape == (None, 6, 5) and d.chunks == (8, 6, 5)
        np.testing.assert_array_equal(d[()], frames)
        assert f["valid"].dtype == np.uint8 and f["seq"].dtype == np.int64
        np.testing.assert_array_equal(f["host_time_s"][()], t)
        # units on every dataset
        units = {}
        f.visititems(lambda n, o: units.__setitem__(n, o.attrs.get("unit")) if isinstance(o, h5py.Dataset) else None)
        assert all(u is not None for u in units.values()), units
        assert text(units["counts"]) == "count" and text(units["host_time_s"]) == "s"
        assert text(units["device_time_us"]) == "us"
        # device description as separate attributes and as JSON
        g = f["device"].attrs
        assert text(g["serial"]) == "0000A1B2" and g["r_o"] == 2200.0 and g["v_ref"] == 3.3 and g["bits"] == 12
        assert text(g["fw"]) == "0.1.0" and g["protocol"] == 2 and g["rate"] == 100
        assert json.loads(g["json"])["serial"] == "0000A1B2"
        assert f["calibration"].attrs["r_adc"] == 6.9e6 and json.loads(f["calibration"].attrs["json"]) == CAL
        assert text(f["metadata"].attrs["subject"]) == "S07"
        names = [text(x) for x in f["counters"].attrs["names"]]
        c = dict(zip(names, f["counters"][()].tolist()))
        assert c["dropped_frames"] == 4 and c["resyncs"] == 1
    s = load_session(p)
    assert s.counters["dropped_frames"] == 4 and s.counters["resyncs"] == 1 and s.counters["bad_frames"] == 0


def test_no_pickles_or_object_dtypes(tmp_path: Path) -> None:
    frames, t, valid, seq, dev_t = psm_data(10)
    p = write(tmp_path / "np.h5", frames, t, valid, seq, dev_t, calibration=CAL, metadata=META)
    save_product(p, "cop", np.zeros((10, 2)), {"method": "x"}, "cm")
    with h5py.File(p, "r") as f:
        def check(name, obj):
            if isinstance(obj, h5py.Dataset):
                assert obj.dtype.kind in "uif", (name, obj.dtype)
                assert obj.dtype.names is None
        f.visititems(check)


# ---------------------------------------------------------------------- flushing and threads
def test_flush_policy_by_frames(tmp_path: Path) -> None:
    p = tmp_path / "f.h5"
    frames, t, valid, *_ = psm_data(25)
    w = SessionWriter(p, (6, 5), DEVICE, background=False, flush_frames=10, flush_interval_s=1e6)
    try:
        w.append(frames[:9], t[:9], valid[:9])
        assert w.n_frames == 9 and w.n_synced == 0  # in the journal, not yet fsync'd
        assert not p.exists()  # the HDF5 file appears, complete, when the writer closes
        with pytest.raises(FileNotFoundError):
            load_session(p, use_journal=False)
        assert load_session(p).n_frames == 9  # the journal has them
        w.append(frames[9:12], t[9:12], valid[9:12])  # 12 unsynced >= 10 -> sync
        assert w.n_synced == 12
        w.append(frames[12:15], t[12:15], valid[12:15])
        assert w.n_synced == 12
        w.flush()
        assert w.n_synced == 15
    finally:
        w.close()
    s = load_session(p)
    assert s.complete and s.n_frames == 15 and not journal_path(p).exists()
    np.testing.assert_array_equal(s.counts, frames[:15])


def test_flush_policy_by_time(tmp_path: Path) -> None:
    p = tmp_path / "ft.h5"
    frames, t, valid, *_ = psm_data(4)
    with SessionWriter(p, (6, 5), DEVICE, flush_frames=10**6, flush_interval_s=0.05) as w:
        w.append(frames[:2], t[:2], valid[:2])
        deadline = time.monotonic() + 30  # a hang guard
        while w.n_synced < 2:
            assert time.monotonic() < deadline, "background sync did not happen"
            time.sleep(0.02)


def test_append_never_waits_for_a_sync(tmp_path: Path) -> None:
    """A reader thread appends small batches while the journal sync is stuck (a slow disk): all return."""
    n_batches, bs = 600, 3
    frames, t, valid, seq, dev_t = psm_data(n_batches * bs, shape=(16, 16), seed=5)
    p = tmp_path / "thr.h5"
    w = SessionWriter(p, (16, 16), DEVICE, flush_frames=100, flush_interval_s=3600)
    orig = w._sync
    stuck, release = threading.Event(), threading.Event()

    def stuck_sync() -> None:  # the background sync hangs until the test releases it
        stuck.set()
        release.wait()
        orig()

    w._sync = stuck_sync  # type: ignore[method-assign]

    def reader() -> None:
        for b in range(n_batches):
            sl = slice(b * bs, (b + 1) * bs)
            w.append(frames[sl], t[sl], valid[sl], seq=seq[sl], device_time_us=dev_t[sl])
            if b == 34:  # 105 frames >= flush_frames: the sync has been asked for
                stuck.wait(30)

    th = threading.Thread(target=reader)
    th.start()
    th.join(60)
    done = not th.is_alive()
    release.set()
    th.join()
    assert stuck.is_set() and done  # every append returned while the sync was stuck
    assert w.n_frames == n_batches * bs
    w.close()
    s = load_session(p)
    np.testing.assert_array_equal(s.counts, frames)
    np.testing.assert_array_equal(s.seq, seq)
    np.testing.assert_array_equal(s.host_time_s, t)


def test_concurrent_appends_keep_batches_whole(tmp_path: Path) -> None:
    p = tmp_path / "cc.h5"
    with SessionWriter(p, (2, 2), DEVICE, flush_frames=7) as w:
        def worker(k: int) -> None:
            for b in range(50):
                fr = np.full((4, 2, 2), k, np.uint16)
                w.append(fr, np.full(4, float(k)), np.ones(4, bool), seq=np.full(4, b))
        ths = [threading.Thread(target=worker, args=(k,)) for k in range(4)]
        for th in ths:
            th.start()
        for th in ths:
            th.join()
    s = load_session(p)
    assert s.n_frames == 800
    blocks = s.counts[:, 0, 0].reshape(-1, 4)
    assert np.all(blocks == blocks[:, :1])  # no interleaving inside a batch
    np.testing.assert_array_equal(s.host_time_s, s.counts[:, 1, 1].astype(float))
    for k in range(4):
        sq = s.seq[s.counts[:, 0, 0] == k].reshape(-1, 4)[:, 0]
        np.testing.assert_array_equal(sq, np.arange(50))  # each thread's order kept


# ---------------------------------------------------------------------- validation
def test_append_validation(tmp_path: Path) -> None:
    with SessionWriter(tmp_path / "v.h5", (2, 3), DEVICE) as w:
        with pytest.raises(ValueError, match="shape"):
            w.append(np.zeros((1, 3, 2), np.uint16), [0.0], [True])
        with pytest.raises(ValueError, match="range"):
            w.append(np.full((1, 2, 3), 70000), [0.0], [True])
        with pytest.raises(ValueError, match="host_time_s"):
            w.append(np.zeros((2, 2, 3), np.uint16), [0.0], [True, True])
        with pytest.raises(ValueError, match="unknown counter"):
            w.set_counters(dropped=1)
        w.append(np.zeros((1, 2, 3), np.uint16), [0.0], [True])
    with pytest.raises(ValueError, match="closed"):
        w.append(np.zeros((1, 2, 3), np.uint16), [0.0], [True])
    with pytest.raises(FileExistsError):
        SessionWriter(tmp_path / "v.h5", (2, 3), DEVICE)
    with pytest.raises(ValueError, match="kind"):
        SessionWriter(tmp_path / "k.h5", (2, 3), DEVICE, kind="xyz")
    with SessionWriter(tmp_path / "v.h5", (2, 3), DEVICE, overwrite=True) as w:
        pass
    assert load_session(tmp_path / "v.h5").n_frames == 0


# ---------------------------------------------------------------------- errors on load
def test_missing_file(tmp_path: Path) -> None:
    p = tmp_path / "nope.h5"
    with pytest.raises(FileNotFoundError, match="nope.h5"):
        load_session(p)


def test_not_hdf5(tmp_path: Path) -> None:
    p = tmp_path / "text.h5"
    p.write_text("time,x\n1,2\n")
    with pytest.raises(SessionFormatError, match=r"text\.h5.*not an HDF5 file"):
        load_session(p)


def test_hdf5_but_not_session(tmp_path: Path) -> None:
    p = tmp_path / "other.h5"
    with h5py.File(p, "w") as f:
        f["x"] = np.arange(3)
    with pytest.raises(SessionFormatError, match=r"other\.h5.*not a psmat session"):
        load_session(p)


def test_newer_version_rejected(tmp_path: Path) -> None:
    frames, t, valid, *_ = psm_data(3)
    p = write(tmp_path / "new.h5", frames, t, valid)
    with h5py.File(p, "r+") as f:
        f.attrs["format_version"] = 99
    with pytest.raises(SessionFormatError, match=r"new\.h5.*version 99"):
        load_session(p)


def test_corrupt_truncated_file(tmp_path: Path) -> None:
    """Cut inside its metadata (the first bytes): one clear error (a cut among the frames: test_session_truncated)."""
    frames, t, valid, *_ = psm_data(2000, shape=(16, 16))
    p = write(tmp_path / "trunc.h5", frames, t, valid, batch=500)
    raw = p.read_bytes()
    p.write_bytes(raw[:2000])
    with pytest.raises(SessionFormatError, match=r"trunc\.h5.*truncated at byte 2000 of"):
        load_session(p)


def test_corrupt_inconsistent_lengths(tmp_path: Path) -> None:
    frames, t, valid, *_ = psm_data(10)
    p = write(tmp_path / "len.h5", frames, t, valid)
    with h5py.File(p, "r+") as f:
        f["valid"].resize((7,))
    with pytest.raises(SessionFormatError, match=r"len\.h5.*disagree"):
        load_session(p)


# ---------------------------------------------------------------------- products
def test_products_roundtrip(tmp_path: Path) -> None:
    frames, t, valid, *_ = psm_data(12)
    p = write(tmp_path / "prod.h5", frames, t, valid)
    G = np.random.default_rng(1).uniform(1e-6, 1e-2, size=(12, 6, 5))
    cop = np.random.default_rng(2).normal(size=(12, 2))
    save_product(p, "G", G, {"circuit": {"r_o": 2200.0, "r_mux": 145.0}, "calibration_serial": "0000A1B2"}, "S")
    save_product(p, "cop", cop, {"variant": "CHC", "pitch_cm": 2.0, "iecm": True}, "cm")
    s = load_session(p)
    assert set(s.products) == {"G", "cop"}
    np.testing.assert_array_equal(s.products["G"].data, G)
    assert s.products["G"].unit == "S"
    assert s.products["G"].params == {"circuit": {"r_o": 2200.0, "r_mux": 145.0}, "calibration_serial": "0000A1B2"}
    assert s.products["cop"].params == {"variant": "CHC", "pitch_cm": 2.0, "iecm": True}
    # replace
    save_product(p, "cop", cop[:, ::-1], {"variant": "FP"}, "cm")
    s = load_session(p)
    np.testing.assert_array_equal(s.products["cop"].data, cop[:, ::-1])
    assert s.products["cop"].params == {"variant": "FP"}
    np.testing.assert_array_equal(s.counts, frames)  # raw data untouched
    with h5py.File(p, "r") as f:
        assert text(f["products/cop"].attrs["variant"]) == "FP" and text(f["products/G"].attrs["unit"]) == "S"
    with pytest.raises(ValueError):
        save_product(p, "a/b", cop, {}, "cm")
    with pytest.raises(FileNotFoundError):
        save_product(tmp_path / "none.h5", "x", cop, {}, "cm")


def test_save_product_refuses_unfinished(tmp_path: Path) -> None:
    p = tmp_path / "open.h5"
    w = SessionWriter(p, (2, 2), DEVICE)
    try:
        with pytest.raises(SessionFormatError, match="repair_session"):
            save_product(p, "x", np.zeros(3), {}, "1")
    finally:
        w.close()
    save_product(p, "x", np.zeros(3), {}, "1")


def test_saving_products_never_touches_the_recording_until_complete(tmp_path: Path) -> None:
    """Products go into a copy that replaces the file only when complete: a save that fails midway
    (here the second product's parameters cannot be written) leaves the recording byte for byte."""
    frames, t, valid, *_ = psm_data(12)
    p = write(tmp_path / "keep.h5", frames, t, valid)
    before = p.read_bytes()
    G = np.ones((12, 6, 5))
    with pytest.raises(TypeError):
        save_products(p, {"G": (G, {"ok": 1}, "S"), "bad": (G, {"not json": object()}, "S")})
    assert p.read_bytes() == before
    assert sorted(x.name for x in tmp_path.iterdir()) == ["keep.h5"]  # no temporary file left
    save_products(p, {"G": (G, {"ok": 1}, "S"), "cop": (np.zeros((12, 2)), {}, "cm")})
    s = load_session(p)
    assert set(s.products) == {"G", "cop"} and s.complete
    np.testing.assert_array_equal(s.counts, frames)


# ---------------------------------------------------------------------- CSV
def test_export_csv_psm(tmp_path: Path) -> None:
    frames, t, valid, seq, dev_t = psm_data(17, shape=(3, 4))
    p = write(tmp_path / "e.h5", frames, t, valid, seq, dev_t)
    out = export_csv(load_session(p), tmp_path / "e.csv")
    with open(out, newline="") as fh:
        rows = list(csv.reader(fh))
    names = [f"c_{i}_{q}" for i in range(3) for q in range(4)]
    assert rows[0] == ["time_s", "valid", "seq", *names]
    assert len(rows) == 18
    body = rows[1:]
    np.testing.assert_array_equal([float(r[0]) for r in body], t)
    np.testing.assert_array_equal([r[1] == "1" for r in body], valid)
    np.testing.assert_array_equal([int(r[2]) for r in body], seq)
    cells = np.array([[int(x) for x in r[3:]] for r in body])
    np.testing.assert_array_equal(cells, frames.reshape(17, 12))
    # c_i_p names are row-major: column c_2_1 is frames[:, 2, 1]
    col = rows[0].index("c_2_1")
    np.testing.assert_array_equal([int(r[col]) for r in body], frames[:, 2, 1])

    # invalid frames blanked on request; unknown seq is empty
    p2 = write(tmp_path / "e2.h5", frames, t, valid)
    export_csv(p2, tmp_path / "e2.csv", missing="")
    with open(tmp_path / "e2.csv", newline="") as fh:
        rows = list(csv.reader(fh))[1:]
    for r, v in zip(rows, valid):
        assert r[2] == ""
        assert (r[3:] == [""] * 12) == (not v)


def test_export_csv_imu(tmp_path: Path) -> None:
    ang = np.random.default_rng(9).uniform(-180, 180, size=(8, 5, 3)).astype(np.float32)
    p = write(tmp_path / "i.h5", ang, np.arange(8) * 0.1, np.ones(8, bool), kind="imu", device={})
    export_csv(load_session(p), tmp_path / "i.csv")
    with open(tmp_path / "i.csv", newline="") as fh:
        rows = list(csv.reader(fh))
    expect = [f"s{k}_{a}_deg" for k in range(5) for a in ("heading", "roll", "pitch")]
    assert rows[0][3:] == expect
    vals = np.array([[float(x) for x in r[3:]] for r in rows[1:]]).astype(np.float32)
    np.testing.assert_array_equal(vals, ang.reshape(8, 15))  # exact float32 round trip
    col = rows[0].index("s3_pitch_deg")
    np.testing.assert_array_equal(np.float32([float(r[col]) for r in rows[1:]]), ang[:, 3, 2])


# ---------------------------------------------------------------------- info
def test_info_summary(tmp_path: Path) -> None:
    n = 201
    t = 10.0 + np.arange(n) / 125.0  # 125 Hz, 1.6 s
    valid = np.ones(n, bool)
    valid[:20] = False  # 20/201 invalid
    frames = np.zeros((n, 4, 4), np.uint16)
    p = tmp_path / "info.h5"
    with SessionWriter(p, (4, 4), DEVICE, CAL, META) as w:
        w.append(frames, t, valid, seq=np.arange(n))
        w.set_counters(dropped_frames=5)
    save_product(p, "pressure", np.zeros((n, 4, 4)), {"model": "MPICreep"}, "kPa")
    s = load_session(p)
    assert math.isclose(s.rate_hz, (n - 1) / (t[-1] - t[0]))
    assert math.isclose(s.duration_s, 1.6)
    text = info(s)
    assert f"{(n - 1) / 1.6:.2f} Hz" in text  # 125.00 Hz
    assert f"{n} frames" in text or f"frames        {n}" in text
    assert f"{100 * 20 / n:.2f} %" in text
    assert "dropped_frames 5" in text
    assert "0000A1B2" in text and "S07" in text and "r_adc" in text
    assert "pressure" in text and "kPa" in text and "MPICreep" in text
    assert s.path == p and info(p) == text  # the same summary from the path


def test_info_spans_a_device_clock_that_started_again(tmp_path: Path) -> None:
    """A box that restarted: 2 s on its clock, then (restarted at 0.3 s) 1 s more; the span is 3 s in
    two segments, not the last stamp minus the first (-0.7 s)."""
    k = np.arange(30)
    dev = np.r_[np.linspace(0, 2_000_000, 20), np.linspace(300_000, 1_300_000, 10)].astype(np.int64)  # µs
    p = tmp_path / "restart.h5"
    with SessionWriter(p, (4, 4), DEVICE) as w:
        w.append(np.zeros((30, 4, 4), np.uint16), 100.0 + k * 0.1, np.ones(30, bool), seq=np.where(k < 20, k, k - 20),
                 device_time_us=dev)
    text = info(load_session(p))
    assert "device clock  3.000 s span in 2 segments (it started again 1 time(s))" in text


# ---------------------------------------------------------------------- interrupted files (in process)
def _snapshot(w: SessionWriter, dst: Path) -> Path:
    """What a kill at this instant leaves on disk: the journal (the HDF5 file appears only at close)."""
    import shutil

    assert not w.path.exists()
    shutil.copyfile(journal_path(w.path), journal_path(dst))
    return dst


def test_interrupted_snapshot_loads(tmp_path: Path) -> None:
    frames, t, valid, seq, dev_t = psm_data(50)
    w = SessionWriter(tmp_path / "live.h5", (6, 5), DEVICE, CAL, META, background=False,
                      flush_frames=10**6, flush_interval_s=1e6)
    try:
        w.append(frames[:30], t[:30], valid[:30], seq=seq[:30], device_time_us=dev_t[:30])
        w.set_counters(dropped_frames=2)
        w.flush()
        w.append(frames[30:45], t[30:45], valid[30:45], seq=seq[30:45], device_time_us=dev_t[30:45])
        snap = _snapshot(w, tmp_path / "snap.h5")
    finally:
        w.close()
    s = load_session(snap)
    assert s.recovered and not s.complete and s.n_frames == 45 and s.counters["dropped_frames"] == 2
    np.testing.assert_array_equal(s.counts, frames[:45])
    np.testing.assert_array_equal(s.seq, seq[:45])
    np.testing.assert_array_equal(s.valid, valid[:45])
    assert s.calibration == CAL and s.metadata == META
    assert "INTERRUPTED" in info(s)
    with pytest.raises(FileNotFoundError):
        load_session(snap, use_journal=False)

    # a damaged file at PATH (here a truncated session): everything comes from the journal
    other = write(tmp_path / "other.h5", *psm_data(2000, shape=(16, 16))[:3], batch=500)
    snap.write_bytes(other.read_bytes()[: other.stat().st_size // 2])
    s2 = load_session(snap)
    assert s2.recovered and s2.n_frames == 45 and s2.calibration == CAL and s2.device["serial"] == DEVICE["serial"]
    assert any("snap.h5 unusable" in n for n in s2.notes)
    np.testing.assert_array_equal(s2.counts, frames[:45])
    np.testing.assert_array_equal(s2.host_time_s, t[:45])
    # ... and without the journal, the cut file itself: the frames of its chunks before the cut (test_session_truncated)
    s3 = load_session(snap, use_journal=False)
    assert s3.n_frames == 2000 and not s3.valid[-1] and any(n.startswith("file truncated at byte") for n in s3.notes)


def test_repair_session_in_process(tmp_path: Path) -> None:
    from psmat.io import repair_session

    frames, t, valid, *_ = psm_data(20)
    w = SessionWriter(tmp_path / "live.h5", (6, 5), DEVICE, metadata=META, background=False)
    try:
        w.append(frames, t, valid)
        snap = _snapshot(w, tmp_path / "snap.h5")
    finally:
        w.close()
    r = repair_session(snap)
    assert r.complete and r.n_frames == 20 and not journal_path(snap).exists()
    np.testing.assert_array_equal(r.counts, frames)
    np.testing.assert_array_equal(r.valid, valid)
    with h5py.File(snap, "r") as f:  # an ordinary finished file, with checksums
        assert f["counts"].fletcher32 and "frames recovered from the journal" in text(f.attrs["repair_notes"])
    save_product(snap, "x", np.ones(3), {"a": 1}, "1")  # now allowed
    assert "x" in load_session(snap).products

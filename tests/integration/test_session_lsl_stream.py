"""A session stream of kind ``lsl``: another program's Lab Streaming Layer samples, float64 (T, N).

Written with the real writer, loaded from the finished file and from the journals a killed
recording leaves; a file whose ``lsl`` stream has another dtype or rank loads without that stream
(left out, with a note). Expectations are the arrays appended (NaN and sub-ulp values included).
"""

from __future__ import annotations

import shutil
from pathlib import Path

import h5py
import numpy as np
import pytest

from psmat.io import SessionWriter, export_csv, journal_path, load_session, repair_session, \
    stream_csv_path

MAT_DEV = {"serial": "0000A1B2", "protocol": 2, "rate": 100}
FP_DEV = {"device": "lsl", "name": "FP", "type": "Force", "channel_units": ["N", "N", "N"]}


def mat(n: int) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(0)
    return {"frames": rng.integers(0, 4096, (n, 4, 4), dtype=np.uint16), "t": 100.0 + 0.01 * np.arange(n)}


def fp(n: int) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(1)
    v = rng.normal(0.0, 300.0, (n, 3))
    v[4, 1] = np.nan           # a missing channel value stays missing
    v[5, 2] = 1e-300           # float64, not float32: this would flush to 0
    v[6, 0] = 1.0 + 2.0**-40   # nor round
    return {"frames": v, "t": 100.004 + 0.001 * np.arange(n), "dt": np.round((7.5 + 0.001 * np.arange(n)) * 1e6)}


def record(w: SessionWriter, m: dict[str, np.ndarray], f: dict[str, np.ndarray], chunk: int = 7) -> None:
    s = w.add_stream("lsl_FP", kind="lsl", shape=(3,), device=FP_DEV)
    w.append(m["frames"], m["t"], np.ones(len(m["t"]), bool))
    for a in range(0, len(f["t"]), chunk):
        sl = slice(a, a + chunk)
        s.append(f["frames"][sl], f["t"][sl], np.ones(len(f["t"][sl]), bool), seq=None,
                 device_time_us=f["dt"][sl].astype(np.int64))


def assert_fp(st, f: dict[str, np.ndarray]) -> None:
    assert st.kind == "lsl" and st.frame_shape == (3,) and st.counts.dtype == np.float64
    np.testing.assert_array_equal(st.counts, f["frames"])  # NaN where NaN, bit for bit elsewhere
    assert st.counts[5, 2] == 1e-300 and st.counts[6, 0] == 1.0 + 2.0**-40
    np.testing.assert_array_equal(st.host_time_s, f["t"])
    np.testing.assert_array_equal(st.device_time_us, f["dt"].astype(np.int64))
    assert st.seq is None and st.valid.all()
    assert st.device["channel_units"] == ["N", "N", "N"] and st.device["kind"] == "lsl"


def test_an_lsl_stream_is_written_and_loaded_as_appended(tmp_path: Path) -> None:
    m, f = mat(20), fp(40)
    p = tmp_path / "s.h5"
    with SessionWriter(p, (4, 4), MAT_DEV, chunk_frames=8) as w:
        record(w, m, f)
    s = load_session(p)
    assert_fp(s.streams["lsl_FP"], f)
    with h5py.File(p, "r") as h:
        g = h["streams/lsl_FP"]
        assert g.attrs["frame_dataset"] == b"samples" and g["samples"].dtype == np.dtype("<f8")
    out = export_csv(s, tmp_path / "s.csv")
    header = stream_csv_path(out, "lsl_FP").read_text().splitlines()[0]
    assert header == "time_s,valid,seq,ch0,ch1,ch2"


def test_the_journals_of_a_killed_recording_give_the_lsl_stream_back(tmp_path: Path) -> None:
    m, f = mat(20), fp(30)
    w = SessionWriter(tmp_path / "live.h5", (4, 4), MAT_DEV, background=False)
    try:
        record(w, m, f)
        dst = tmp_path / "killed.h5"
        shutil.copyfile(journal_path(w.path), journal_path(dst))
        shutil.copyfile(journal_path(w.path, "lsl_FP"), journal_path(dst, "lsl_FP"))
    finally:
        w.close()
    s = load_session(dst)
    assert s.recovered and s.streams["lsl_FP"].recovered
    assert_fp(s.streams["lsl_FP"], f)
    repair_session(dst)
    assert_fp(load_session(dst).streams["lsl_FP"], f)


def test_lsl_frames_have_one_axis_of_channels(tmp_path: Path) -> None:
    with SessionWriter(tmp_path / "s.h5", (4, 4), MAT_DEV) as w:
        with pytest.raises(ValueError, match=r"an lsl frame shape is \(n_channels,\)"):
            w.add_stream("lsl_x", kind="lsl", shape=(3, 2), device={})
        s = w.add_stream("lsl_y", kind="lsl", shape=2, device={})
        with pytest.raises(TypeError, match="real numbers"):
            s.append(np.array([["a", "b"]]), [1.0], [True])


@pytest.mark.parametrize("case", ["float32 samples", "samples of rank 3"])
def test_an_lsl_stream_of_another_dtype_or_rank_is_refused(tmp_path: Path, case: str) -> None:
    m, f = mat(16), fp(16)
    p = tmp_path / "s.h5"
    with SessionWriter(p, (4, 4), MAT_DEV, chunk_frames=8) as w:
        record(w, m, f)
    with h5py.File(p, "r+") as h:
        g = h["streams/lsl_FP"]
        del g["crc32"]  # no CRC table to disagree: the kind alone must decide
        data = g["samples"][...]
        del g["samples"]
        if case == "float32 samples":
            new = data.astype(np.float32)
        else:
            new = np.repeat(data[:, :, None], 2, axis=2)
            g.attrs["frame_shape"] = np.array([3, 2])
        g.create_dataset("samples", data=new, chunks=(8, *new.shape[1:]), maxshape=(None, *new.shape[1:]),
                         fletcher32=True)
        np.asarray(h["streams/lsl_FP/samples"][...])  # plain HDF5 reads it without complaint
    s = load_session(p)  # a damaged stream costs that stream only: left out, with a note naming why
    assert "lsl_FP" not in s.streams and s.n_frames == 16
    note = [n for n in s.notes if "stream 'lsl_FP' damaged and left out" in n]
    assert len(note) == 1 and ("float32" in note[0] if case == "float32 samples" else "frame shape" in note[0]), s.notes

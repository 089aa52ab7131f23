"""psmat.io.export on real session files: column names with units, every device kind, no events, bad input."""

from __future__ import annotations

import csv

import numpy as np
import pytest

from psmat.io import SessionWriter, export, load_session


def _session(path, kind: str, shape, n: int = 5, events=()):
    with SessionWriter(path, shape, device={}, kind=kind) as w:
        for k in range(n):
            if kind == "imu":
                fr = (np.arange(np.prod(shape)) * 0.5 + k).astype(np.float32).reshape(shape)
            else:
                fr = (np.arange(np.prod(shape)) + k).astype(np.uint16).reshape(shape)
            w.append(fr, 10.0 + k / 8, True)
        for t, label in events:
            w.add_event(t, label)
    return path


def _csv(path):
    with open(path, newline="", encoding="utf-8") as fh:
        return list(csv.reader(fh))


@pytest.mark.parametrize("kind, shape, first, last", [
    ("psm", (16, 16), "r00c00_count", "r15c15_count"),
    ("psm", (2, 101), "r000c000_count", "r001c100_count"),   # three digits past 100 columns
    ("daq", (10,), "s00_count", "s09_count"),
    ("imu", (5, 3), "s0_heading_deg", "s4_pitch_deg"),
])
def test_counts_columns_are_row_major_with_their_unit(tmp_path, kind, shape, first, last) -> None:
    path = _session(tmp_path / "s.h5", kind, shape)
    out = export(path, "counts", "csv", tmp_path / "c.csv")
    rows = _csv(out)
    n_cells = int(np.prod(shape))
    assert rows[0][:2] == ["time_s", "valid"] and len(rows[0]) == 2 + n_cells
    assert rows[0][2] == first and rows[0][-1] == last
    s = load_session(path)
    got = np.array([[float(x) for x in r[2:]] for r in rows[1:]])
    np.testing.assert_array_equal(got, s.counts.reshape(s.n_frames, -1).astype(np.float64))
    if kind == "psm":  # row-major: the column of cell (i, j) is 2 + i * C + j
        i, j = shape[0] - 1, 1
        w = 3 if max(shape) > 100 else 2
        assert rows[0][2 + i * shape[1] + j] == f"r{i:0{w}d}c{j:0{w}d}_count"
        assert float(rows[3][2 + i * shape[1] + j]) == s.counts[2, i, j]


def test_a_session_without_events_exports_an_empty_table_in_every_format(tmp_path) -> None:
    pq = pytest.importorskip("pyarrow.parquet")
    from scipy.io import loadmat

    path = _session(tmp_path / "s.h5", "psm", (3, 3))
    assert _csv(export(path, "events", "csv", tmp_path / "e.csv")) == [["time_s", "label"]]
    t = pq.read_table(export(path, "events", "parquet", tmp_path / "e.parquet"))
    assert t.num_rows == 0 and t.column_names == ["time_s", "label"]
    m = loadmat(export(path, "events", "mat", tmp_path / "e.mat"))
    assert m["time"].size == 0 and m["label"].size == 0


def test_an_in_memory_session_exports_too(tmp_path) -> None:
    s = load_session(_session(tmp_path / "s.h5", "psm", (2, 2), events=[(10.1, "b"), (10.0, "a")]))
    rows = _csv(export(s, "events", "csv", tmp_path / "e.csv"))
    assert rows == [["time_s", "label"], ["10.0", "a"], ["10.1", "b"]]


@pytest.mark.parametrize("what, fmt, says", [("frames", "csv", "what must be one of"),
                                             ("counts", "xlsx", "format must be one of")])
def test_unknown_what_or_format_is_one_value_error(tmp_path, what, fmt, says) -> None:
    path = _session(tmp_path / "s.h5", "psm", (2, 2))
    with pytest.raises(ValueError, match=says):
        export(path, what, fmt, tmp_path / "x")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s.h5"]


def test_pressure_of_an_imu_session_is_refused(tmp_path) -> None:
    path = _session(tmp_path / "s.h5", "imu", (5, 3))
    with pytest.raises(ValueError, match="mats only"):
        export(path, "pressure", "csv", tmp_path / "p.csv")


def test_a_failed_export_leaves_the_existing_file_as_it_was(tmp_path) -> None:
    path = _session(tmp_path / "s.h5", "psm", (2, 2))
    out = tmp_path / "p.csv"
    out.write_text("kept\n")
    with pytest.raises(ValueError, match="run psmat process"):
        export(path, "pressure", "csv", out)
    assert out.read_text() == "kept\n" and sorted(p.name for p in tmp_path.iterdir()) == ["p.csv", "s.h5"]

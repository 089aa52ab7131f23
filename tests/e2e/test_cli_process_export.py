"""``psmat process`` and ``psmat export`` on a real session file, as a person types them.

The session is written with :class:`psmat.io.SessionWriter` from counts that the measurement
chain (:class:`psmat.Circuit`) gives for hand-chosen cell conductances through the crosstalk
model (:func:`psmat.iecm.forward`): ``psmat process`` must give those conductances back (within
the 12-bit ADC's resolution), and every export must hold exactly the arrays the session holds,
read back with the csv module, pyarrow and scipy.io.loadmat.
"""

from __future__ import annotations

import csv
import json
import math
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import psmat
from psmat import iecm
from psmat.io import SessionWriter, load_session

SHAPE = (5, 4)
N = 30
BAD = 7  # the frame the device flagged
CIRCUIT = psmat.Circuit(r_o=2200.0, r_mux=145.0, r_adc=6.9e6, v_ref=3.3, bits=12)
EVENTS = [(100.05, "eyes closed"), (100.0, "start: Ωμέγα"), (100.2, 'pied gauche, "droit" 👣')]


def true_g(k: int) -> np.ndarray:
    """Cell conductances (S) of frame ``k``: a 3 x 2 loaded patch on an unloaded mat (2 µS)."""
    g = np.full(SHAPE, 2e-6)
    g[1:4, 1:3] = np.array([[2e-4, 4e-4], [6e-4, 8e-4], [3e-4, 1e-4]]) * (1.0 + 0.2 * math.sin(k / 5))
    return g


def psmat_cli(*args: str, timeout: float = 300) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "psmat", *map(str, args)], capture_output=True, text=True,
                          timeout=timeout)


def one_line(err: str) -> str:
    lines = err.strip().splitlines()
    assert len(lines) == 1, lines
    return lines[0]


def make_session(path: Path) -> None:
    with SessionWriter(path, SHAPE, device={"serial": "E2E1", "rate": 100}, calibration=CIRCUIT.as_dict(),
                       metadata={"subject": "S01"}, chunk_frames=8) as w:
        for k in range(N):
            counts = CIRCUIT.counts(iecm.forward(true_g(k)))
            w.append(counts, 100.0 + 0.01 * k, k != BAD, seq=k, device_time_us=10_000 * k)
        for t, label in EVENTS:
            w.add_event(t, label)


@pytest.fixture(scope="module")
def processed(tmp_path_factory) -> Path:
    """A session after ``psmat process`` (made once: the export tests only read it)."""
    path = tmp_path_factory.mktemp("processed") / "s01.h5"
    make_session(path)
    r = psmat_cli("process", path)
    assert r.returncode == 0, r.stderr
    return path


# ---------------------------------------------------------------------- psmat process
def test_process_stores_g_pressure_and_cop_and_says_what_it_used(tmp_path) -> None:
    path = tmp_path / "s.h5"
    make_session(path)
    r = psmat_cli("process", path)
    assert r.returncode == 0, r.stderr
    out = r.stdout
    assert f"{N} frames processed, {N - 1} usable" in out
    assert "circuit       the session's stored calibration" in out
    assert "pressure      " in out
    s = load_session(path)
    units = {name: p.unit for name, p in s.products.items()}
    assert units == {"G": "S", "g": "S", "pressure": "kPa", "cop": "cm"}
    assert s.products["pressure"].data.shape == (N, *SHAPE) and s.products["cop"].data.shape == (N, 2)
    ok = np.arange(N) != BAD
    G, g = s.products["G"].data, s.products["g"].data
    assert np.isnan(G[BAD]).all() and np.isnan(s.products["cop"].data[BAD]).all()
    want_G = np.stack([iecm.forward(true_g(k)) for k in range(N)])
    # a 12-bit ADC at these counts resolves G to about 0.5 % (one count in ~1500..4000)
    np.testing.assert_allclose(G[ok], want_G[ok], rtol=0.01)
    # the loaded cells' own conductances come back through IECM (the unloaded ones sit at the ADC's floor)
    want_g = np.stack([true_g(k) for k in range(N)])
    np.testing.assert_allclose(g[ok][:, 1:4, 1:3], want_g[ok][:, 1:4, 1:3], rtol=0.02)
    # the CoP lies among the loaded cells' centres: rows 1..3, columns 1..2 at the stored pitch (M-L along
    # the columns, A-P along the rows, cell (0, 0) at the origin: the default orientation, docs/spec.md §7);
    # the unloaded cells' near-zero pressure moves it by far less than 0.1 cm
    pitch = float(s.products["cop"].params["pitch_cm"])
    cop = s.products["cop"].data[ok]
    assert np.all((cop[:, 0] > 1 * pitch - 0.1) & (cop[:, 0] < 2 * pitch + 0.1)), cop
    assert np.all((cop[:, 1] > 1 * pitch - 0.1) & (cop[:, 1] < 3 * pitch + 0.1)), cop
    assert s.events == sorted(EVENTS)  # products stored, events kept


def test_process_refuses_to_replace_products_without_overwrite(tmp_path) -> None:
    path = tmp_path / "s.h5"
    make_session(path)
    assert psmat_cli("process", path).returncode == 0
    before = path.read_bytes()
    r = psmat_cli("process", path)
    assert r.returncode == 1 and "--overwrite" in one_line(r.stderr) and "already holds" in r.stderr
    assert path.read_bytes() == before
    r = psmat_cli("process", path, "--overwrite")
    assert r.returncode == 0, r.stderr
    assert set(load_session(path).products) == {"G", "g", "pressure", "cop"}


def test_process_of_a_missing_file_is_one_line(tmp_path) -> None:
    r = psmat_cli("process", tmp_path / "none.h5")
    assert r.returncode == 1 and "none.h5" in one_line(r.stderr)


# ---------------------------------------------------------------------- psmat export
def expected_columns(s, what: str) -> dict[str, tuple[np.ndarray, str]]:
    """The columns an export of ``what`` must hold, from the session's own arrays: name -> (values, unit)."""
    R, C = SHAPE
    if what == "events":
        return {"time_s": (np.array([t for t, _ in s.events]), "s"),
                "label": (np.array([lb for _, lb in s.events], dtype=object), "")}
    cols = {"time_s": (s.host_time_s, "s"), "valid": (s.valid.astype(np.uint8), "1")}
    if what == "cop":
        cop = s.products["cop"].data
        return {**cols, "ml_cm": (cop[:, 0], "cm"), "ap_cm": (cop[:, 1], "cm")}
    data, suffix, unit = ((s.counts, "count", "count") if what == "counts"
                          else (s.products["pressure"].data, "kpa", "kPa"))
    for i in range(R):
        for j in range(C):
            cols[f"r{i:02d}c{j:02d}_{suffix}"] = (data[:, i, j], unit)
    return cols


def same(got, want) -> None:
    got, want = np.asarray(got), np.asarray(want)
    if want.dtype == object:
        assert [str(x) for x in got] == [str(x) for x in want]
    else:
        np.testing.assert_array_equal(got.astype(np.float64), want.astype(np.float64))  # NaN == NaN here


@pytest.mark.parametrize("what", ["counts", "pressure", "cop", "events"])
def test_export_csv_has_units_in_its_header_and_the_sessions_values(processed, tmp_path, what) -> None:
    out = tmp_path / f"x.{what}.csv"
    r = psmat_cli("export", processed, "--what", what, "--format", "csv", "-o", out)
    assert r.returncode == 0, r.stderr
    s = load_session(processed)
    want = expected_columns(s, what)
    with open(out, newline="", encoding="utf-8") as fh:
        rows = list(csv.reader(fh))
    assert rows[0] == list(want)
    body = rows[1:]
    for k, (name, (values, _unit)) in enumerate(want.items()):
        col = [row[k] for row in body]
        same(col if values.dtype == object else np.array(col, dtype=np.float64), values)


@pytest.mark.parametrize("what", ["counts", "pressure", "cop", "events"])
def test_export_parquet_reads_back_equal_with_units_in_the_schema(processed, tmp_path, what) -> None:
    pq = pytest.importorskip("pyarrow.parquet")
    out = tmp_path / f"x.{what}.parquet"
    r = psmat_cli("export", processed, "--what", what, "--format", "parquet", "-o", out)
    assert r.returncode == 0, r.stderr
    want = expected_columns(load_session(processed), what)
    t = pq.read_table(out)
    assert t.column_names == list(want)
    units = json.loads(t.schema.metadata[b"psmat.units"])
    assert units == {name: unit for name, (_v, unit) in want.items()}
    for name, (values, unit) in want.items():
        assert t.schema.field(name).metadata[b"unit"].decode() == unit
        same(t.column(name).to_pylist() if values.dtype == object else t.column(name).to_numpy(), values)


@pytest.mark.parametrize("what", ["counts", "pressure", "cop", "events"])
def test_export_mat_reads_back_equal_with_a_units_struct(processed, tmp_path, what) -> None:
    from scipy.io import loadmat

    out = tmp_path / f"x.{what}.mat"
    r = psmat_cli("export", processed, "--what", what, "--format", "mat", "-o", out)
    assert r.returncode == 0, r.stderr
    s = load_session(processed)
    m = loadmat(out, squeeze_me=True, chars_as_strings=True)
    units = m["units"]
    if what == "events":
        same(m["time"], [t for t, _ in s.events])
        assert list(m["label"]) == [lb for _, lb in s.events]
        assert str(units["time"]) == "s"
        return
    same(m["time"], s.host_time_s)
    same(m["valid"], s.valid)
    assert str(units["time"]) == "s" and str(units["valid"]) == "1"
    if what == "counts":
        assert m["counts"].shape == (N, *SHAPE) and m["counts"].dtype == np.uint16
        same(m["counts"], s.counts)
        assert str(units["counts"]) == "count"
    elif what == "pressure":
        same(m["pressure"], s.products["pressure"].data)
        assert str(units["pressure"]) == "kPa"
    else:
        same(m["ml"], s.products["cop"].data[:, 0])
        same(m["ap"], s.products["cop"].data[:, 1])
        assert str(units["ml"]) == "cm" and str(units["ap"]) == "cm"


def test_export_default_out_is_beside_the_session(processed, tmp_path) -> None:
    path = tmp_path / "t1.h5"
    shutil.copyfile(processed, path)
    r = psmat_cli("export", path, "--what", "cop", "--format", "csv")
    assert r.returncode == 0, r.stderr
    assert (tmp_path / "t1.cop.csv").is_file() and "t1.cop.csv" in r.stdout


@pytest.mark.parametrize("what", ["pressure", "cop"])
def test_export_of_pressure_before_process_is_one_line_naming_psmat_process(tmp_path, what) -> None:
    path = tmp_path / "s.h5"
    make_session(path)
    r = psmat_cli("export", path, "--what", what, "--format", "csv")
    assert r.returncode == 1
    assert one_line(r.stderr) == f"psmat export: no {what} in {path}: run psmat process {path} first"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s.h5"]  # nothing written


def test_an_existing_out_is_refused_without_overwrite_and_untouched(processed, tmp_path) -> None:
    out = tmp_path / "mine.csv"
    out.write_text("someone's data\n")
    r = psmat_cli("export", processed, "--what", "counts", "--format", "csv", "-o", out)
    assert r.returncode == 1 and "--overwrite" in one_line(r.stderr)
    assert out.read_text() == "someone's data\n"
    r = psmat_cli("export", processed, "--what", "counts", "--format", "csv", "-o", out, "--overwrite")
    assert r.returncode == 0, r.stderr
    assert out.read_text().startswith("time_s,valid,r00c00_count,")


def test_the_session_itself_is_never_an_output(processed, tmp_path) -> None:
    path = tmp_path / "s.h5"
    shutil.copyfile(processed, path)
    before = path.read_bytes()
    r = psmat_cli("export", path, "--what", "counts", "--format", "csv", "-o", path, "--overwrite")
    assert r.returncode == 1 and "input" in one_line(r.stderr)
    assert path.read_bytes() == before


def test_parquet_without_pyarrow_is_one_line_naming_the_extra(processed, tmp_path) -> None:
    """A pyarrow that fails to import (as when it is not installed) shadows the real one."""
    shadow = tmp_path / "shadow" / "pyarrow"
    shadow.mkdir(parents=True)
    (shadow / "__init__.py").write_text("raise ImportError('No module named pyarrow')\n")
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(shadow.parent), os.environ.get("PYTHONPATH", "")])}
    out = tmp_path / "x.parquet"
    r = subprocess.run([sys.executable, "-m", "psmat", "export", str(processed), "--what", "counts", "--format",
                        "parquet", "-o", str(out)], capture_output=True, text=True, timeout=300, env=env)
    assert r.returncode == 1
    assert "pip install psmat[parquet]" in one_line(r.stderr)
    assert not out.exists()


# ---------------------------------------------------------------------- a session given as a port
@pytest.mark.parametrize("cmd", [["record", "--seconds", "1", "-o", "OUT"]])  # psmat view replays it
def test_a_session_given_as_a_port_names_the_commands_that_read_files(processed, tmp_path, cmd) -> None:
    out = tmp_path / "out.h5"
    args = [a if a != "OUT" else str(out) for a in cmd]
    r = psmat_cli(args[0], processed, *args[1:])
    assert r.returncode == 1
    line = one_line(r.stderr)
    for name in ("psmat process", "psmat export", "psmat info"):
        assert f"{name} {processed}" in line, line
    assert not out.exists()

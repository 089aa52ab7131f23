"""``psmat import`` end to end (docs/spec.md §6): a file in a maker's layout, written here by hand,
becomes a session that loads, exports and reports like any other; a bad file is one line, exit status 1."""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import pytest

from psmat.cli import main
from psmat.io import load_session

MMHG_KPA = 13595.1 * 9.80665 * 1e-3 / 1000.0  # conventional mmHg: mercury's density × g_n × 1 mm


def tekscan(path: Path, values_mmhg: np.ndarray, spf: float = 0.02) -> Path:
    t, r, c = values_mmhg.shape
    lines = ["ASCII_DATA @@", "SENSOR_TYPE 5101", f"ROWS {r}", f"COLS {c}", "ROW_SPACING 0.254 centimeters",
             "COL_SPACING 0.254 centimeters", f"SECONDS_PER_FRAME {spf}", "UNITS mmHg", ""]
    for k in range(t):
        lines += [f"Frame {k + 1}", *(",".join(f"{v:g}" for v in row) for row in values_mmhg[k]), ""]
    path.write_text("\n".join(lines))
    return path


def values() -> np.ndarray:
    v = np.zeros((3, 4, 5))
    v[0, 0, 0], v[1, 3, 4], v[2, 2, 1] = 75.0, 150.0, 7.5
    return v


def test_import_then_export_pressure_gives_the_files_values_in_kpa(tmp_path: Path, capsys) -> None:
    src = tekscan(tmp_path / "walk.asf", values())
    out = tmp_path / "walk.h5"
    assert main(["import", str(src), "-o", str(out)]) == 0
    printed = capsys.readouterr().out
    assert str(out) in printed and "3 frames of 4x5" in printed
    s = load_session(out)
    assert s.kind == "pressure" and s.metadata["source_format"] == "tekscan"
    np.testing.assert_allclose(s.host_time_s, [0.0, 0.02, 0.04], atol=1e-12)
    table = tmp_path / "walk.pressure.csv"
    assert main(["export", str(out), "--what", "pressure", "--format", "csv", "-o", str(table)]) == 0
    with open(table, newline="") as f:
        rows = list(csv.reader(f))
    assert rows[0][:3] == ["time_s", "valid", "r00c00_kpa"] and len(rows) == 4
    cells = np.array([[float(x) for x in row[2:]] for row in rows[1:]])
    np.testing.assert_allclose(cells, values().reshape(3, -1) * MMHG_KPA, rtol=1e-6)
    assert main(["info", str(out)]) == 0
    assert "pressure" in capsys.readouterr().out


def test_default_output_beside_the_file_and_no_overwrite(tmp_path: Path, capsys) -> None:
    src = tekscan(tmp_path / "t.asf", values())
    assert main(["import", str(src)]) == 0
    assert (tmp_path / "t.h5").is_file()
    capsys.readouterr()
    assert main(["import", str(src)]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "exists" in err
    assert main(["import", str(src), "--overwrite"]) == 0


def test_generic_csv_needs_its_shape_and_takes_a_rate(tmp_path: Path, capsys) -> None:
    f = tmp_path / "g.csv"
    f.write_text("\n".join(",".join(f"{v:g}" for v in row.ravel()) for row in values()) + "\n")
    assert main(["import", str(f), "-o", str(tmp_path / "g.h5")]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--shape" in err
    assert main(["import", str(f), "-o", str(tmp_path / "g.h5"), "--shape", "4x5", "--pitch-cm", "1.5",
                 "--rate-hz", "25", "--unit", "mmHg"]) == 0
    s = load_session(tmp_path / "g.h5")
    np.testing.assert_allclose(s.frames, values() * MMHG_KPA, rtol=1e-6)
    np.testing.assert_allclose(s.host_time_s, [0.0, 0.04, 0.08], atol=1e-12)
    from psmat.profile import session_profile

    assert session_profile(s).geometry.pitch_cm == pytest.approx(1.5)


def test_a_bad_file_is_one_line_exit_2(tmp_path: Path, capsys) -> None:
    src = tekscan(tmp_path / "bad.asf", values())
    text = src.read_text().replace("0,0,0,0,150", "0,0,0,150", 1)
    src.write_text(text)
    assert main(["import", str(src), "-o", str(tmp_path / "bad.h5")]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "bad.asf:" in err and "COLS says 5" in err
    assert not (tmp_path / "bad.h5").exists()

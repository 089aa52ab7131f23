"""Other mats' files (docs/spec.md §6): Tekscan ASCII, XSENSOR CSV and a generic CSV, imported as
sessions of kind ``pressure``.

Every file is written here by hand in its maker's published layout (3 frames of 4 x 5 cells);
the expected kPa are converted by hand from the definitions of the units (1 mmHg = 13 595.1 kg/m³ ×
9.80665 m/s² × 1 mm; 1 psi = 0.45359237 kg x 9.80665 m/s² / (0.0254 m)²; 1 N/cm² = 10 kPa), and the expected
centre of pressure is the pressure-weighted mean of the loaded cells' positions, worked out by hand
for cells at (column, row) x pitch.
"""

from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np
import pytest

from psmat.balance import cop
from psmat.io import ImportFormatError, import_pressure, load_session, read_pressure_file
from psmat.profile import session_profile

MMHG_KPA = 13595.1 * 9.80665 * 1e-3 / 1000.0  # conventional mmHg: ρ_Hg × g_n × 1 mm
PSI_KPA = 0.45359237 * 9.80665 / 0.0254**2 / 1000.0

# three frames, values in the file's unit: frame k loads cell (1, 1) with A[k] and cell (2, 3) with B[k]
A = (10.0, 20.0, 0.0)
B = (30.0, 20.0, 40.0)
# hand CoP in cells (column, row): frame 0: x = (10·1 + 30·3)/40 = 2.5, y = (10·1 + 30·2)/40 = 1.75;
# frame 1: x = (20·1 + 20·3)/40 = 2, y = 1.5; frame 2: only (2, 3): x = 3, y = 2
HAND_COP_CELLS = np.array([[2.5, 1.75], [2.0, 1.5], [3.0, 2.0]])


def frame_rows(k: int, blank: bool = False) -> list[str]:
    f = np.zeros((4, 5))
    f[1, 1], f[2, 3] = A[k], B[k]
    rows = [",".join(f"{v:g}" for v in row) for row in f]
    if blank:  # Tekscan marks a cell outside the sensor's outline "B"
        rows[3] = "B" + rows[3][1:]
    return rows


def hand_kpa(factor: float) -> np.ndarray:
    out = np.zeros((3, 4, 5))
    for k in range(3):
        out[k, 1, 1], out[k, 2, 3] = A[k] * factor, B[k] * factor
    return out


def tekscan_file(path: Path, units: str = "mmHg", spacing: str = "5.08 mm", col_spacing: str | None = None,
                 rows_cut: bool = False) -> Path:
    lines = ["ASCII_DATA @@", "VERSION 7.00-20", "SENSOR_TYPE 3150", "ROWS 4", "COLS 5",
             f"ROW_SPACING {spacing}", f"COL_SPACING {col_spacing or spacing}", "SECONDS_PER_FRAME 0.01",
             f"UNITS {units}", ""]
    for k in range(3):
        rows = frame_rows(k, blank=True)
        if rows_cut and k == 1:
            rows[2] = rows[2].rsplit(",", 1)[0]  # a row one value short
        lines += [f"Frame {k + 1}", *rows, ""]
    path.write_text("\r\n".join(lines))
    return path


def xsensor_file(path: Path, unit: str = "PSI", times: tuple[str, ...] = ("10:00:00.000", "10:00:00.025",
                 "10:00:00.050"), dates: tuple[str, ...] = ("2024-03-01",) * 3, drop: str | None = None) -> Path:
    lines = []
    for k in range(3):
        block = [f"Frame:,{k + 1}", f"Date:,{dates[k]}", f"Time:,{times[k]}", "Sensor:,PX100:4.5.0508",
                 "Rows:,4", "Columns:,5", "COP Row:,2.1", "COP Column:,2.4", "Sensel Width (cm):,0.508",
                 "Sensel Height (cm):,0.508", f"Units:,{unit}", f"Average Pressure ({unit}):,1.2",
                 f"Peak Pressure ({unit}):,3.4", "Contact Area (cm^2):,0.52"]
        lines += [b for b in block if drop is None or not b.startswith(drop)] + frame_rows(k) + [""]
    path.write_text("\n".join(lines))
    return path


def test_tekscan_mmhg_converted_by_hand_and_its_cop(tmp_path: Path) -> None:
    out = import_pressure(tekscan_file(tmp_path / "t.asf"), tmp_path / "t.h5")
    s = load_session(out)
    assert s.kind == "pressure" and s.frames.dtype == np.float32 and s.frames.shape == (3, 4, 5)
    assert s.counts is s.frames or np.array_equal(s.counts, s.frames)
    np.testing.assert_allclose(s.frames, hand_kpa(MMHG_KPA), rtol=1e-6)
    np.testing.assert_allclose(s.host_time_s, [0.0, 0.01, 0.02], atol=1e-12)
    geo = session_profile(s).geometry
    assert geo is not None and geo.shape == (4, 5) and geo.pitch_cm == pytest.approx(0.508)
    assert s.metadata["source_format"] == "tekscan" and s.metadata["source_file"] == "t.asf"
    assert s.metadata["source_unit"] == "mmHg" and s.metadata["blank_cells"] == 1
    np.testing.assert_allclose(cop(s.frames, geometry=geo), HAND_COP_CELLS * 0.508, rtol=1e-6)
    assert s.valid.all() and not s.notes


def test_xsensor_psi_converted_by_hand_times_from_stamps_and_its_cop(tmp_path: Path) -> None:
    s = load_session(import_pressure(xsensor_file(tmp_path / "x.csv"), tmp_path / "x.h5"))
    np.testing.assert_allclose(s.frames, hand_kpa(PSI_KPA), rtol=1e-6)
    np.testing.assert_allclose(s.host_time_s, [0.0, 0.025, 0.05], atol=1e-9)
    assert s.metadata["source_format"] == "xsensor" and s.metadata["source_unit"] == "PSI"
    geo = session_profile(s).geometry
    np.testing.assert_allclose(cop(s.frames, geometry=geo), HAND_COP_CELLS * 0.508, rtol=1e-6)


def test_xsensor_unit_from_the_average_pressure_field_and_a_midnight_crossing(tmp_path: Path) -> None:
    f = xsensor_file(tmp_path / "x.csv", unit="mmHg", drop="Units:", times=("23:59:59.980", "00:00:00.000",
                     "00:00:00.020"), dates=("03/31/2024", "04/01/2024", "04/01/2024"))
    r = read_pressure_file(f)
    assert r.source_unit == "mmHg"
    np.testing.assert_allclose(r.pressure_kpa, hand_kpa(MMHG_KPA), rtol=1e-6)
    np.testing.assert_allclose(r.t_s, [0.0, 0.02, 0.04], atol=1e-9)
    # the same with a German locale's dates, DD.MM.YYYY, always day first (before: "is not a date")
    g = xsensor_file(tmp_path / "de.csv", unit="mmHg", drop="Units:", times=("23:59:59.980", "00:00:00.000",
                     "00:00:00.020"), dates=("31.03.2024", "01.04.2024", "01.04.2024"))
    np.testing.assert_allclose(read_pressure_file(g).t_s, [0.0, 0.02, 0.04], atol=1e-9)


def test_generic_csv_with_rate_and_with_a_time_column(tmp_path: Path) -> None:
    cells = [",".join(",".join(frame_rows(k)).split(",")) for k in range(3)]
    plain = tmp_path / "p.csv"
    plain.write_text("\n".join(cells) + "\n")
    s = load_session(import_pressure(plain, tmp_path / "p.h5", "csv", shape=(4, 5), pitch_cm=1.0, rate_hz=50.0,
                                     unit="N/cm2"))
    np.testing.assert_allclose(s.frames, hand_kpa(10.0), rtol=1e-6)
    np.testing.assert_allclose(s.host_time_s, [0.0, 0.02, 0.04], atol=1e-12)
    np.testing.assert_allclose(cop(s.frames, geometry=session_profile(s).geometry), HAND_COP_CELLS, rtol=1e-6)
    timed = tmp_path / "t.csv"
    header = "time_s;" + ";".join(f"r{r}c{c}" for r in range(4) for c in range(5))
    timed.write_text(header + "\n" + "\n".join(f"{5 + 0.1 * k};" + c.replace(",", ";") for k, c in enumerate(cells)))
    r = read_pressure_file(timed, shape=(4, 5), pitch_cm=1.0)
    np.testing.assert_allclose(r.t_s, [0.0, 0.1, 0.2], atol=1e-12)
    np.testing.assert_allclose(r.pressure_kpa, hand_kpa(1.0))


def test_auto_detects_each_format(tmp_path: Path) -> None:
    from psmat.io import detect_format

    assert detect_format(tekscan_file(tmp_path / "a.txt")) == "tekscan"
    assert detect_format(xsensor_file(tmp_path / "b.txt")) == "xsensor"
    (tmp_path / "c.txt").write_text("1,2,3\n")
    assert detect_format(tmp_path / "c.txt") == "csv"


@pytest.mark.parametrize("make, where", [
    (lambda p: tekscan_file(p, rows_cut=True), ":20: 4 values, COLS says 5"),
    (lambda p: tekscan_file(p, units="furlongs"), ":9: UNITS: unknown pressure unit"),
    (lambda p: tekscan_file(p, spacing="5.08 mm", col_spacing="7.62 mm"), "not square"),
    (lambda p: xsensor_file(p, drop="Rows:"), "lacks the field 'rows:'"),
    (lambda p: xsensor_file(p, times=("10:00:00", "10:00:00", "10:00:01")), "are not after frame 1's"),
])
def test_a_bad_file_is_one_line_naming_it(tmp_path: Path, make, where: str) -> None:
    f = make(tmp_path / "bad.txt")
    with pytest.raises(ImportFormatError) as e:
        import_pressure(f, tmp_path / "bad.h5")
    msg = str(e.value)
    assert "\n" not in msg and str(f) in msg and where in msg
    assert not (tmp_path / "bad.h5").exists()


def test_generic_csv_bad_line_and_missing_options(tmp_path: Path) -> None:
    f = tmp_path / "g.csv"
    f.write_text("1,2,3\n1,2\n")
    with pytest.raises(ImportFormatError, match=r"g\.csv:2: 2 values, expected 3"):
        read_pressure_file(f, "csv", shape=(1, 3), pitch_cm=1.0, rate_hz=10.0)
    with pytest.raises(ImportFormatError, match="--shape RxC and --pitch-cm"):
        read_pressure_file(f, "csv")
    f.write_text("1,2,x\n")
    with pytest.raises(ImportFormatError, match=r"g\.csv:1: 'x' is not a number"):
        read_pressure_file(f, "csv", shape=(1, 3), pitch_cm=1.0, rate_hz=10.0)


def test_generic_csv_european_decimal_comma_and_an_empty_value(tmp_path: Path) -> None:
    # a semicolon-separated CSV with decimal commas, BOM and Windows line ends: 1x2 frames of 0.5/1.25 kPa, ...
    f = tmp_path / "eu.csv"
    f.write_bytes("\ufeffr0c0;r0c1\r\n0,5;1,25\r\n2,5;3,75;\r\n".encode("utf-8"))
    r = read_pressure_file(f, "csv", shape=(1, 2), pitch_cm=1.0, rate_hz=10.0)
    np.testing.assert_array_equal(r.pressure_kpa, np.array([[[0.5, 1.25]], [[2.5, 3.75]]], np.float32))
    # read as 1x4 the decimal commas must not become separators (it was 4 silent wrong values a line)
    with pytest.raises(ImportFormatError, match=r"eu\.csv:2: 2 values, expected 4"):
        read_pressure_file(f, "csv", shape=(1, 4), pitch_cm=1.0, rate_hz=10.0)
    f.write_bytes("r0c0\tr0c1\r\n0,5\t1,25\r\n2,5\t3,75\r\n".encode("utf-16"))  # Excel's "Unicode text", European
    r = read_pressure_file(f, "csv", shape=(1, 2), pitch_cm=1.0, rate_hz=10.0)  # (before: "'0' ... 3 values")
    np.testing.assert_array_equal(r.pressure_kpa, np.array([[[0.5, 1.25]], [[2.5, 3.75]]], np.float32))
    f.write_text("1,,2,3\n4,5,6\n")  # a missing value must not shift the cells
    with pytest.raises(ImportFormatError, match=r"eu\.csv:1: value 2 is empty"):
        read_pressure_file(f, "csv", shape=(1, 3), pitch_cm=1.0, rate_hz=10.0)


def test_a_damaged_imported_session_is_caught_by_its_checksums(tmp_path: Path) -> None:
    out = import_pressure(tekscan_file(tmp_path / "t.asf"), tmp_path / "t.h5")
    with h5py.File(out, "r") as f:
        info = f["pressure"].id.get_chunk_info(0)
        off, size = int(info.byte_offset), int(info.size)
    with open(out, "r+b") as fh:  # one byte in the middle of the frames' only chunk
        fh.seek(off + size // 2)
        b = fh.read(1)[0]
        fh.seek(off + size // 2)
        fh.write(bytes([b ^ 0xFF]))
    s = load_session(out)
    assert not s.valid.any()  # the chunk's frames are never returned as valid
    assert any("pressure" in n for n in s.notes)


def test_unit_factors_are_the_definitions() -> None:
    from psmat.units import cm_per_unit, kpa_per_unit

    assert kpa_per_unit("mmHg") == pytest.approx(MMHG_KPA, rel=1e-12)
    assert kpa_per_unit("PSI") == pytest.approx(PSI_KPA, rel=1e-6)  # psmat's psi is given to 7 digits
    assert kpa_per_unit("N/cm2") == kpa_per_unit("N / cm^2") == 10.0
    assert cm_per_unit("millimeters") == 0.1 and cm_per_unit("inches") == 2.54
    assert kpa_per_unit("bar") == 100.0 and kpa_per_unit("mbar") == 0.1  # 1 bar = 10^5 Pa, by definition
    from psmat.units import kg_per_unit

    # the international avoirdupois pound (1959): 0.45359237 kg exactly; the stone, 14 lb
    assert kg_per_unit("LB") == kg_per_unit("pounds") == 0.45359237 and kg_per_unit("st") == 14 * 0.45359237
    with pytest.raises(ValueError, match="unknown mass unit 'oz'"):
        kg_per_unit("oz")
    with pytest.raises(ValueError, match="unknown pressure unit 'atm'"):
        kpa_per_unit("atm")


def test_a_pressure_profile_has_a_geometry_and_no_circuit() -> None:
    from psmat.profile import Profile, ProfileError

    d = {"name": "imported", "description": "a 4x5 mat", "kind": "pressure", "protocol": "import", "rate_hz": 50.0,
         "geometry": {"shape": [4, 5], "pitch_cm": 0.5}}
    p = Profile.from_dict(d)
    assert p.geometry is not None and p.geometry.pitch_cm == 0.5 and p.r_o_ohm is None and p.baudrate == 0
    assert Profile.from_dict(p.to_dict()) == p
    with pytest.raises(ProfileError, match="circuit"):
        Profile.from_dict({**d, "circuit": {"r_o_ohm": 1.0}})
    with pytest.raises(ProfileError, match="geometry"):
        Profile.from_dict({k: v for k, v in d.items() if k != "geometry"})


def test_an_export_saved_again_as_utf16_or_windows_1252_reads_the_same(tmp_path: Path) -> None:
    """A file opened and saved again by a spreadsheet ("Unicode text": UTF-16) or written by Windows
    software (Windows-1252, a µ in a note): before, UTF-16 read as replacement characters was no
    Tekscan file at all."""
    plain = read_pressure_file(tekscan_file(tmp_path / "t.asf"))
    text = (tmp_path / "t.asf").read_text()
    for name, data in (("u16.asf", text.encode("utf-16")),
                       ("w1252.asf", text.replace("VERSION 7.00-20", "VERSION 7.00-20 (µ)").encode("cp1252"))):
        (tmp_path / name).write_bytes(data)
        r = read_pressure_file(tmp_path / name)
        np.testing.assert_array_equal(r.pressure_kpa, plain.pressure_kpa)
        np.testing.assert_array_equal(r.t_s, plain.t_s)
    (tmp_path / "bin.csv").write_bytes(b"1,2,3\n\x00\x00\x00\n")
    with pytest.raises(ImportFormatError, match=r"bin\.csv is not text \(byte 0x00 at offset 6\)"):
        read_pressure_file(tmp_path / "bin.csv", "csv", shape=(1, 3), pitch_cm=1.0, rate_hz=10.0)

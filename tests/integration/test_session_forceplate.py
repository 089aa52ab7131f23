"""psmat.io's force-platform files (load_forceplate_csv, load_bds, ...): generic CoP CSV files and the BDS
data set (one real file)."""

from __future__ import annotations

import csv
import lzma
import shutil
from pathlib import Path

import numpy as np
import pytest

from psmat.io import ForcePlateRecording, bds_dir, bds_files, bds_trial, bds_trials_table, load_bds, load_forceplate_csv

#: The trials shipped with the package (the source tree's copy: this test checks the installed one finds it).
PACKAGE_BDS = Path(__file__).resolve().parents[2] / "src" / "psmat" / "data" / "bds"


def parse_bds(path: Path) -> dict[str, np.ndarray]:
    """An independent reader of a BDS file (plain or xz-compressed text)."""
    opener = lzma.open if path.suffix == ".xz" else open
    with opener(path, "rt", newline="") as fh:
        rows = list(csv.reader(fh, delimiter="\t"))
    head = rows[0]
    data = np.array([[float(x) for x in r] for r in rows[1:] if r], dtype=float)
    return {h.strip(): data[:, k] for k, h in enumerate(head)}


def test_bds_trial_matches_file(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("PSMAT_BDS_DIR", raising=False)
    files = bds_files()  # the copy shipped with the package, found without any setting
    assert [f.name for f in files] == [f"BDS{k:05d}.txt.xz" for k in range(1, 25)]
    assert bds_dir().samefile(PACKAGE_BDS) or (bds_dir() / "README.md").read_text() == (PACKAGE_BDS / "README.md").read_text()
    path = bds_dir() / "BDS00001.txt.xz"
    assert "CC BY 4.0" in (bds_dir() / "README.md").read_text() and "10.7717/peerj.2648" in (bds_dir() / "README.md").read_text()
    r = bds_trial(1)
    ref = parse_bds(path)
    assert isinstance(r, ForcePlateRecording) and r.n == ref["Time[s]"].size == 6000
    np.testing.assert_array_equal(r.t, ref["Time[s]"])
    np.testing.assert_array_equal(r.cop_ap_cm, ref["COPx[cm]"])  # COPx is anterior-posterior
    np.testing.assert_array_equal(r.cop_ml_cm, ref["COPy[cm]"])  # COPy is medial-lateral
    np.testing.assert_array_equal(r.fz_n, ref["Fz[N]"])
    np.testing.assert_array_equal(r.meta["channels"]["Mx[Nm]"], ref["Mx[Nm]"])
    assert abs(r.rate_hz - 100.0) < 1e-9
    assert r.meta["trial"] == "BDS00001" and r.meta["trial_info"]["Vision"] in ("Open", "Closed")
    np.testing.assert_array_equal(r.cop_cm, np.column_stack([ref["COPy[cm]"], ref["COPx[cm]"]]))
    assert bds_trial("BDS00001").n == r.n
    table = bds_trials_table()
    assert any(row["Trial"] == "BDS00001" and row["Subject"] == 1 for row in table)
    with pytest.raises(FileNotFoundError, match="BDS99999"):
        bds_trial(99999)


def test_bds_dir_from_env(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    path = PACKAGE_BDS / "BDS00002.txt.xz"
    with lzma.open(path, "rb") as src, open(tmp_path / "BDS00002.txt", "wb") as dst:  # a plain-text copy
        shutil.copyfileobj(src, dst)
    shutil.copy(PACKAGE_BDS / "BDS00003.txt.xz", tmp_path / "BDS00003.txt.xz")
    monkeypatch.setenv("PSMAT_BDS_DIR", str(tmp_path))
    assert bds_dir() == tmp_path
    assert bds_files() == [tmp_path / "BDS00002.txt", tmp_path / "BDS00003.txt.xz"]
    r = bds_trial(2)
    assert "trial_info" not in r.meta  # no trials.tsv beside the copy
    np.testing.assert_array_equal(r.cop_ml_cm, parse_bds(path)["COPy[cm]"])
    np.testing.assert_array_equal(bds_trial("BDS00003").cop_ap_cm, parse_bds(tmp_path / "BDS00003.txt.xz")["COPx[cm]"])
    with pytest.raises(FileNotFoundError, match="BDS00001.*not found"):  # only what the folder holds
        bds_trial(1)
    monkeypatch.setenv("PSMAT_BDS_DIR", str(tmp_path / "nope"))
    with pytest.raises(FileNotFoundError, match="PSMAT_BDS_DIR"):
        bds_dir()


def test_load_bds_rejects_other_files(tmp_path: Path) -> None:
    p = tmp_path / "x.txt"
    p.write_text("a\tb\n1\t2\n")
    with pytest.raises(ValueError, match="not a BDS file"):
        load_bds(p)
    bad = tmp_path / "BDS00001.txt.xz"
    bad.write_bytes(b"not xz at all")
    with pytest.raises(ValueError, match="not a valid xz file"):
        load_bds(bad)


def test_forceplate_csv_with_header(tmp_path: Path) -> None:
    t = np.arange(50) * 0.01
    x = np.sin(t) * 1.234567
    y = np.cos(t) * 0.5
    fz = 700 + t
    p = tmp_path / "fp.csv"
    with open(p, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["Time (s)", "COP_x [mm]", "COP_y [mm]", "Fz [N]", "Mx"])
        for row in zip(t, x * 10, y * 10, fz, -t):
            w.writerow([repr(float(v)) for v in row])
    r = load_forceplate_csv(p)
    np.testing.assert_array_equal(r.t, t)
    np.testing.assert_allclose(r.cop_ml_cm, x, rtol=1e-15, atol=0)  # mm -> cm from the header
    np.testing.assert_allclose(r.cop_ap_cm, y, rtol=1e-15, atol=0)
    np.testing.assert_array_equal(r.fz_n, fz)
    assert r.meta["unit"] == "mm" and "Mx" in r.meta["channels"]
    rs = load_forceplate_csv(p, swap_axes=True)
    np.testing.assert_array_equal(rs.cop_ml_cm, r.cop_ap_cm)


def test_forceplate_csv_without_header_and_tabs(tmp_path: Path) -> None:
    p = tmp_path / "fp.tsv"
    p.write_text("# exported\n0.0\t1.5\t-2.0\n0.1\t1.25\t-2.5\n0.2\t1.0\t-3.0\n")
    r = load_forceplate_csv(p)
    np.testing.assert_array_equal(r.t, [0.0, 0.1, 0.2])
    np.testing.assert_array_equal(r.cop_ml_cm, [1.5, 1.25, 1.0])
    np.testing.assert_array_equal(r.cop_ap_cm, [-2.0, -2.5, -3.0])
    assert r.fz_n is None
    r2 = load_forceplate_csv(p, unit="m")
    np.testing.assert_array_equal(r2.cop_ml_cm, [150.0, 125.0, 100.0])


def test_forceplate_csv_european_semicolons_and_decimal_commas(tmp_path: Path) -> None:
    """What a spreadsheet in a European locale writes: semicolons between the fields, a comma before
    the decimals; the same numbers as the file written with points (before: "non-numeric value")."""
    t = np.arange(40) * 0.01
    x, y = np.sin(7 * t) * 12.345, -np.cos(5 * t) * 6.5
    plain, european = tmp_path / "plain.csv", tmp_path / "eu.csv"
    lines = [f"{float(a)!r},{float(b)!r},{float(c)!r}" for a, b, c in zip(t, x, y)]
    plain.write_text("time,x [mm],y [mm]\n" + "\n".join(lines) + "\n")
    european.write_text("time (s);x [mm];y [mm]\n"
                        + "\n".join(ln.replace(",", ";").replace(".", ",") for ln in lines) + "\n")
    a, b = load_forceplate_csv(plain), load_forceplate_csv(european)
    for k in ("t", "cop_ml_cm", "cop_ap_cm"):
        np.testing.assert_array_equal(getattr(b, k), getattr(a, k))
    assert b.meta["unit"] == "mm"
    np.testing.assert_allclose(b.cop_ml_cm, x / 10, rtol=1e-15, atol=0)  # mm -> cm
    # without a header, a first line with decimal commas is data, split on its semicolons
    headless = tmp_path / "eu_headless.csv"
    headless.write_text("0,00;1,5;-2,25\n0,01;1,75;-2\n")
    r = load_forceplate_csv(headless)
    assert r.t.tolist() == [0.0, 0.01] and r.cop_ml_cm.tolist() == [1.5, 1.75] and r.cop_ap_cm.tolist() == [-2.25, -2.0]


def test_samples_without_a_cop_are_lost_samples(tmp_path: Path) -> None:
    p = tmp_path / "fp.csv"
    p.write_text("time,x,y,Fz\n0.00,1.0,2.0,700\n0.01,NaN,NaN,3\n0.02,1.5,2.5,690\n0.03,1.25,nan,2\n0.04,2.0,3.0,710\n")
    t, c = load_forceplate_csv(p).samples()
    assert t.tolist() == [0.0, 0.02, 0.04] and c.tolist() == [[1.0, 2.0], [1.5, 2.5], [2.0, 3.0]]
    p.write_text("time,x,y\n0.0,NaN,1\n0.1,2,3\n")
    with pytest.raises(ValueError, match="fp.csv has 1 sample.s. with a time and a CoP"):
        load_forceplate_csv(p).samples()
    p.write_text("time,x,y\n0.5,1,1\n0.5,2,3\n0.5,2,3\n")
    with pytest.raises(ValueError, match="times do not advance"):
        load_forceplate_csv(p).samples()


def test_forceplate_csv_time_in_milliseconds_is_read_in_seconds(tmp_path: Path) -> None:
    """Platform software often writes the time in ms: read as seconds it made a 1 kHz platform a
    1 Hz one (and the study's alignment and metrics wrong). The unit comes from the time column's
    header, as the CoP's does from the x column's."""
    p = tmp_path / "fp.csv"
    for header, scale in (("Time [ms]", 1e-3), ("time_ms", 1e-3), ("Time (us)", 1e-6), ("time (µs)", 1e-6),
                          ("Time (s)", 1.0), ("t", 1.0)):
        p.write_text(f"{header},COPx [mm],COPy [mm]\n0,10,20\n1,11,21\n2,12,22\n")
        r = load_forceplate_csv(p)
        np.testing.assert_allclose(r.t, np.arange(3) * scale, rtol=1e-15, atol=0)
        assert r.rate_hz == pytest.approx(1.0 / scale)
    p.write_text("0,1,2\n5,1,2\n")  # no header: seconds unless told
    assert load_forceplate_csv(p).t.tolist() == [0.0, 5.0]
    assert load_forceplate_csv(p, t_unit="ms").t.tolist() == [0.0, 0.005]
    p.write_text("Time [frames],x,y\n0,1,2\n1,1,2\n")
    with pytest.raises(ValueError, match="unknown time unit 'frames'"):
        load_forceplate_csv(p)


def test_samples_without_a_load_are_lost_samples(tmp_path: Path) -> None:
    """CoP = moment / Fz has no meaning once the subject steps off: a platform's software then writes
    0 or noise. With an Fz column, a sample under 5 % of the median |Fz| is left out (700 N standing:
    under 35 N); a plate counting downward force negative is read by its magnitude."""
    p = tmp_path / "fp.csv"
    fz = [700.0] * 4 + [3.0, 34.9, 35.1] + [700.0] * 4  # standing, then off the plate for 2 samples; median 700 N
    rows = [f"{k * 0.01:.2f},{1 + k * 0.5},{2 + k * 0.25},{f}" for k, f in enumerate(fz)]
    p.write_text("time,x,y,Fz\n" + "\n".join(rows) + "\n")
    t, c = load_forceplate_csv(p).samples()
    kept = [k for k in range(len(fz)) if k not in (4, 5)]
    np.testing.assert_allclose(t, np.array(kept) * 0.01, rtol=0, atol=1e-12)
    assert c[:, 0].tolist() == [1 + k * 0.5 for k in kept]
    p.write_text("time,x,y,Fz\n" + "\n".join(r.rsplit(",", 1)[0] + ",-" + r.rsplit(",", 1)[1] for r in rows) + "\n")
    np.testing.assert_allclose(load_forceplate_csv(p).samples()[0], np.array(kept) * 0.01, rtol=0, atol=1e-12)
    p.write_text("time,x,y\n" + "\n".join(r.rsplit(",", 1)[0] for r in rows) + "\n")  # no Fz: every sample
    assert load_forceplate_csv(p).samples()[0].size == len(fz)


def test_forceplate_csv_errors(tmp_path: Path) -> None:
    with pytest.raises(FileNotFoundError):
        load_forceplate_csv(tmp_path / "missing.csv")
    p = tmp_path / "bad.csv"
    p.write_text("when,a,b\n1,2,3\n")
    with pytest.raises(ValueError, match="no time column"):
        load_forceplate_csv(p)
    r = load_forceplate_csv(p, t_column="when", x="a", y="b")
    assert r.t.tolist() == [1.0] and r.cop_ml_cm.tolist() == [2.0]
    p.write_text("t,x,y\n1,2,3\n4,5\n")
    with pytest.raises(ValueError, match="row 3"):
        load_forceplate_csv(p)


def _export(t, x_mm, y_mm, fz, sep=",", comma=False):
    """The data rows of a platform export, numbers as written by hand (``comma``: decimal commas)."""
    rows = [sep.join(f"{v:.3f}" for v in r) for r in zip(t, x_mm, y_mm, fz)]
    return "\n".join(r.replace(".", ",") for r in rows) if comma else "\n".join(rows)


T4, X4, Y4, FZ4 = [0.0, 0.001, 0.002, 0.003], [12.5, 13.0, -4.25, 0.5], [-30.0, -29.5, 2.0, 7.75], [701.0, 699.5, 702.0, 700.0]


def test_forceplate_export_with_a_preamble_and_a_units_row(tmp_path: Path) -> None:
    """What platform software writes: lines about the recording above the header, the units in a
    row of their own under it (before: "row 4 has 4 fields, expected 1"; and with the units row,
    "non-numeric value": a mm file could not be read, and read without the units it is 10x off)."""
    p = tmp_path / "export.txt"
    preamble = ["Platform export v2.1", "Subject;Müller", "Sampling rate;1000;Hz"]
    p.write_bytes(("\r\n".join(preamble + ["Time;COPx;COPy;Fz", "ms;mm;mm;N",
                                           _export([1000 * v for v in T4], X4, Y4, FZ4, ";", comma=True)])
                   + "\r\n").encode("cp1252"))  # a German Windows: Windows-1252, decimal commas
    r = load_forceplate_csv(p)
    np.testing.assert_allclose(r.t, T4, rtol=0, atol=1e-12)  # ms -> s
    np.testing.assert_allclose(r.cop_ml_cm, np.array(X4) / 10, rtol=1e-15)  # mm -> cm
    np.testing.assert_allclose(r.cop_ap_cm, np.array(Y4) / 10, rtol=1e-15)
    np.testing.assert_array_equal(r.fz_n, FZ4)
    assert r.meta["preamble"] == preamble and r.meta["unit"] == "mm" and r.meta["time_unit"] == "ms"
    assert r.meta["columns"] == ["Time [ms]", "COPx [mm]", "COPy [mm]", "Fz [N]"]


@pytest.mark.parametrize("encoding", ["utf-16", "utf-8-sig", "cp1252"])
def test_forceplate_export_as_a_spreadsheet_saves_it(encoding: str, tmp_path: Path) -> None:
    """Excel's "Unicode text" (UTF-16, tabs; decimal commas in a European locale), "CSV UTF-8" (a
    byte-order mark), "CSV" on a western Windows (Windows-1252); a unit in brackets (µ, °)."""
    p = tmp_path / "export.txt"
    p.write_bytes(("Zeit [s]\tCOPx [mm]\tCOPy [mm]\tFz [N]\tT [°C]\n"
                   + _export(T4, X4, Y4, FZ4, "\t", comma=True).replace("\n", "\t21,5\n") + "\t21,5\n").encode(encoding))
    r = load_forceplate_csv(p, t_column="Zeit [s]")
    np.testing.assert_allclose(r.t, T4, rtol=0, atol=1e-12)
    np.testing.assert_allclose(r.cop_ml_cm, np.array(X4) / 10, rtol=1e-15)
    assert r.meta["channels"]["T [°C]"].tolist() == [21.5] * 4


def test_forceplate_rows_that_are_not_a_preamble(tmp_path: Path) -> None:
    """A row of numbers above a second header (two exports pasted together) is no preamble: the
    rows under the first header are data, the second header a bad row (nothing dropped unsaid); an
    empty field is a missing value (NaN: a lost sample); a bad value is named with its row."""
    p = tmp_path / "fp.csv"
    p.write_text("note\nt,x,y\n0,1,2\nt,x,y\n1,2,3\n")
    with pytest.raises(ValueError, match=r"row 4: 't' is not a number"):
        load_forceplate_csv(p)
    p.write_text("t,x,y,Fz\n0,1,2,700\n0.01,,,3\n0.02,1.5,2.5,690\n0.03,x1,2,700\n")
    with pytest.raises(ValueError, match=r"row 5: 'x1' is not a number"):
        load_forceplate_csv(p)
    p.write_text("t,x,y,Fz\n0,1,2,700\n0.01,,,3\n0.02,1.5,2.5,690\n")
    r = load_forceplate_csv(p)
    assert np.isnan(r.cop_ml_cm[1]) and r.samples()[0].tolist() == [0.0, 0.02]
    # empty fields at the end of a row are missing values too (before: "row 3 has 1 fields, expected 3");
    # a delimiter that ends every line adds no field, the European way included
    p.write_text("t,x,y\n0,1,2\n0.01,,\n0.02,1.5,2.5\n")
    r = load_forceplate_csv(p)
    assert r.meta["columns"] == ["t", "x", "y"] and r.samples()[0].tolist() == [0.0, 0.02]
    p.write_text("t;x;y;\n0;1,5;2;\n0,01;;;\n0,02;1;3;\n")
    r = load_forceplate_csv(p)
    assert r.meta["columns"] == ["t", "x", "y"] and r.samples()[0].tolist() == [0.0, 0.02]
    np.testing.assert_allclose(r.cop_ml_cm[[0, 2]], [1.5, 1.0])
    p.write_text("Export\nTime;x;y;\n12:00:00,00;1,5;2;\n12:00:00,01;;;\n12:00:00,02;1;3;\n")  # clock times too
    r = load_forceplate_csv(p)
    assert r.meta["columns"] == ["Time", "x", "y"] and r.meta["preamble"] == ["Export"]
    np.testing.assert_allclose(r.samples()[0] - 43200.0, [0.0, 0.02], atol=1e-9)
    p.write_bytes(b"t,x,y\n0,1,2\n\x00\x01\x02\n")
    with pytest.raises(ValueError, match=r"fp.csv: is not text \(byte 0x00 at offset 12\)"):
        load_forceplate_csv(p)


def test_forceplate_export_timed_by_its_rate(tmp_path: Path) -> None:
    """Software that writes a sample number (or nothing) and its rate above the header: before, "no
    time column recognised" and the session had no platform. Sample k is at k / rate; a skipped
    number keeps its gap (a lost sample); a rate given by hand wins; two stated rates are an error."""
    p = tmp_path / "export.txt"
    p.write_text("Platform export\nSampling rate: 1 kHz\nLow-pass filter: 10 Hz\nSample;COPx (mm);COPy (mm);Fz (N)\n"
                 "1;12,5;-30;701\n2;13;-29,5;699,5\n4;-4,25;2;702\n")
    r = load_forceplate_csv(p)
    np.testing.assert_allclose(r.t, [0.001, 0.002, 0.004], rtol=1e-15)
    np.testing.assert_allclose(r.cop_ml_cm, [1.25, 1.3, -0.425], rtol=1e-15)
    assert r.meta["time_from"] == "'Sample' / 1000 Hz (the line 'Sampling rate: 1 kHz')" and r.meta["channels"] == {}
    np.testing.assert_allclose(load_forceplate_csv(p, rate_hz=500).t, [0.002, 0.004, 0.008], rtol=1e-15)
    p.write_text("Rate;100;Hz\nCOPx;COPy\n1;2\n1;2\n1;3\n")  # no counter: the row
    assert load_forceplate_csv(p).t.tolist() == [0.0, 0.01, 0.02]
    p.write_text("Frame rate: 50\nRate of force development 120 N/s\nCOPx;COPy\n1;2\n1;2\n1;3\n")  # not a sampling rate
    assert load_forceplate_csv(p).t.tolist() == [0.0, 0.02, 0.04]
    p.write_text("Sample rate 100 Hz\nframe rate: 50\nCOPx,COPy\n1,2\n1,2\n1,3\n")
    with pytest.raises(ValueError, match="the lines above the header name 2 rates"):
        load_forceplate_csv(p)
    p.write_text("COPx,COPy\n1,2\n1,2\n1,3\n")
    with pytest.raises(ValueError, match="no time column recognised .*give the platform's rate_hz="):
        load_forceplate_csv(p)


def test_times_saved_with_too_few_decimals_are_put_back_on_their_rate(tmp_path: Path) -> None:
    """A 1 kHz platform's file saved by a spreadsheet that shows two decimals: each time repeats ten
    times (before: "its times do not advance"). Rounded from a constant rate, they lie within q/2 of
    a line in the sample number, and the line's times are within ~q/2 of the true ones; 100 lost
    samples (0.1 s) stand off any line, and the file is refused with the reason."""
    t = np.arange(3000) * 1e-3
    p = tmp_path / "fp.csv"

    def write(times: np.ndarray, decimals: int) -> None:
        p.write_text("time,x,y\n" + "".join(f"{v:.{decimals}f},{np.sin(v):.4f},{np.cos(v):.4f}\n" for v in times))

    write(t, 2)
    r = load_forceplate_csv(p)
    np.testing.assert_allclose(r.t, t, rtol=0, atol=0.005)  # the rounding's own bound
    assert np.all(np.diff(r.t) > 0) and r.rate_hz == pytest.approx(1000.0, rel=1e-3)
    assert r.meta["time_from"].startswith("the column 'time', written to 0.01 s and put back on its 99")
    write(t, 3)  # every decimal: taken as written
    assert load_forceplate_csv(p).meta["time_from"] == "the column 'time'"
    write(np.r_[t[:1000], t[1100:]], 2)
    with pytest.raises(ValueError, match=r"its times repeat \(written to 0.01 s .* export it again with every decimal"):
        load_forceplate_csv(p)


def test_a_time_that_goes_back_names_the_step(tmp_path: Path) -> None:
    """Two recordings in one file (or a platform clock that started again): before, "cop_ref times must
    increase strictly" from deep in the alignment, not naming the file."""
    p = tmp_path / "two.csv"
    t = np.r_[np.arange(100), np.arange(50)] * 0.01
    p.write_text("time,x,y\n" + "".join(f"{v:.2f},{v:.3f},1\n" for v in t))
    with pytest.raises(ValueError, match=r"two.csv: its time goes from 0.99 s back to 0 s \(1 such step\(s\)\): it "
                                         r"holds more than one recording"):
        load_forceplate_csv(p).samples()


def test_forces_and_moments_without_a_cop_give_the_published_cop(tmp_path: Path) -> None:
    """Some platform software exports only the six channels (Fx, Fy, Fz, Mx, My, Mz): before, "no x
    column recognised". The CoP of moments about the plate's surface, x = -My/Fz, y = Mx/Fz, is what
    the BDS authors published as COPx, COPy (their x is A-P: swap_axes)."""
    rec = bds_trial(3)
    ch = rec.meta["channels"]
    p = tmp_path / "six.csv"
    for unit, scale in (("N.m", 1.0), ("N·mm", 1e3)):
        six = np.c_[rec.t, ch["Fx[N]"], ch["Fy[N]"], rec.fz_n, ch["Mx[Nm]"] * scale, ch["My[Nm]"] * scale,
                    ch["Mz[Nm]"] * scale]
        header = f"Time [s],Fx [N],Fy [N],Fz [N],Mx [{unit}],My [{unit}],Mz [{unit}]"
        np.savetxt(p, six, delimiter=",", header=header, comments="", fmt="%.9g", encoding="utf-8")
        r = load_forceplate_csv(p, swap_axes=True)
        np.testing.assert_allclose(r.cop_ml_cm, rec.cop_ml_cm, rtol=0, atol=1e-5)
        np.testing.assert_allclose(r.cop_ap_cm, rec.cop_ap_cm, rtol=0, atol=1e-5)
        assert r.meta["cop_from"].startswith("-My/Fz, Mx/Fz") and set(r.meta["channels"]) == {"Fx [N]", "Fy [N]",
                                                                                              f"Mz [{unit}]"}
    p.write_text("t,Fz,Mx [kN.m],My [kN.m]\n0,700,1,2\n0.01,700,1,2\n")
    with pytest.raises(ValueError, match=r"the moment column 'Mx \[kN.m\]': its unit 'kn.m' is not N·m"):
        load_forceplate_csv(p)


def test_clock_times_are_read_as_seconds(tmp_path: Path) -> None:
    """Platform software that writes the time of day (``23:59:59,990``, a units row ``hh:mm:ss.sss``),
    or a date and time: before, "'23:59:59,990' is not a number". Times of the day are seconds of the
    day, carried on past midnight; a date and time is POSIX seconds (UTC unless it names its offset).
    Expected values by hand: 23 h 59 min 59.99 s = 86 399.99 s; 2024-03-01 12:00 UTC = 1 709 294 400 s."""
    p = tmp_path / "clock.csv"
    p.write_text("Export\nStart;23:59:59\nTime;COPx (mm);COPy (mm);Fz\nhh:mm:ss.sss;mm;mm;N\n"
                 "23:59:59,990;1;2;700\n23:59:59,995;1;2;700\n00:00:00,000;1;2;700\n00:00:00,005;1;2;700\n")
    r = load_forceplate_csv(p)
    np.testing.assert_allclose(r.t, 86399.99 + np.arange(4) * 0.005, rtol=0, atol=1e-9)
    assert r.meta["time_from"] == "the clock times of the column 'Time [hh:mm:ss.sss]'" and r.meta["time_unit"] == "s"
    assert r.meta["preamble"] == ["Export", "Start;23:59:59"]
    np.testing.assert_allclose(r.cop_ml_cm, 0.1)
    p.write_text("timestamp,x,y\n2024-03-01T12:00:00.000Z,1,2\n2024-03-01 12:00:00.010,1,2\n"
                 "2024-03-01T13:00:00.020+01:00,1,2\n")
    r = load_forceplate_csv(p)
    np.testing.assert_allclose(r.t, 1709294400.0 + np.array([0.0, 0.01, 0.02]), rtol=0, atol=1e-6)
    assert r.meta["time_from"] == "the clock times of the column 'timestamp'"
    p.write_text("time,x,y\n12:00:00.00,1,2\n12:00:00.00,1,2\n12:00:00.01,1,2\n12:00:00.01,1,2\n12:00:00.02,1,2\n")
    r = load_forceplate_csv(p)  # clock times with too few decimals: put back on their rate, as numbers are
    assert r.meta["time_from"].startswith("the clock times of the column 'time', written to 0.01 s and put back")
    p.write_text("time,x,y\n12:00:00,1,2\n25:61:00,1,2\n")
    with pytest.raises(ValueError, match=r"row 3: '25:61:00' is not a number"):
        load_forceplate_csv(p)


@pytest.mark.parametrize("down", [False, True])
def test_moments_about_an_origin_below_the_surface(down: bool, tmp_path: Path) -> None:
    """Plates whose moments are about an origin below their surface (Kistler's a_z0, AMTI's z0): the
    CoP of moments about the surface is off by z Fx / Fz. Expectation from the physics alone: a force
    F applied at a known point r of the surface has the moment r × F (numpy's cross product) about
    the origin; the file of F and M gives back r's x and y, in z-up axes and in Kistler's z-down axes
    (turned 180° about x: y and z change sign)."""
    rng = np.random.default_rng(3)
    n, depth = 200, 0.041  # m below the surface
    point = np.c_[rng.normal(0, 0.03, n), rng.normal(0, 0.05, n), np.full(n, depth)]  # m, z up
    force = np.c_[rng.normal(0, 8, n), rng.normal(0, 8, n), rng.normal(700, 30, n)]  # N on the plate, z up
    flip = np.array([1.0, -1.0, -1.0]) if down else np.ones(3)
    r, f = point * flip, force * flip
    m = np.cross(r, f)  # N·m about the origin
    p = tmp_path / "six.csv"
    np.savetxt(p, np.c_[np.arange(n) / 1000, f, m * 1000], delimiter=",", fmt="%.12g",
               header="Time,Fx,Fy,Fz,Mx [N.mm],My [N.mm],Mz [N.mm]", comments="")
    got = load_forceplate_csv(p, surface_z_mm=r[0, 2] * 1000)
    np.testing.assert_allclose(got.cop_ml_cm, r[:, 0] * 100, rtol=0, atol=1e-8)
    np.testing.assert_allclose(got.cop_ap_cm, r[:, 1] * 100, rtol=0, atol=1e-8)
    assert got.meta["cop_from"] == f"(z Fx - My)/Fz, (Mx + z Fy)/Fz, z = {r[0, 2] * 1000:g} mm"
    assert set(got.meta["channels"]) == {"Mz [N.mm]"}
    surface = load_forceplate_csv(p)  # taken as moments about the surface: off by z Fx / Fz
    np.testing.assert_allclose(surface.cop_ml_cm - r[:, 0] * 100, -r[:, 2] * f[:, 0] / f[:, 2] * 100, atol=1e-8)
    p.write_text("Time,Fz,Mx,My\n0,700,1,2\n0.01,700,1,2\n")
    with pytest.raises(ValueError, match="surface_z_mm needs the horizontal forces Fx and Fy"):
        load_forceplate_csv(p, surface_z_mm=-41)
    p.write_text("Time,x,y\n0,1,2\n0.01,1,2\n")
    with pytest.raises(ValueError, match="surface_z_mm is for a file of forces and moments without a CoP column"):
        load_forceplate_csv(p, surface_z_mm=-41)


def test_force_units_named_in_the_header_are_converted(tmp_path: Path) -> None:
    """Six channels written in kgf and kN·m (a platform's software may): the CoP of moments is a ratio of
    a moment to a force, so each must be in its unit (before: kgf taken as N, the CoP 9.81 times too
    small). Hand values: 1 kgf = 9.80665 N; a point force of 700 N at x = 2 cm, y = -3 cm has
    My = -x Fz = -14 N·m and Mx = y Fz = -21 N·m. A column in %BW is kept as written."""
    p = tmp_path / "kgf.csv"
    fz_kgf = 700 / 9.80665
    p.write_text(f"time,Fz [kgf],Mx [kN.m],My [kN.m]\n0,{fz_kgf!r},-0.021,-0.014\n0.01,{fz_kgf!r},-0.021,-0.014\n")
    with pytest.raises(ValueError, match=r"the moment column 'Mx \[kN.m\]'"):  # kN·m: not offered
        load_forceplate_csv(p)
    p.write_text(f"time,Fz [kgf],Mx [N.m],My [N.m]\n0,{fz_kgf!r},-21,-14\n0.01,{fz_kgf!r},-21,-14\n")
    r = load_forceplate_csv(p)
    np.testing.assert_allclose(r.cop_ml_cm, 2.0, rtol=1e-12)
    np.testing.assert_allclose(r.cop_ap_cm, -3.0, rtol=1e-12)
    np.testing.assert_allclose(r.fz_n, 700.0, rtol=1e-12)
    assert r.meta["fz_unit"] == "N"
    p.write_text("time,x,y,Fz [%BW]\n0,1,2,100\n0.01,1,2,99\n")
    r = load_forceplate_csv(p)
    assert r.fz_n.tolist() == [100, 99] and r.meta["fz_unit"] == "as written in 'Fz [%BW]', no force unit"
    p.write_text("time,Fz [furlong],Mx,My\n0,700,1,2\n0.01,700,1,2\n")
    with pytest.raises(ValueError, match=r"the force column 'Fz \[furlong\]': unknown force unit 'furlong' "
                                         r"\(known: N, kN, kgf, lbf\)"):
        load_forceplate_csv(p)

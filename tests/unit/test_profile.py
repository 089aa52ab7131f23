"""Device profiles (docs/spec.md §5 "Device profiles"): the shipped files hold the thesis' numbers,
bad files fail in one line naming the file and the key, and geometry places cells as drawn by hand."""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

import psmat
from psmat.balance import cop
from psmat.circuit import Circuit
from psmat.process import Processor
from psmat.profile import (DEFAULT_PROFILE, Geometry, Profile, ProfileError, default_geometry, list_profiles,
                           load_profile, session_profile)

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

SHIPPED_DIR = Path(psmat.profile.__file__).parent / "profiles"

# name: (kind, protocol, rate Hz, baud, shape, pitch cm, (R_o Ω, V_ref V, bits, R_mux Ω, R_adc Ω) or None)
THESIS = {
    # thesis §2.2.2: USB, 100 Hz, R_adc about 6.9 MΩ; §2.2.1: R_o 2.2 kΩ, 12 bits, R_mux 145 Ω, 32 cm, 16 tracks
    "psm16": ("psm", "v2", 100.0, 1_000_000, (16, 16), 2.0, (2200.0, 3.3, 12, 145.0, 6.9e6)),
    # thesis §2.2.1: text over Bluetooth (115200 bit/s, §2.2.2), 10 Hz, typical R_ADC 123 kΩ
    "psm16-v0": ("psm", "csv", 10.0, 115_200, (16, 16), 2.0, (2200.0, 3.3, 12, 145.0, 123e3)),
    # thesis §3.2.1: one of every two rows and columns of the 32 cm mat
    "psm8": ("psm", "v2", 100.0, 1_000_000, (8, 8), 4.0, (2200.0, 3.3, 12, 145.0, 6.9e6)),
    # thesis §2.4.1: 10 sensors, a line every 500 ms; ATmega4809 10-bit ADC at 5 V
    "daq": ("daq", "daq-text", 2.0, 115_200, (10,), None, (2200.0, 5.0, 10, 0.0, math.inf)),
    # thesis §4.2: five BNO055, 10 Hz, 3 Euler angles each
    "imu": ("imu", "v2", 10.0, 1_000_000, (5, 3), None, None),
    # Arduino Uno (10-bit, 5 V), two CD74HC4067 (about 70 Ω each), ATmega328P analog input 100 MΩ
    "arduino16": ("psm", "csv", 10.0, 115_200, (16, 16), 2.0, (2200.0, 5.0, 10, 140.0, 100e6)),
}


def _write(tmp_path: Path, text: str, name: str = "mat.toml") -> Path:
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


GOOD = """name = "mine"
description = "a test mat"
kind = "psm"
protocol = "csv"
rate_hz = 20
baudrate = 115200

[geometry]
shape = [3, 2]
pitch_cm = 2.5

[circuit]
r_o_ohm = 1000.0
v_ref_volt = 5.0
bits = 10
r_mux_ohm = 100.0
r_adc_ohm = 1e8
"""


# ------------------------------------------------------------------ shipped profiles
def test_every_shipped_profile_loads_under_its_own_name() -> None:
    names = [p.name for p in list_profiles()]
    assert names == sorted(THESIS) == sorted(p.stem for p in SHIPPED_DIR.glob("*.toml"))
    for name in names:
        prof = load_profile(name)
        assert prof.source == f"builtin:{name}"
        text = (SHIPPED_DIR / f"{name}.toml").read_text(encoding="utf-8")
        assert text.startswith("# ") and text.count("\n# ") >= 2  # a header says what and where from
    assert DEFAULT_PROFILE == "psm16" and psmat.Profile is Profile and psmat.load_profile is load_profile


@pytest.mark.parametrize("name", sorted(THESIS))
def test_shipped_numbers_are_the_sources(name: str) -> None:
    kind, protocol, rate_hz, baud, shape, pitch_cm, circuit = THESIS[name]
    p = load_profile(name)
    assert (p.kind, p.protocol, p.rate_hz, p.baudrate, p.shape, p.pitch_cm) == (kind, protocol, rate_hz, baud,
                                                                                  shape, pitch_cm)
    if pitch_cm is not None:
        assert p.geometry is not None and p.geometry.shape == shape
        assert p.shape[0] * pitch_cm == p.shape[1] * pitch_cm == 32.0  # every mat here is 32 cm wide
        assert p.cell_area_cm2 == pitch_cm**2
        assert (p.geometry.origin_cm, p.geometry.x, p.geometry.y) == ((0.0, 0.0), "+columns", "+rows")
    else:
        assert p.geometry is None and p.cell_area_cm2 is None
    if circuit is None:
        with pytest.raises(ProfileError, match="no measurement circuit"):
            p.circuit()
    else:
        assert (p.r_o_ohm, p.v_ref_volt, p.bits, p.r_mux_ohm, p.r_adc_ohm) == circuit
        c = p.circuit()
        assert isinstance(c, Circuit)
        assert (c.r_o, c.v_ref, c.bits, c.r_mux, c.r_adc) == circuit


def test_default_geometry_is_the_thesis_mat() -> None:
    g = default_geometry()
    assert (g.shape, g.pitch_cm, g.cell_area_cm2) == ((16, 16), 2.0, 4.0)  # docs/spec.md §1: 2 cm pitch, 4 cm²
    assert default_geometry((4, 5)).shape == (4, 5) and default_geometry((4, 5)).pitch_cm == 2.0


@pytest.mark.parametrize("name", sorted(THESIS))
def test_round_trips(name: str) -> None:
    p = load_profile(name)
    d = p.to_dict()
    again = Profile.from_dict(json.loads(json.dumps(d, allow_nan=False)))  # strict JSON, as a session stores it
    assert again == p and again.source == p.source
    text = p.to_toml()
    assert text.startswith(f"# source: builtin:{name}\n")
    assert Profile.from_dict(tomllib.loads(text)) == p


def test_a_users_file_loads_and_reshapes(tmp_path: Path) -> None:
    path = _write(tmp_path, GOOD)
    p = load_profile(path)
    assert p.source == str(path) and p.shape == (3, 2) and p.rate_hz == 20.0 and p.cell_area_cm2 == 6.25
    assert load_profile(str(path)) == p
    q = p.with_shape((6, 4))
    assert q.shape == (6, 4) and q.pitch_cm == 2.5 and q.r_o_ohm == 1000.0 and q.name == "mine-6x4"
    assert p.with_shape((3, 2)) is p


def test_a_file_notepad_saved_with_a_byte_order_mark_loads(tmp_path: Path) -> None:
    """TOML is UTF-8; Windows' Notepad may begin it with a byte-order mark (before: "not valid TOML")."""
    path = tmp_path / "bom.toml"
    path.write_bytes(GOOD.encode("utf-8-sig"))
    p, plain = load_profile(path), load_profile(_write(tmp_path, GOOD))
    assert p.source == str(path) and p.shape == (3, 2) and p.rate_hz == 20.0
    assert {**p.to_dict(), "source": plain.source} == plain.to_dict()


# ------------------------------------------------------------------ bad files: one line naming file and key
BAD = [
    # a typo is not a default
    (GOOD.replace("pitch_cm = 2.5", "pich_cm = 2.5"), "geometry.pich_cm", "unknown key"),
    (GOOD + "colour = \"red\"\n", "circuit.colour", "unknown key"),
    (GOOD.replace('kind = "psm"', 'kind = "psm"\nshape_cells = 3'), "shape_cells", "unknown key"),
    # wrong types
    (GOOD.replace("pitch_cm = 2.5", 'pitch_cm = "2.5"'), "geometry.pitch_cm", "number"),
    (GOOD.replace("bits = 10", "bits = 10.0"), "circuit.bits", "integer"),
    (GOOD.replace("shape = [3, 2]", "shape = 3"), "geometry.shape", "2 integers"),
    (GOOD.replace("rate_hz = 20", "rate_hz = -20"), "rate_hz", "> 0"),
    (GOOD.replace('protocol = "csv"', 'protocol = "v9"'), "protocol", "v1, v2, csv"),
    (GOOD.replace("pitch_cm = 2.5", 'pitch_cm = 2.5\nx = "+rows"\ny = "-rows"'), "geometry.y", "different lines"),
    # wire orders must be permutations of the rows (0..2) and columns (0..1)
    (GOOD + "[wire]\nrow_order = [0, 0, 1]\n", "wire.row_order", "permutation"),
    (GOOD + "[wire]\ncol_order = [0, 1, 2]\n", "wire.col_order", "permutation"),
    (GOOD + "[wire]\nrow_order = [2, 1, 0.0]\n", "wire.row_order", "integers"),
    # missing tables and keys
    (GOOD.replace('description = "a test mat"\n', ""), "description", "missing"),
    (GOOD.split("[circuit]")[0], "circuit", "missing"),
]


@pytest.mark.parametrize("text, key, words", BAD, ids=[b[1] + ": " + b[2] for b in BAD])
def test_a_bad_file_is_one_line_naming_file_and_key(tmp_path: Path, text: str, key: str, words: str) -> None:
    path = _write(tmp_path, text)
    with pytest.raises(ProfileError) as err:
        load_profile(path)
    msg = str(err.value)
    assert isinstance(err.value, ValueError) and "\n" not in msg
    assert msg.startswith(f"{path}: {key}: ") and words in msg, msg


def test_unreadable_inputs_are_one_line(tmp_path: Path) -> None:
    for arg, words in [(_write(tmp_path, "name = \n"), "not valid TOML"), (tmp_path / "nothere.toml", "no such"),
                       ("psm99", "no profile named 'psm99'; shipped: arduino16")]:
        with pytest.raises(ProfileError) as err:
            load_profile(arg)
        assert words in str(err.value) and "\n" not in str(err.value)
    with pytest.raises(ProfileError, match=r"^stored: geometry\.pitch_cm: "):
        Profile.from_dict({**load_profile("psm16").to_dict(), "geometry": {"shape": [16, 16], "pitch_cm": 0}},
                          "stored")


# ------------------------------------------------------------------ wire order
def test_wire_to_logical_on_a_hand_made_frame(tmp_path: Path) -> None:
    p = load_profile(_write(tmp_path, GOOD + "[wire]\nrow_order = [2, 0, 1]\ncol_order = [1, 0]\n"))
    wire = np.array([[1, 2], [3, 4], [5, 6]])
    # wire row 0 is logical row 2, wire row 1 logical row 0, wire row 2 logical row 1; the columns swap
    logical = np.array([[4, 3], [6, 5], [2, 1]])
    np.testing.assert_array_equal(p.wire_to_logical(wire), logical)
    np.testing.assert_array_equal(p.wire_to_logical(np.stack([wire, 10 * wire])), np.stack([logical, 10 * logical]))
    plain = load_profile(_write(tmp_path, GOOD, "plain.toml"))
    np.testing.assert_array_equal(plain.wire_to_logical(wire), wire)
    with pytest.raises(ValueError, match="frames must be"):
        p.wire_to_logical(np.zeros((2, 3)))


# ------------------------------------------------------------------ geometry
def test_default_geometry_centres() -> None:
    x, y = Geometry((2, 3), 2.0).cell_centres_cm()
    np.testing.assert_array_equal(x, [[0, 2, 4], [0, 2, 4]])
    np.testing.assert_array_equal(y, [[0, 0, 0], [2, 2, 2]])


def test_mirrored_axes_and_an_origin() -> None:
    # x falls with the column index, y with the row index, cell (0, 0) at (30, 20)
    x, y = Geometry((2, 3), 2.0, (30.0, 20.0), x="-columns", y="-rows").cell_centres_cm()
    np.testing.assert_array_equal(x, [[30, 28, 26], [30, 28, 26]])
    np.testing.assert_array_equal(y, [[20, 20, 20], [18, 18, 18]])


def test_swapped_axes() -> None:
    # x (M-L) down the rows, falling; y (A-P) along the columns; cell (i, p) at (10 - 1.5 i, 5 + 1.5 p)
    g = Geometry((2, 3), 1.5, (10.0, 5.0), x="-rows", y="+columns")
    x, y = g.cell_centres_cm()
    np.testing.assert_array_equal(x, [[10, 10, 10], [8.5, 8.5, 8.5]])
    np.testing.assert_array_equal(y, [[5, 6.5, 8], [5, 6.5, 8]])
    assert g.cell_area_cm2 == 2.25
    assert Geometry.from_dict(g.to_dict()) == g
    with pytest.raises(ValueError, match="different lines"):
        Geometry((2, 3), 1.5, x="+rows", y="-rows")


def test_a_subgrid_sits_where_its_cells_are() -> None:
    g = Geometry((4, 6), 2.0, (1.0, 3.0), x="-columns", y="+rows")
    sub = g.subgrid(1, 0, 2)  # rows 1, 3 and columns 0, 2, 4
    sx, sy = sub.cell_centres_cm()
    x, y = g.cell_centres_cm()
    np.testing.assert_array_equal(sx, x[1::2, 0::2])
    np.testing.assert_array_equal(sy, y[1::2, 0::2])


def test_cop_of_a_two_cell_frame() -> None:
    p = np.zeros((2, 3))
    p[0, 0], p[1, 2] = 1.0, 3.0  # 1 unit at cell (0, 0), 3 units at cell (1, 2)
    g = Geometry((2, 3), 1.5, (10.0, 5.0), x="-rows", y="+columns")
    # centres (10, 5) and (8.5, 8): CoP = ((10 + 3·8.5)/4, (5 + 3·8)/4)
    np.testing.assert_allclose(cop(p, geometry=g), [35.5 / 4, 29.0 / 4])
    # default orientation, 2 cm: centres (0, 0) and (4, 2)
    np.testing.assert_allclose(cop(p), [3.0, 1.5])
    np.testing.assert_allclose(cop(p, 2.0), [3.0, 1.5])
    np.testing.assert_allclose(cop(np.stack([p, 2 * p]), geometry=g), [[35.5 / 4, 29.0 / 4]] * 2)
    with pytest.raises(ValueError, match="not both"):
        cop(p, 2.0, geometry=g)
    with pytest.raises(ValueError, match="2x3"):
        cop(np.zeros((3, 2)) + 1, geometry=g)


def test_the_chain_records_its_geometry() -> None:
    g = Geometry((2, 3), 1.5, (10.0, 5.0), x="-rows", y="+columns")
    proc = Processor((2, 3), geometry=g, method=None)
    out = proc.push(np.full((1, 2, 3), 2000), 0.01)
    assert proc.pitch_cm == 1.5 and out.params["geometry"] == g.to_dict() and out.params["pitch_cm"] == 1.5
    assert Processor((2, 3), method=None).geometry == default_geometry((2, 3))
    with pytest.raises(ValueError, match="not both"):
        Processor((2, 3), geometry=g, pitch_cm=2.0, method=None)


# ------------------------------------------------------------------ a session's profile
def test_session_profile_stored_or_rebuilt() -> None:
    stored = load_profile("psm8").to_dict()
    s = SimpleNamespace(kind="psm", device={}, frame_shape=(8, 8), profile=stored, path="a.h5")
    assert session_profile(s) == load_profile("psm8")
    # an older file: no profile; the device record's pitch (as the synthetic studies write it)
    old = SimpleNamespace(kind="psm", device={"rows": 8, "cols": 8, "pitch_cm": 4.0, "bits": 12, "proto": 2,
                                              "rate": 100}, frame_shape=(8, 8), calibration=None, path="b.h5")
    p = session_profile(old)
    assert (p.shape, p.pitch_cm, p.cell_area_cm2, p.protocol, p.bits) == ((8, 8), 4.0, 16.0, "v2", 12)
    # nothing in the record: the default profile's pitch, the session's shape
    bare = SimpleNamespace(kind="psm", device={}, frame_shape=(12, 10), path=None)
    p = session_profile(bare)
    assert p.shape == (12, 10) and p.pitch_cm == load_profile(DEFAULT_PROFILE).pitch_cm
    assert session_profile(SimpleNamespace(kind="imu", device={}, frame_shape=(5, 3))) == load_profile("imu")

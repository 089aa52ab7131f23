"""Calibration of a DAQ box (docs/spec.md §2; thesis §2.1.4 end): the estimators and the JSON data.

Expectations come from the circuit algebra written out here in resistance form, and the
censored-Gaussian fit is checked against scipy's maximum-likelihood fit of censored data.
"""

from __future__ import annotations

import ast
import json
from functools import partial
from pathlib import Path

import numpy as np
import pytest
from scipy import optimize, stats

import psmat

from psmat import circuit as estimate  # the estimators: estimate_r_adc, from_recordings, ...
from psmat.circuit import Calibration, Circuit

V_REF, R_O, R_MUX, BITS = 3.3, 2200.0, 145.0, 12
FS = 2**BITS - 1
LSB = V_REF / FS
R_ADC_FIRST, R_ADC_IMPROVED = 123e3, 6.9e6


# --------------------------------------------------------------------- calibration
def _short_counts(circuit, pairs, shape, frames, noise_v, rng):
    """Counts of recordings with one row-column pair shorted by a wire (cell R = 0 → G huge)."""
    out = {}
    for i, p in pairs:
        G = np.zeros((frames, *shape))
        G[:, i, p] = 1e12  # 1 pΩ: R_path = R_mux to 1e-12 Ω
        out[(i, p)] = circuit.counts(G, noise_v=noise_v, rng=rng)
    return out


def _r_mux_tolerance(r_mux, r_adc):
    """Half an LSB at the short-circuit reading, expressed in Ω (plus rounding margin)."""
    r_x = r_mux * r_adc / (r_mux + r_adc)
    c = FS * r_x / (R_O + r_x)
    drx_dc = R_O * FS / (FS - c) ** 2  # R_x = R_o c/(FS - c)
    drpath_drx = (r_adc / (r_adc - r_x)) ** 2  # R_path = R_x || (-R_adc)
    return 0.5 * drx_dc * drpath_drx * 1.05


@pytest.mark.parametrize("r_adc, frames", [(R_ADC_FIRST, 20), (R_ADC_IMPROVED, 400)])
def test_open_circuit_recording_gives_r_adc(r_adc, frames):
    c = Circuit(r_adc=r_adc)
    rec = c.counts(np.zeros((frames, 16, 16)), noise_v=1e-3, rng=5)
    cal = estimate.from_open_circuit(rec, c, serial="box-1")
    assert cal.r_adc == pytest.approx(r_adc, rel=0.05)
    st = cal.open_stats
    assert st.n_samples == rec.size
    assert st.count_sd == pytest.approx(1e-3 / LSB, rel=0.1)  # the spread is the noise
    m = FS * r_adc / (R_O + r_adc)
    assert st.r_adc_per_count == pytest.approx(R_O * FS / (FS - m) ** 2, rel=0.05)
    # a single frame (256 samples) works too, within the standard error it reports: for the
    # improved prototype one count is ~5 MΩ, so 256 samples of 1.2-LSB noise give ~6 %
    one = estimate.from_open_circuit(rec[0], c)
    assert abs(one.r_adc - r_adc) < 4 * one.open_stats.r_adc_se


def test_open_circuit_rejects_bad_recordings():
    c = Circuit.first_prototype()
    with pytest.raises(ValueError, match=r"\(R, C\)"):
        estimate.from_open_circuit(np.full(10, 4000), c)
    with pytest.raises(ValueError):
        estimate.from_open_circuit(np.full((2, 2), np.nan), c)
    with pytest.raises(TypeError):
        estimate.from_open_circuit(np.full((2, 2), 4000 + 0j), c)
    with pytest.raises(ValueError, match="end of the ADC range"):
        estimate.from_open_circuit(np.full((2, 2), FS), c)


@pytest.mark.parametrize("r_adc", [R_ADC_FIRST, R_ADC_IMPROVED])
def test_short_circuit_recordings_give_r_mux(r_adc):
    c = Circuit(r_adc=r_adc)
    pairs = [(i, p) for i in range(4) for p in range(4)]
    rec = _short_counts(c, pairs, (4, 4), 30, noise_v=1e-4, rng=np.random.default_rng(2))
    cal = estimate.from_short_circuit(rec, c)
    tol = _r_mux_tolerance(R_MUX, r_adc)
    assert tol < 0.5  # one LSB is ~0.6 Ω at the short-circuit reading
    assert cal.r_mux == pytest.approx(R_MUX, abs=tol)
    assert cal.short_stats.r_mux_pairs.shape == (4, 4)
    np.testing.assert_allclose(cal.short_stats.r_mux_pairs, R_MUX, atol=tol)
    assert cal.r_adc == r_adc


def test_short_circuit_per_pair_and_sample_forms():
    rng = np.random.default_rng(4)
    r_mux = rng.uniform(120, 170, size=(3, 2))
    c = Circuit(r_mux=r_mux, r_adc=R_ADC_FIRST)
    pairs = [(i, p) for i in range(3) for p in range(2)]
    rec = _short_counts(c, pairs, (3, 2), 10, noise_v=1e-4, rng=rng)
    cal = estimate.from_short_circuit(rec, c, per_pair=True)
    assert cal.r_mux.shape == (3, 2)
    np.testing.assert_allclose(cal.r_mux, r_mux, atol=_r_mux_tolerance(170.0, R_ADC_FIRST))
    # the same recordings given as that cell's samples only
    samples = {k: v[:, k[0], k[1]] for k, v in rec.items()}
    cal2 = estimate.from_short_circuit(samples, c, per_pair=True)
    np.testing.assert_array_equal(cal2.r_mux, cal.r_mux)
    # the summary is the median over pairs
    assert estimate.from_short_circuit(rec, c).r_mux == pytest.approx(np.median(cal.r_mux))
    # per_pair needs every pair
    del rec[(0, 0)]
    with pytest.raises(ValueError, match="every pair"):
        estimate.from_short_circuit(rec, c, per_pair=True)


def test_short_circuit_rejects_bad_input():
    c = Circuit()
    with pytest.raises(ValueError):
        estimate.from_short_circuit({}, c)
    with pytest.raises(ValueError, match="outside"):
        estimate.from_short_circuit({(5, 0): np.zeros((2, 3), dtype=np.uint16)}, c)
    with pytest.raises(ValueError, match="pairs"):
        estimate.from_short_circuit({(0, -1): np.array([250])}, c)
    with pytest.raises(ValueError, match="pair"):
        estimate.from_short_circuit({(0, 0): np.array([4095, 4095])}, c)
    # above the open-circuit reading of the first prototype (4023): the wire is not there
    with pytest.raises(ValueError, match="reads as open"):
        estimate.from_short_circuit({(0, 0): np.array([4050])}, Circuit.first_prototype())


def _calibration():
    c = Circuit(r_adc=R_ADC_FIRST)
    rng = np.random.default_rng(9)
    open_rec = c.counts(np.zeros((20, 4, 4)), noise_v=1e-3, rng=rng)
    shorts = _short_counts(c, [(i, p) for i in range(4) for p in range(4)], (4, 4), 10, 1e-4, rng)
    return estimate.from_recordings("PSM-0042", open_rec, shorts, Circuit(), date="2024-05-17", notes="lab")


def test_from_recordings_combines_both():
    cal = _calibration()
    assert cal.serial == "PSM-0042" and cal.date == "2024-05-17" and cal.notes == "lab"
    assert cal.r_adc == pytest.approx(R_ADC_FIRST, rel=0.05)
    assert cal.r_mux == pytest.approx(R_MUX, abs=0.5)
    assert cal.open_stats is not None and cal.short_stats is not None


def test_calibration_save_load_round_trip(tmp_path):
    cal = _calibration()
    path = tmp_path / "cal.json"
    cal.save(path)
    d = json.loads(path.read_text())
    assert d["serial"] == "PSM-0042"
    assert {"r_adc_ohm", "r_mux_ohm", "r_o_ohm", "v_ref_volt", "bits"} <= d.keys()
    back = Calibration.load(path)
    assert back == cal
    assert back.r_adc == cal.r_adc and back.r_mux == cal.r_mux
    # per-pair arrays survive too
    per_pair = Calibration("x", 123e3, np.arange(6.0).reshape(2, 3) + 140, date="2024-01-01")
    per_pair.save(path)
    np.testing.assert_array_equal(Calibration.load(path).r_mux, per_pair.r_mux)
    # the file saved again by an editor on Windows, with a byte-order mark (before: "Unexpected UTF-8 BOM")
    path.write_bytes(path.read_bytes().decode().encode("utf-8-sig"))
    np.testing.assert_array_equal(Calibration.load(path).r_mux, per_pair.r_mux)


def test_a_calibration_is_applied_to_a_circuit():
    cal = _calibration()
    c = Circuit().calibrated(cal)
    assert (c.r_adc, c.r_mux, c.r_o, c.v_ref, c.bits) == (cal.r_adc, cal.r_mux, 2200.0, 3.3, 12)
    # the circuit keeps its side of the divider; R_adc and R_mux are the calibration's
    assert Circuit(sensor_side="high").calibrated(cal).sensor_side == "high"
    with pytest.raises(ValueError, match="r_o"):
        Circuit(r_o=1000.0).calibrated(cal)
    with pytest.raises(ValueError, match="bits"):
        Circuit(bits=10).calibrated(cal)
    with pytest.raises(TypeError):
        Circuit().calibrated({"r_adc_ohm": 1.0})


@pytest.mark.parametrize(
    "text",
    [
        "",
        "{not json",
        '{"format": "psmat-calibration"',
        "[1, 2]",
        '{"format": "other", "version": 1}',
        "GOOD:r_adc_ohm=-5",
        "GOOD:r_adc_ohm=NaN",
        'GOOD:r_adc_ohm="123k"',
        "GOOD:bits=12.5",
        "GOOD:r_mux_ohm=[[1, 2], [3]]",
        "GOOD:date=\"yesterday\"",
        "GOOD:version=3",
        "GOOD:version=true",
        "GOOD:pressure=[1]",
        "DROP:serial",
    ],
)
def test_corrupt_calibration_file(tmp_path, text):
    path = tmp_path / "bad.json"
    if text.startswith(("GOOD:", "DROP:")):
        good = _calibration().to_dict()
        if text.startswith("DROP:"):
            del good[text[5:]]
            body = json.dumps(good)
        else:
            key, val = text[5:].split("=", 1)
            good[key] = "@@"
            body = json.dumps(good).replace('"@@"', val)
        path.write_text(body)
    else:
        path.write_text(text)
    with pytest.raises(ValueError):
        Calibration.load(path)


def test_binary_garbage_and_missing_calibration_file(tmp_path):
    path = tmp_path / "bad.json"
    path.write_bytes(b"\xff\xfe\x00garbage")
    with pytest.raises(ValueError, match="not a valid calibration"):
        Calibration.load(path)
    with pytest.raises(FileNotFoundError):
        Calibration.load(tmp_path / "nope.json")


def test_calibration_validation():
    with pytest.raises(ValueError):
        Calibration("x", r_adc=-1.0, r_mux=145.0)
    with pytest.raises(ValueError):
        Calibration("x", r_adc=123e3, r_mux=np.full((2, 2), -1.0))
    with pytest.raises(TypeError):
        Calibration(12, r_adc=123e3, r_mux=145.0)  # type: ignore[arg-type]
    with pytest.raises(ValueError):
        Calibration("x", r_adc=123e3, r_mux=145.0, date="17/05/2024")


# --------------------------------------------------------------------- no Calibration <-> Circuit cycle
PKG = Path(psmat.__file__).resolve().parent


def _module_file(name: str) -> Path | None:
    rel = Path(*name.split(".")[1:])
    for f in (PKG / rel.with_suffix(".py"), PKG / rel / "__init__.py"):
        if f.is_file():
            return f
    return None


def _psmat_imports(name: str) -> set[str]:
    """psmat modules that module ``name`` imports anywhere in its source (lazy and type-only imports too)."""
    f = _module_file(name)
    is_pkg = f.name == "__init__.py"
    base = name.split(".") if is_pkg else name.split(".")[:-1]
    found: set[str] = set()
    for node in ast.walk(ast.parse(f.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            found.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            pkg = base[: len(base) - node.level + 1] if node.level else []
            mod = ".".join(pkg + ([node.module] if node.module else []))
            found.add(mod)
            found.update(f"{mod}.{a.name}" for a in node.names)
    return {m for m in found if m.startswith("psmat") and _module_file(m) is not None and m != "psmat"}


def _reachable(start: str) -> set[str]:
    seen: set[str] = set()
    todo = sorted(_psmat_imports(start))
    while todo:
        m = todo.pop()
        if m not in seen:
            seen.add(m)
            todo.extend(_psmat_imports(m))
    return seen


@pytest.mark.parametrize("module", ["psmat.circuit._calibration", "psmat.circuit._circuit", "psmat.circuit._estimate"])
def test_no_import_cycle_through_calibration_or_circuit(module):
    assert module not in _reachable(module)


def test_calibration_is_plain_data():
    # the data module knows nothing of the circuit; the estimators import both
    assert "psmat.circuit._circuit" not in _reachable("psmat.circuit._calibration")
    assert {"psmat.circuit._calibration", "psmat.circuit._circuit"} <= _psmat_imports("psmat.circuit._estimate")


@pytest.mark.parametrize(
    "kwargs, exc",
    [
        (dict(r_o=0.0), ValueError),
        (dict(r_o="2200"), TypeError),
        (dict(r_adc=-1.0), ValueError),
        (dict(v_ref=np.inf), ValueError),
        (dict(bits=17), ValueError),
        (dict(bits=12.0), TypeError),
        (dict(r_mux=np.full((2, 2), -1.0)), ValueError),
        (dict(r_mux=np.ones(3)), ValueError),
        (dict(r_mux=1j), TypeError),
    ],
)
def test_circuit_and_calibration_share_one_validation(kwargs, exc):
    const = dict(r_o=R_O, r_mux=R_MUX, r_adc=R_ADC_FIRST, v_ref=V_REF, bits=BITS) | kwargs
    with pytest.raises(exc) as by_circuit:
        Circuit(**const)
    with pytest.raises(exc) as by_calibration:
        Calibration("x", **const)
    assert str(by_calibration.value) == str(by_circuit.value)


def test_estimators_need_the_low_side_circuit():
    high = Circuit(sensor_side="high")
    with pytest.raises(ValueError, match="sensor_side"):
        estimate.from_open_circuit(np.full((2, 2), 2000), high)
    with pytest.raises(ValueError, match="sensor_side"):
        estimate.from_short_circuit({(0, 0): np.array([250])}, high)


# --------------------------------------------------------------------- censored-Gaussian fit
def _scipy_censored_fit(c: np.ndarray, fs: int) -> tuple[float, float]:
    """Independent MLE: scipy's fit of interval-censored normal data (count k: [k-1/2, k+1/2], open ends)."""
    lo = np.where(c <= 0, -np.inf, c - 0.5)
    hi = np.where(c >= fs, np.inf, c + 0.5)
    tight = partial(optimize.fmin, xtol=1e-10, ftol=1e-14, maxiter=20000, maxfun=20000, disp=0)
    with np.errstate(divide="ignore"):  # scipy takes log(0) for the censored ends' empty side
        data = stats.CensoredData.interval_censored(lo, hi)
        loc, scale = stats.norm.fit(data, loc=c.mean(), scale=c.std(), optimizer=tight)
    return float(loc), float(scale)


@pytest.mark.parametrize("mu, sd", [(FS - 1.3, 1.24), (FS - 0.4, 0.6), (0.7, 0.9)])
def test_clipped_recording_mean_is_the_censored_mle(mu, sd):
    rng = np.random.default_rng(11)
    c = np.clip(np.rint(mu + sd * rng.standard_normal((20, 8, 8))), 0, FS)
    assert 0.05 < np.mean((c == 0) | (c == FS)) < 0.95  # clipped, but not all
    _, st = estimate.estimate_r_adc(c, Circuit())
    loc, scale = _scipy_censored_fit(c.ravel(), FS)
    assert st.count_mean == pytest.approx(loc, abs=1e-6)
    assert st.count_sd == pytest.approx(scale, abs=1e-6)
    assert st.clipped_fraction == np.mean((c == 0) | (c == FS))

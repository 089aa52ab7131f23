"""Material metrics (eq. 2.1-2.4), simulated runs and the material-DAQ loader (thesis §2.1.3, §2.4; docs/spec.md §4)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from psmat.sensor import MPICreep
from psmat.sensor.metrics import (
    CREEP_RADAR_TIME_S,
    creep,
    creep_by_step,
    drift,
    drift_by_step,
    format_table,
    hysteresis,
    hysteresis_loops,
    material_table,
    pulse_means,
    table_summary,
    variability,
    variability_by_level,
)
from psmat.sensor.plots import plot_hysteresis_loops, radar_chart
from psmat.sensor.pneumatic import (
    PneumaticRun,
    SkippedLine,
    divider_conductance,
    divider_counts,
    load_daq_log,
    load_schedule_csv,
    simulate_run,
)
from psmat.sensor.protocols import (
    Segment,
    ascending_hysteresis,
    descending_hysteresis,
    fast_cyclic,
    long_staircase,
)

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


def run_of(p: np.ndarray, g: np.ndarray, segments: list[Segment], dt: float = 0.5, name: str = "run"
           ) -> PneumaticRun:
    t = np.arange(p.shape[0]) * dt
    return PneumaticRun(name=name, t=t, p=p, g=g, dt=dt, segments=segments)


# --------------------------------------------------------------------------- variability (eq. 2.1)
def test_variability_known_values(rng):
    pr = fast_cyclic(5.0, cycles=4, on_s=60, off_s=30)
    cells = 3
    vals = 1e-3 * (1.0 + 0.2 * rng.standard_normal((4, cells)))  # ḡ[cycle, cell]
    g = np.zeros((pr.n_samples, cells))
    loads = [s for s in pr.segments if s.label == "load"]
    for k, s in enumerate(loads):
        g[s.start:s.stop] = 5e-3  # the first part of the pulse must not count …
        g[s.stop - 60:s.stop] = vals[k]  # … only the last 30 s (60 samples at 2 Hz)
    run = run_of(pr.p_psi, g, pr.segments, name="fast_cyclic")
    lv, means = pulse_means(run)
    assert np.all(lv == 5.0)
    np.testing.assert_allclose(means, vals, rtol=1e-14)
    expected = np.var(vals, ddof=1) / np.mean(vals) ** 2
    assert variability(run) == pytest.approx(expected, rel=1e-12)
    assert variability(run, ddof=0) == pytest.approx(np.var(vals) / np.mean(vals) ** 2, rel=1e-12)
    # tuple form of a run
    assert variability((run.t, run.p, run.g, run.segments)) == pytest.approx(expected, rel=1e-12)
    # a window longer than a pulse is an error, not a silent truncation
    with pytest.raises(ValueError, match="shorter"):
        variability(run, window_s=90.0)


def test_variability_per_level():
    segs = [Segment(0, 80, "load", 5.0), Segment(80, 100, "rest", 0.0), Segment(100, 180, "load", 15.0),
            Segment(180, 200, "rest", 0.0), Segment(200, 280, "load", 5.0), Segment(280, 300, "rest", 0.0)]
    p = np.zeros(300)
    g = np.zeros((300, 2))
    for s in segs:
        p[s.start:s.stop] = s.level
    g[0:80] = [1.0, 3.0]
    g[200:280] = [1.0, 3.0]
    g[100:180] = [2.0, 2.0]
    by = variability_by_level(run_of(p, g, segs), ddof=0)
    assert by == {5.0: pytest.approx(0.25), 15.0: 0.0}


# --------------------------------------------------------------------------- drift (eq. 2.2)
def test_drift_of_constant_signal_with_gaussian_noise(rng):
    pr = long_staircase(levels=(0, 10, 20, 0), step_s=600)
    mu, sigma = 2e-3, 2e-5
    g = mu + sigma * rng.standard_normal((pr.n_samples, 8))
    run = run_of(pr.p_psi, g, pr.segments, name="long_staircase")
    steps = drift_by_step(run)
    assert [(m.step, m.level) for m in steps] == [(2, 10.0), (3, 20.0)]  # 0-psi steps skipped
    for m in steps:
        assert m.value == pytest.approx(sigma / mu, rel=0.03)
    assert drift(run) == pytest.approx(sigma / mu, rel=0.03)


def test_drift_exact_and_discards_first_half():
    # one 120 s step at 2 Hz: first 60 s discarded, then 2 windows of 30 s
    n = 240
    p = np.full(n, 5.0)
    g = np.full((n, 1), 1.0)
    g[:120] = 50.0  # discarded half: a huge change that must not count
    g[120:240:2] += 0.1  # ±0.05 square wave around 1.05 → population SD 0.05 exactly
    run = run_of(p, g, [Segment(0, n, "step", 5.0)])
    (m,) = drift_by_step(run, ddof=0)
    assert m.value == pytest.approx(0.05 / 1.05, rel=1e-12)
    # the drift windows are 30 s long: a 90 s kept part gives 3 windows, a trailing partial one is dropped
    with pytest.raises(ValueError, match="window"):
        drift_by_step(run, window_s=90.0)


# --------------------------------------------------------------------------- creep (eq. 2.3)
def test_creep_of_linear_ramps():
    pr = long_staircase(levels=(0, 5, 30, 5), step_s=300)
    t = pr.t_s
    slopes = np.array([2e-8, -4e-8, 1e-8])  # S/s, per cell
    offsets = np.array([1e-3, 2e-3, 5e-4])  # S
    g = offsets + slopes * t[:, None]
    run = run_of(pr.p_psi, g, pr.segments, name="long_staircase")
    res = creep_by_step(run)
    assert [(m.step, m.level) for m in res] == [(2, 5.0), (3, 30.0), (4, 5.0)]
    for m in res:
        s = pr.segments[m.step - 1]
        a = s.start + (s.stop - s.start) // 2  # second half [t_e - ΔT/2, t_e]
        mean = offsets + slopes * t[a:s.stop].mean()
        assert m.value == pytest.approx(np.mean(np.abs(slopes) / mean), rel=1e-9)
    assert creep(run) == pytest.approx(np.mean([m.value for m in res]), rel=1e-12)
    # a pure ramp of known relative slope: creep = that slope (1/s), whatever the step
    g2 = 1e-3 * (1.0 + 1e-5 * (t - t[-1]))[:, None] * np.ones((1, 2))
    for m in creep_by_step(run_of(pr.p_psi, g2, pr.segments)):
        s = pr.segments[m.step - 1]
        a = s.start + (s.stop - s.start) // 2
        assert m.value == pytest.approx(1e-5 / (1.0 + 1e-5 * (t[a:s.stop].mean() - t[-1])), rel=1e-9)


def test_creep_ignores_cells_with_nan():
    p = np.full(100, 5.0)
    g = np.stack([np.linspace(1.0, 2.0, 100), np.full(100, np.nan)], axis=1)
    run = run_of(p, g, [Segment(0, 100, "step", 5.0)])
    (m,) = creep_by_step(run)
    x = np.arange(50, 100) * 0.5
    y = g[50:, 0]
    assert m.value == pytest.approx(abs(np.polyfit(x, y, 1)[0]) / y.mean(), rel=1e-9)


# --------------------------------------------------------------------------- hysteresis (eq. 2.4)
def no_hysteresis_model() -> MPICreep:
    return MPICreep(rho=0.0, tau=0.3, a1=1.5e-4, a2=0.0, a3=0.0)


def hysteretic_model() -> MPICreep:
    return MPICreep(rho=1.64e-4, tau=0.1, a1=1.0e-4, a2=-2e-6, a3=0.0)  # no creep


def poly(m: MPICreep, p: np.ndarray) -> np.ndarray:
    q = m.params
    return q["a1"] * p + q["a2"] * p**2 + q["a3"] * p**3


def analytic_descending(m: MPICreep, P: float) -> float:
    """0 → P → 0 from rest: play operators y_r = (p − r)+ rising, min(p, (P − r)+) falling."""
    p = np.arange(0.0, P + 1.0, 2.0)
    r, b = m.thresholds, m.weights
    up = poly(m, p) + ((p[:, None] - r).clip(min=0) * b).sum(axis=1)
    down = poly(m, p) + (np.minimum(p[:, None], (P - r).clip(min=0)) * b).sum(axis=1)
    allv = np.concatenate([up, down])
    return float(np.max(np.abs(up - down)) / (allv.max() - allv.min()))


def analytic_ascending(m: MPICreep, valley: float, top: float = 32.0) -> float:
    """0 → top → valley → top: falling y_r = min(p, top − r), rising y_r = max(p − r, min(valley, top − r))."""
    p = np.arange(valley, top + 1.0, 2.0)
    r, b = m.thresholds, m.weights
    yt = (top - r).clip(min=0)
    down = poly(m, p) + (np.minimum(p[:, None], yt) * b).sum(axis=1)
    up = poly(m, p) + (np.maximum(p[:, None] - r, np.minimum(valley, yt)) * b).sum(axis=1)
    allv = np.concatenate([up, down])
    return float(np.max(np.abs(up - down)) / (allv.max() - allv.min()))


@pytest.mark.parametrize("protocol", [descending_hysteresis(repetitions=2), ascending_hysteresis(repetitions=1)])
def test_no_hysteresis_model_gives_zero(protocol):
    run = simulate_run(protocol, no_hysteresis_model(), cells=3, variability=0.0, noise_rel=0.0)
    loops = hysteresis_loops(run)
    assert len(loops) == (8 if protocol.name.startswith("desc") else 7)
    for h in loops:
        assert h.value == pytest.approx(0.0, abs=1e-12)
    assert hysteresis(run) == pytest.approx(0.0, abs=1e-12)


def test_descending_loops_match_the_play_operator_analytics():
    m = hysteretic_model()
    run = simulate_run(descending_hysteresis(repetitions=2), m, cells=4, variability=0.2, noise_rel=0.0, rng=3)
    loops = hysteresis_loops(run)
    assert [(h.kind, h.level, h.n_repetitions) for h in loops] == [("descending", float(P), 2) for P in range(4, 33, 4)]
    for h in loops:
        np.testing.assert_array_equal(h.p_psi, np.arange(0.0, h.level + 1.0, 2.0))
        assert h.value == pytest.approx(analytic_descending(m, h.level), rel=1e-9)
    assert hysteresis(run) == pytest.approx(np.mean([analytic_descending(m, P) for P in range(4, 33, 4)]), rel=1e-9)
    assert 0.01 < loops[-1].value < 0.5


def test_ascending_loops_match_the_play_operator_analytics():
    m = hysteretic_model()
    run = simulate_run(ascending_hysteresis(repetitions=1), m, cells=2, variability=0.0, noise_rel=0.0)
    loops = hysteresis_loops(run)
    assert [(h.kind, h.level) for h in loops] == [("ascending", float(v)) for v in range(4, 29, 4)]
    for h in loops:
        np.testing.assert_array_equal(h.p_psi, np.arange(h.level, 33.0, 2.0))
        assert h.value == pytest.approx(analytic_ascending(m, h.level), rel=1e-9)


def test_thesis_model_hysteresis_is_plausible():
    # creep makes the loops of the thesis model depend on history; just check sizes and ranges
    run = simulate_run(descending_hysteresis(repetitions=1), cells=2, variability=0.0, noise_rel=0.0)
    vals = [h.value for h in hysteresis_loops(run)]
    assert all(0.0 < v < 0.3 for v in vals)


# --------------------------------------------------------------------------- simulation
def test_simulate_run_gains_noise_and_reproducibility():
    pr = fast_cyclic(10.0, cycles=1, on_s=2.0, off_s=1.0)
    a = simulate_run(pr, cells=20000, variability=0.1, noise_rel=0.0, rng=7)
    gains = a.meta["gains"]
    assert a.g.shape == (pr.n_samples, 20000)
    assert np.all(gains > 0)
    assert np.mean(gains) == pytest.approx(1.0, abs=0.004)
    assert np.std(gains) / np.mean(gains) == pytest.approx(0.1, rel=0.03)
    g_model = MPICreep.thesis().direct(pr.p_psi, pr.dt_s)
    np.testing.assert_allclose(a.g, g_model[:, None] * gains[None, :], rtol=1e-14)
    b = simulate_run(pr, cells=20000, variability=0.1, noise_rel=0.0, rng=7)
    np.testing.assert_array_equal(a.g, b.g)
    # relative noise → drift ≈ noise_rel
    lp = long_staircase(levels=(0, 15), step_s=300)
    run = simulate_run(lp, MPICreep(rho=0.0, tau=0.1, a1=1e-4, a2=0, a3=0), cells=10, noise_rel=0.01, rng=1)
    assert drift(run) == pytest.approx(0.01, rel=0.05)
    with pytest.raises(ValueError):
        simulate_run(pr, cells=0)


# --------------------------------------------------------------------------- DAQ loader
def daq_lines(counts: np.ndarray, sep: str = " ") -> list[str]:
    return [sep.join(str(int(c)) for c in row) for row in counts]


def test_divider_round_trip_and_flags():
    g = np.array([0.0, 1e-5, 1e-4, 1e-3, 5e-3, 1e-2])
    for side in ("low", "high"):
        c = divider_counts(g, bits=10, sensor_side=side)
        g2, flags = divider_conductance(c / 1023.0, sensor_side=side)
        np.testing.assert_array_equal(divider_counts(g2, bits=10, sensor_side=side), c)
    # low side: full scale is open (0 S), 0 counts is a short (NaN, never inf)
    g3, f3 = divider_conductance(np.array([0.0, 1.0, 0.5]), r_o=2200.0)
    assert math.isnan(g3[0]) and g3[1] == 0.0 and g3[2] == pytest.approx(1 / 2200.0)
    assert list(f3) == [1, 2, 0]  # SHORT, OPEN, OK (psmat.circuit flags)


def test_load_daq_log_with_protocol_schedule(tmp_path):
    pr = descending_hysteresis(p_max=8, repetitions=1)  # 0→8→0→4→0: 13 plateaus, 156 lines
    sim = simulate_run(pr, cells=10, variability=0.1, noise_rel=0.0, rng=2)
    counts = divider_counts(sim.g)
    lines = daq_lines(counts, sep=", ")
    lines.insert(0, "# material DAQ, Velostat PCB")
    lines.insert(5, "")
    lines[9] = lines[9] + "   # inline comment"
    path = tmp_path / "log.txt"
    path.write_text("\n".join(lines) + "\n" + "1017 1017 10")  # the acquisition stopped mid-line
    run = load_daq_log(path, schedule=pr)
    assert run.name == "descending_hysteresis"
    assert run.g.shape == (pr.n_samples, 10)
    np.testing.assert_array_equal(run.t, pr.t_s)
    np.testing.assert_array_equal(run.p, pr.p_psi)
    assert run.segments == pr.segments
    np.testing.assert_array_equal(divider_counts(run.g), counts)  # conversion undone exactly
    assert run.skipped == [SkippedLine(len(lines) + 1, "1017 1017 10", run.skipped[0].reason)]
    assert "partial" in run.skipped[0].reason
    assert run.meta["line_numbers"][0] == 2
    # recovered hysteresis close to the simulated one (10-bit quantisation)
    assert hysteresis(run) == pytest.approx(hysteresis(sim), abs=0.02)


def test_load_daq_log_from_lines_and_csv_schedule():
    g = np.zeros((18, 10))
    g[6:12] = 2e-3
    lines = daq_lines(divider_counts(g))  # whitespace separated, no newlines
    sched = ["time_s,pressure_psi", "0,0", "3,5", "6,0", "9,0"]
    run = load_daq_log(lines, schedule=sched, name="fast_cyclic")
    np.testing.assert_array_equal(run.p, [0.0] * 6 + [5.0] * 6 + [0.0] * 6)
    assert [(s.start, s.stop, s.level) for s in run.segments] == [(0, 6, 0.0), (6, 12, 5.0), (12, 18, 0.0)]
    assert np.all(run.g[:6] == 0.0) and np.all(run.flags[:6] == 2)  # at rest: open → 0 S, flagged
    np.testing.assert_allclose(run.g[6:12], 2e-3, rtol=0.01)
    # the log started 3 s into the schedule; samples beyond its end are dropped
    run2 = load_daq_log(lines, schedule=sched, offset_s=3.0)
    assert run2.p[0] == 5.0 and run2.t[0] == 3.0
    assert run2.meta["n_outside_schedule"] == 6 - 1  # t = 9 s is the schedule's last row, inclusive
    t, p = load_schedule_csv(sched)
    np.testing.assert_array_equal(t, [0, 3, 6, 9])


def test_load_daq_log_time_column_and_volts():
    rows = ["0 1.0 2.5", "500 1.0 2.5", "1000 1.0 2.5"]
    run = load_daq_log(rows, n_sensors=2, time_column=True, unit="volts", v_ref=5.0, r_o=1000.0)
    np.testing.assert_allclose(run.t, [0.0, 0.5, 1.0])
    np.testing.assert_allclose(run.g[0], [4.0 / 1000.0, 1.0 / 1000.0])  # R_s = R_o x/(1-x)
    assert np.all(np.isnan(run.p)) and run.segments == []
    with pytest.raises(ValueError, match="line 2"):
        load_daq_log(["500 1 1", "400 1 1"], n_sensors=2, time_column=True, unit="volts")


def test_load_daq_log_errors(tmp_path):
    good = daq_lines(np.full((6, 10), 600))
    bad = list(good)
    bad[3] = "600 600 600 6x0 600 600 600 600 600 600"
    with pytest.raises(ValueError, match=r"line 4\b"):
        load_daq_log(bad)
    short = list(good)
    short[2] = "600 600 600"
    with pytest.raises(ValueError, match=r"line 3: .*expected 10 values, got 3"):
        load_daq_log(short)
    # a malformed last line *with* its newline is corrupt, not partial
    p = tmp_path / "log.txt"
    p.write_text("\n".join(good + ["600 600"]) + "\n")
    with pytest.raises(ValueError, match="line 7"):
        load_daq_log(p)
    # the same line without newline is a partial line: skipped, reported
    p.write_text("\n".join(good + ["600 600"]))
    assert load_daq_log(p).skipped[0].line_no == 7
    over = list(good)
    over[1] = "600 600 600 600 600 600 600 600 600 1024"
    with pytest.raises(ValueError, match=r"line 2: sensor 10 reading 1024 outside \[0, 1023\]"):
        load_daq_log(over)
    with pytest.raises(ValueError, match="no readings"):
        load_daq_log(["# only a comment", ""])
    with pytest.raises(FileNotFoundError):
        load_daq_log(tmp_path / "missing.txt")
    with pytest.raises(ValueError, match="line 3"):
        load_schedule_csv(["time,pressure", "0,0", "0,5"])
    with pytest.raises(ValueError, match="overlap"):
        load_daq_log(good, schedule=["0,0", "1,5"], offset_s=100.0)


def test_a_schedule_from_a_european_spreadsheet_reads_as_the_plain_one() -> None:
    plain = load_schedule_csv(["time_s,pressure_psi", "0,0", "10.5,2.5", "20,5"])
    european = load_schedule_csv(["time_s;pressure_psi", "0;0", "10,5;2,5", "20;5"])
    for a, b in zip(plain, european):
        np.testing.assert_array_equal(a, b)
    assert european[0].tolist() == [0.0, 10.5, 20.0] and european[1].tolist() == [0.0, 2.5, 5.0]


def test_a_schedule_file_as_a_spreadsheet_saves_it(tmp_path) -> None:
    """Excel's "CSV UTF-8" begins with a byte-order mark (before: its header "\\ufefftime_s" named no
    time column); its "Unicode text" is UTF-16 with tabs and, in a European locale, decimal commas;
    its "CSV" on a western Windows is Windows-1252 (before: "not UTF-8 text")."""
    plain = load_schedule_csv(["time_s,pressure_psi", "0,0", "10.5,2.5", "20,5"])
    f = tmp_path / "schedule.csv"
    for data in ("time_s,pressure_psi\r\n0,0\r\n10.5,2.5\r\n20,5\r\n".encode("utf-8-sig"),
                 "time_s\tpressure_psi\n0\t0\n10,5\t2,5\n20\t5\n".encode("utf-16"),
                 "# Prüfstand: Druck in psi\ntime_s;pressure_psi\n0;0\n10,5;2,5\n20;5\n".encode("cp1252")):
        f.write_bytes(data)
        for a, b in zip(plain, load_schedule_csv(f)):
            np.testing.assert_array_equal(a, b)
    f.write_bytes(b"time_s,pressure_psi\n0,0\n\x00\x00\n")
    with pytest.raises(ValueError, match=r"schedule .*schedule.csv is not text \(byte 0x00 at offset 24\)"):
        load_schedule_csv(f)


def test_a_schedule_header_names_its_units_and_they_are_converted() -> None:
    """Read as psi, a schedule written in kPa was 6.9 times too high (the header was skipped unread)."""
    plain = load_schedule_csv(["time_s,pressure_psi", "0,0", "60,14.50377438972831"])  # 100 kPa = 14.5038 psi
    for header, rows in (("time_ms,pressure_kpa", ["0,0", "60000,100"]), ("Time [ms],Pressure (kPa)", ["0,0", "60000,100"]),
                         ("t,p_bar", ["0,0", "60,1"]), ("time,pressure", ["0,0", "60,14.50377438972831"])):
        t, p = load_schedule_csv([header, *rows])
        np.testing.assert_allclose(t, plain[0], rtol=1e-15)
        np.testing.assert_allclose(p, plain[1], rtol=1e-9)  # psi by psmat.units: 1 psi = 6.894757 kPa
    with pytest.raises(ValueError, match="line 1: header 'seconds,load' names no time and pressure column"):
        load_schedule_csv(["seconds,load", "0,0", "1,5"])
    with pytest.raises(ValueError, match="line 1: unknown pressure unit 'atm'"):
        load_schedule_csv(["time_s,pressure_atm", "0,0", "1,5"])


# --------------------------------------------------------------------------- tables and figures
@pytest.fixture(scope="module")
def small_study() -> dict[str, list[PneumaticRun]]:
    """Two 'materials', short protocols (fewer cycles, shorter steps)."""
    out = {}
    for k, (name, model) in enumerate([("Velostat", MPICreep.thesis()), ("Other", hysteretic_model())]):
        rng = np.random.default_rng(k)
        protos = [fast_cyclic(5.0, cycles=3, on_s=60, off_s=60), fast_cyclic(15.0, cycles=3, on_s=60, off_s=60),
                  long_staircase(step_s=120), descending_hysteresis(repetitions=1),
                  ascending_hysteresis(repetitions=1)]
        out[name] = [simulate_run(p, model, cells=4, rng=rng) for p in protos]
    return out


def test_material_table(small_study):
    table = material_table(small_study)
    assert {r["metric"] for r in table} == {"variability", "drift", "creep", "hysteresis"}
    v = [r for r in table if r["material"] == "Velostat" and r["metric"] == "variability"]
    assert [r["condition"] for r in v] == ["5 psi", "15 psi", "mean"]
    assert v[-1]["value"] == pytest.approx((v[0]["value"] + v[1]["value"]) / 2)
    c = [r["condition"] for r in table if r["material"] == "Velostat" and r["metric"] == "creep"]
    assert c == ["2) 5 psi", "3) 15 psi", "4) 30 psi", "5) 15 psi", "6) 5 psi", "mean"]
    assert all(r["unit"] == "1/s" for r in table if r["metric"] == "creep")
    h = [r for r in table if r["material"] == "Velostat" and r["metric"] == "hysteresis"]
    assert len(h) == 7 + 8 + 1 and h[0]["condition"] == "ascending 4 psi" and h[-2]["condition"] == "descending 32 psi"
    assert h[-1]["value"] == pytest.approx(np.mean([r["value"] for r in h[:-1]]))  # Table 2.10: all loops
    summ = table_summary(table)
    assert set(summ) == {"Velostat", "Other"} and set(summ["Other"]) == {"variability", "drift", "creep", "hysteresis"}
    txt = format_table(table, "variability")
    assert txt.splitlines()[0].split() == ["material", "5", "psi", "15", "psi", "mean"]
    with pytest.raises(ValueError, match="cannot tell"):
        material_table({"x": [PneumaticRun("mystery", np.zeros(1), np.zeros(1), np.zeros((1, 1)), 0.5, [])]})


def test_radar_and_loops_write_png(small_study, tmp_path):
    table = material_table(small_study)
    out = radar_chart(table, tmp_path / "radar.png")
    data = out.read_bytes()
    assert data.startswith(PNG_MAGIC) and len(data) > 5000
    assert CREEP_RADAR_TIME_S == 1500.0
    out2 = plot_hysteresis_loops(small_study["Velostat"][4], tmp_path / "loops.png")
    data2 = out2.read_bytes()
    assert data2.startswith(PNG_MAGIC) and len(data2) > 5000

"""A recorded session through the one path (:func:`psmat.process.process_session`,
:func:`~psmat.process.process_loaded`): each frame stepped with its own period, the circuit in
the documented order.

The sessions are made here from a known load: cell pressures (psi) → the thesis' sensor model
(Table 2.11) at the true frame times → cell conductances → crosstalk (:func:`psmat.iecm.forward`)
→ 12-bit counts of the default circuit, frames stamped by the device clock every 10 ms. The
expected pressures are worked out by hand: the counts read back through the circuit, IECM on the
surviving frames (``iecm.solve`` on one thread at the chain's tolerance, the numbers of the chain on
one worker), and the inverse sensor model stepped with the true time between surviving frames.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from psmat import Calibration, Circuit, iecm
from psmat.io import SessionWriter, load_session
from psmat.process import IECM_RTOL, Processor, process_loaded, process_session, session_circuit, session_clock
from psmat.sensor import MPICreep

SHAPE = (6, 6)
T = 60
DT_US = 10_000  # the device clock's frame period, µs (100 frames/s)
DT = DT_US * 1e-6
DROPPED = [20, 21, 22, 41]  # lost on the wire: frames the host never received
PSI_KPA = 6.894757  # 1 psi in kPa, by definition


def _load_psi() -> np.ndarray:
    """(T, R, C) psi: a 2×2 patch that rises, is held from frame 15 to 45 (over every gap), then
    falls; every other cell a light, steady load (no cell reads open)."""
    level = np.interp(np.arange(T), [0, 15, 45, T - 1], [2.0, 12.0, 12.0, 6.0])
    p = np.full((T,) + SHAPE, 0.5)
    p[:, 2:4, 2:4] = level[:, None, None]
    return p


@pytest.fixture(scope="module")
def counts() -> np.ndarray:
    g = MPICreep.thesis().direct(_load_psi(), DT)  # the true cell conductances, S
    return Circuit().counts(iecm.forward(g))


def _write(path: Path, counts: np.ndarray, keep: np.ndarray, *, placeholders: bool = False,
           calibration: object = None) -> Path:
    """A v2 session of the frames ``keep`` (their own seq and device time); with ``placeholders``
    the others are stored as frames that failed their check on the wire (seq and time -1)."""
    k = np.arange(T)
    rows = k if placeholders else k[keep]
    ok = keep[rows]
    c = np.where(ok[:, None, None], counts[rows], 0).astype(np.uint16)
    host = 1.7e9 + rows * DT + 0.004  # the host's stamps: not what the chain steps with
    with SessionWriter(path, SHAPE, {"rows": SHAPE[0], "cols": SHAPE[1], "serial": "BOX1"},
                       calibration=calibration) as w:
        w.append(c, host, ok, seq=np.where(ok, rows, -1), device_time_us=np.where(ok, rows * DT_US, -1))
    return path


def _by_hand(counts: np.ndarray, frames: np.ndarray) -> np.ndarray:
    """Pressure (kPa) of ``frames``: the circuit's inverse, IECM, and the inverse sensor model
    stepped with the true time since the previous surviving frame (the first: one period)."""
    G, flags = Circuit().conductance(counts[frames], return_flags=True)
    assert np.all(flags == Circuit.OK)
    g = iecm.solve(G, "newton", threads=1, rtol=IECM_RTOL)  # the chain's stopping rule
    steps = np.diff(frames * DT, prepend=frames[0] * DT - DT)
    return MPICreep.thesis().inverse(g, steps) * PSI_KPA


@pytest.mark.parametrize("placeholders", [False, True], ids=["frames absent", "frames stored as invalid"])
def test_a_lost_frame_advances_the_sensor_model_by_its_real_interval(counts, tmp_path, placeholders) -> None:
    keep = np.ones(T, bool)
    keep[DROPPED] = False
    survivors = np.flatnonzero(keep)
    path = _write(tmp_path / "lost.h5", counts, keep, placeholders=placeholders)
    out = process_session(path, threads=1, save=False, progress=False)
    expected = _by_hand(counts, survivors)
    got = out.pressure_kpa[out.usable]
    np.testing.assert_allclose(got, expected, rtol=1e-12, atol=0)
    if placeholders:
        assert out.usable.tolist() == keep.tolist() and np.all(np.isnan(out.pressure_kpa[DROPPED]))
    # the steps were the device clock's: 40 ms and 20 ms after the gaps, 10 ms elsewhere
    assert out.clock is not None and out.clock.source == "device"
    np.testing.assert_allclose(out.clock.t_s[out.usable], survivors * DT, rtol=0, atol=1e-12)


def test_the_same_session_without_drops_gives_the_same_pressures_where_the_load_is_held(counts, tmp_path) -> None:
    """Around each gap the load is held (frames 15-45) and the frames read the same counts, so the
    sensor model stepped once over the gap is the model stepped frame by frame through it, to
    second order in the creep during the gap: the lossy session's pressures are the whole
    session's at the surviving frames. Stepping every frame with one period instead (the median,
    a lost frame advancing nothing) misses the creep of the gap itself, a first-order error
    (creep is slow, eq. 2.23: l = 8e-4 and 5e-6 1/s, so it is small, but far above the first)."""
    keep = np.ones(T, bool)
    keep[DROPPED] = False
    survivors = np.flatnonzero(keep)
    whole = process_session(_write(tmp_path / "whole.h5", counts, np.ones(T, bool)), threads=1, save=False,
                            progress=False)
    lossy = process_session(_write(tmp_path / "lossy.h5", counts, keep), threads=1, save=False, progress=False)
    after = [int(np.searchsorted(survivors, 23)), int(np.searchsorted(survivors, 42))]  # first frames after gaps
    ref = whole.pressure_kpa[survivors]
    held = lossy.pressure_kpa[lossy.usable]
    dev = np.max(np.abs(held - ref) / ref)
    G = Circuit().conductance(counts[survivors])
    one_period = MPICreep.thesis().inverse(iecm.solve(G, "newton", threads=1, rtol=IECM_RTOL), DT) * PSI_KPA
    miss = np.max(np.abs(one_period[after] - ref[after]) / ref[after])
    assert miss > 1e-7, miss  # about 2e-6 of the pressure here
    assert dev < 1e-4 * miss, (dev, miss)  # about 2e-12


def test_a_box_that_restarted_is_placed_by_the_host_clock_and_stepped_with_the_true_interval(counts, tmp_path) -> None:
    """The box lost power for 0.5 s after frame 29 (or was unplugged and reconnected): its clock
    and sequence numbers start again. The frames after the restart are a new segment of the device
    clock, placed after the first by the host clock; before, such a session was refused ("the
    device clock does not advance at frame 30") and nothing of it could be processed."""
    k = np.arange(T)
    true_s = k * DT + np.where(k >= 30, 0.5, 0.0)  # the frames' times on the first segment's clock
    dev = np.where(k < 30, k * DT_US, 300 + (k - 30) * DT_US)  # the clock starts again at 300 µs
    host = 1.7e9 + true_s + 0.004 + 0.001 * (k % 3)  # the same USB latencies in both segments
    path = tmp_path / "restart.h5"
    with SessionWriter(path, SHAPE, {"rows": SHAPE[0], "cols": SHAPE[1], "serial": "BOX1"}) as w:
        w.append(counts, host, np.ones(T, bool), seq=np.where(k < 30, k, k - 30), device_time_us=dev)
    out = process_session(path, threads=1, save=False, progress=False)
    assert out.clock is not None and out.clock.source == "device" and out.clock.restarts == 1
    np.testing.assert_allclose(out.clock.t_s, true_s, rtol=0, atol=1e-6)  # the host times' float64 grain
    assert "started again 1 time(s)" in out.params["frame_clock"]
    # the sensor model stepped 0.51 s over the outage, 10 ms elsewhere (by hand, as _by_hand)
    G = Circuit().conductance(counts)
    steps = np.diff(true_s, prepend=-DT)
    expected = MPICreep.thesis().inverse(iecm.solve(G, "newton", threads=1, rtol=IECM_RTOL), steps) * PSI_KPA
    np.testing.assert_allclose(out.pressure_kpa, expected, rtol=1e-9, atol=0)


def test_a_restarted_clock_without_host_times_after_it_is_one_clear_error(counts, tmp_path) -> None:
    k = np.arange(T)
    host = np.where(k < 30, 1.7e9 + k * DT, np.nan)  # nothing to place the second segment by
    path = tmp_path / "restart.h5"
    with SessionWriter(path, SHAPE, {"rows": SHAPE[0], "cols": SHAPE[1]}) as w:
        w.append(counts, host, np.ones(T, bool), device_time_us=np.where(k < 30, k, k - 30) * DT_US)
    with pytest.raises(ValueError, match="the device clock started again at frame 30, and the frames 30-59"):
        process_session(path, save=False)


def test_the_stored_calibration_wins_over_a_circuit_argument(counts, tmp_path) -> None:
    """docs/spec.md §2: a calibration is applied when data are loaded. The session's stored
    calibration comes first, a ``circuit`` argument only for a session without one, and a
    calibration file passed by the caller replaces R_adc and R_mux (same box only)."""
    stored = Circuit(r_mux=200.0)
    other = Circuit(r_mux=50.0)
    keep = np.ones(T, bool)
    with_cal = load_session(_write(tmp_path / "stored.h5", counts, keep, calibration=stored.as_dict()))
    without = load_session(_write(tmp_path / "bare.h5", counts, keep))
    assert session_circuit(with_cal, circuit=other) == stored
    assert session_circuit(without, circuit=other) == other
    assert session_circuit(without) == Circuit()
    # the products say which, and are those of that circuit's conductances
    out = process_loaded(with_cal, circuit=other, method=None)
    assert out.params["circuit_from"] == "the session's stored calibration"
    np.testing.assert_array_equal(out.G, stored.conductance(counts))
    assert process_loaded(without, circuit=other, method=None).params["circuit_from"] == "the circuit passed by the caller"
    # a calibration file of the same box replaces R_adc and R_mux of the stored circuit
    cal = tmp_path / "BOX1.json"
    Calibration("BOX1", r_adc=5e6, r_mux=120.0).save(cal)
    assert session_circuit(with_cal, circuit=other, calibration=cal) == Circuit(r_mux=120.0, r_adc=5e6)
    wrong = tmp_path / "BOX2.json"
    Calibration("BOX2", r_adc=5e6, r_mux=120.0).save(wrong)
    with pytest.raises(ValueError, match="BOX2.json is box 'BOX2'; the session was recorded with box 'BOX1'"):
        session_circuit(with_cal, calibration=wrong)
    # a stored calibration file's content (psmat calibrate) is a circuit too
    calibrated = load_session(_write(tmp_path / "cal.h5", counts, keep,
                                     calibration=Calibration("BOX1", r_adc=5e6, r_mux=120.0).to_dict()))
    assert session_circuit(calibrated, circuit=other) == Circuit(r_mux=120.0, r_adc=5e6)


def test_the_host_clock_spreads_the_frames_of_one_read_evenly(counts, tmp_path) -> None:
    """No device clock (v1, csv): the host stamps the frames of one read alike, so the frames are
    placed evenly between the first and the last stamp."""
    path = tmp_path / "v1.h5"
    host = 100.0 + 0.04 * (np.arange(T) // 4 + 1)  # four frames per read, one read every 40 ms
    with SessionWriter(path, SHAPE, {"rows": SHAPE[0], "cols": SHAPE[1]}) as w:
        w.append(counts, host, np.ones(T, bool))
    clock = session_clock(load_session(path))
    step = (host[-1] - host[0]) / (T - 1)
    assert clock.source == "host" and clock.filled == 0
    np.testing.assert_allclose(clock.t_s, host[0] + np.arange(T) * step, rtol=0, atol=1e-9)
    np.testing.assert_allclose(clock.periods_s, step, rtol=1e-9)


def test_a_stretch_without_frames_cuts_the_host_clock(counts, tmp_path) -> None:
    """A csv mat whose cable was out for 3 s in the middle (no frame taken, or all lost): one line through
    the first and last stamps gave every frame a period of (span + 3 s) / 59, 0.07 s for 0.02. Each part
    is now placed back from its last stamp at the streaming period, and the period at the cut is the time
    between the parts."""
    path = tmp_path / "gap.h5"
    true = 0.02 * np.arange(T) + np.where(np.arange(T) >= 30, 3.0, 0.0)   # 50 Hz, 3 s out after frame 29
    host = 1000.0 + true   # one frame per read
    with SessionWriter(path, SHAPE, {"rows": SHAPE[0], "cols": SHAPE[1]}) as w:
        w.append(counts, host, np.ones(T, bool))
    clock = session_clock(load_session(path))
    assert clock.gaps == 1 and clock.source == "host"
    # psmat info says it: the step and the time of day it ended on the recording computer's clock (1003.62 s
    # since 1970 is 00:16:43 UTC, shifted by the offset from UTC the writer stored, this machine's)
    import time

    from psmat.io import info

    off = load_session(path).utc_offset_s
    assert off is not None
    shown = time.strftime("%H:%M:%S", time.gmtime(16 * 60 + 43 + off))   # 00:16:43 UTC, at the stored offset
    assert f"  gaps          1 stretch of the host clock without frames: 3.02 s up to {shown} (the processing cuts " \
           "the clock there; the rate above counts it)" in info(path)
    # one frame a read: the streaming period is 0.02 s, and each part back from its last stamp gives the
    # frames' own times (by hand); the period at the cut is the 3 s out plus one frame's
    np.testing.assert_allclose(clock.t_s, host, rtol=0, atol=1e-9)
    np.testing.assert_allclose(np.delete(clock.periods_s, 30), 0.02, rtol=1e-6)
    assert clock.periods_s[30] == pytest.approx(3.02)


def test_a_burst_after_the_gap_is_placed_before_its_arrival(counts, tmp_path) -> None:
    """Reads of four frames every 80 ms (20 ms a frame), 4 s out after frame 23, then a read of 16 frames
    held in a buffer (taken in the 0.32 s before it arrived) and reads of four again: the burst does not
    fill half the step, so the recording is cut there, and the burst's frames are placed before their
    arrival at the streaming period: every frame at its own time."""
    path = tmp_path / "burst.h5"
    true = 0.02 * np.arange(T) + np.where(np.arange(T) >= 24, 4.0, 0.0)
    reads = np.r_[np.arange(24) // 4, 6 + (np.arange(24, 40) - 24) // 16, 7 + (np.arange(40, T) - 40) // 4]
    host = 1000.0 + np.array([true[reads == r].max() for r in reads])   # each read stamped at its last frame
    with SessionWriter(path, SHAPE, {"rows": SHAPE[0], "cols": SHAPE[1]}) as w:
        w.append(counts, host, np.ones(T, bool))
    clock = session_clock(load_session(path))
    np.testing.assert_allclose(clock.t_s, 1000.0 + true, rtol=0, atol=1e-9)


def test_frames_held_back_and_arriving_together_keep_one_line(counts, tmp_path) -> None:
    """The reader stalled 1.55 s while the board's frames waited in a buffer: they arrive together after the
    step and fill it, so nothing was lost and the frames stay on one line (as before the gap rule)."""
    path = tmp_path / "stall.h5"
    true = 0.05 * np.arange(T)   # 20 Hz
    host = true.copy()
    host[20:50] = 2.5            # frames 20-49 held back, all arriving at 2.5 s (frame 50's own time)
    with SessionWriter(path, SHAPE, {"rows": SHAPE[0], "cols": SHAPE[1]}) as w:
        w.append(counts, host, np.ones(T, bool))
    clock = session_clock(load_session(path))
    np.testing.assert_allclose(clock.t_s, true, rtol=0, atol=1e-9)


@pytest.mark.parametrize("host, match", [
    (np.full(T, 5.0), "frame times do not advance"),
    (np.r_[np.nan * np.ones(T - 1), 5.0], "fewer than two of the session's 60 frames carry a time stamp"),
])
def test_a_clock_that_gives_no_period_is_one_clear_error(counts, tmp_path, host, match) -> None:
    path = tmp_path / "bad.h5"
    with SessionWriter(path, SHAPE, {"rows": SHAPE[0], "cols": SHAPE[1]}) as w:
        w.append(counts, host, np.ones(T, bool))
    with pytest.raises(ValueError, match=match):
        process_session(path, save=False)


def test_a_session_without_calibration_is_read_through_its_profiles_circuit(tmp_path) -> None:
    """A do-it-yourself mat (the arduino16 profile: 10 bits, 5 V) recorded without a calibration:
    its counts go back to G through that circuit, not the thesis' 12-bit 3.3 V default."""
    from psmat.profile import load_profile

    prof = load_profile("arduino16").with_shape(SHAPE)
    arduino = Circuit(r_o=2200.0, r_mux=140.0, r_adc=100e6, v_ref=5.0, bits=10)  # the profile's numbers, by hand
    g = np.full(SHAPE, 2e-5)
    g[2:4, 2:4] = 1e-3
    G = iecm.forward(g)
    frames = np.repeat(arduino.counts(G)[None], 4, axis=0)
    path = tmp_path / "diy.h5"
    with SessionWriter(path, SHAPE, {"proto": "csv", "bits": 10}, profile=prof.to_dict()) as w:
        w.append(frames, 1.7e9 + np.arange(4) * 0.1, np.ones(4, bool))
    s = load_session(path)
    assert session_circuit(s).bits == 10 and session_circuit(s).v_ref == 5.0
    out = process_loaded(s, method=None)
    assert "arduino16" in out.params["circuit_from"]
    # 10-bit quantisation: G within the step of one count at these readings (a few %)
    np.testing.assert_allclose(out.G[0], G, rtol=0.05)
    wrong = Circuit().conductance(frames[0])  # the 12-bit 3.3 V default would be far off
    assert np.nanmax(np.abs(wrong / G - 1)) > 0.5


def test_one_batch_gives_the_numbers_of_the_stream_frame_by_frame(counts, tmp_path) -> None:
    # process_loaded solves the recording in one iecm.solve(threads=1) batch; the live path pushes
    # frames one at a time through the one-worker stream: the same warm starts, so the same numbers
    keep = np.ones(T, bool)
    keep[DROPPED] = False
    s = load_session(_write(tmp_path / "s.h5", counts, keep, placeholders=True))
    out = process_loaded(s, pitch_cm=2.0)
    periods = session_clock(s).periods_s
    with Processor(SHAPE, circuit=session_circuit(s), pitch_cm=2.0) as proc:
        pushed = [proc.push(s.counts[k:k + 1], periods[k:k + 1], valid=s.valid[k:k + 1]) for k in range(T)]
    for name in ("G", "g", "pressure_kpa"):
        np.testing.assert_array_equal(getattr(out, name), np.concatenate([getattr(p, name) for p in pushed]))
    # the CoP of one frame and of many add up in another order: round-off only
    np.testing.assert_allclose(out.cop_cm, np.concatenate([p.cop_cm for p in pushed]), rtol=0, atol=1e-12)
    info = [p.solve_info for p in pushed if p.solve_info is not None]
    np.testing.assert_array_equal(out.solve_info.iterations, np.concatenate([i.iterations for i in info]))
    np.testing.assert_array_equal(out.solve_info.status, np.concatenate([i.status for i in info]))
    # without the sensor model: the same G and g, no pressure, and the parameters say so
    bare = process_loaded(s, pitch_cm=2.0, pressure=False)
    np.testing.assert_array_equal(bare.g, out.g)
    np.testing.assert_array_equal(bare.cop_raw_cm, out.cop_raw_cm)
    assert np.all(np.isnan(bare.pressure_kpa)) and np.all(np.isnan(bare.cop_cm))
    assert bare.params["pressure"].startswith("not computed")

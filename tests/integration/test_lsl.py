"""Lab Streaming Layer with real outlets and inlets over loopback (liblsl through pylsl).

What an inlet sees of the mat's outlets (type, channels, rate, source id, description), the
pushed frames arriving equal with timestamps whose mapping to the host clock is checked against
the test's own reading of both clocks, ``psmat lsl --simulate`` resolved and read from another
process, and ``psmat record --lsl`` storing a test outlet's known samples. Each test uses
stream names of its own (a uuid), so parallel test processes never see each other's streams.
"""

from __future__ import annotations

import os
import subprocess
import sys
import threading
import time
import uuid
from collections.abc import Callable
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

pylsl = pytest.importorskip("pylsl")

from psmat.acquire import HostClock, LslInlet, PressureOutlets  # noqa: E402
from psmat.io import load_session  # noqa: E402
from conftest import child_preexec  # noqa: E402

ENV = {**os.environ, "PYTHONUNBUFFERED": "1"}


def unique(prefix: str) -> str:
    return f"{prefix}_{uuid.uuid4().hex[:12]}"


def raw_inlet(name: str, timeout_s: float = 10.0):
    """A plain pylsl inlet (not psmat's), for what LSL itself delivers."""
    found = pylsl.resolve_byprop("name", name, 1, timeout_s)
    assert found, f"stream {name} not found"
    inlet = pylsl.StreamInlet(found[0])
    inlet.open_stream(timeout_s)
    return inlet


def host_minus_local(now: Callable[[], float]) -> float:
    """The test's own reading of a host clock ``now`` − LSL local_clock (tightest of a few brackets)."""
    best = (np.inf, 0.0)
    for _ in range(20):
        a = pylsl.local_clock()
        h = now()
        b = pylsl.local_clock()
        best = min(best, (b - a, h - (a + b) / 2))
    return best[1]


def pull_until(inlet, n: int, timeout_s: float) -> tuple[list, list]:
    values: list = []
    stamps: list = []
    deadline = time.monotonic() + timeout_s
    while len(stamps) < n and time.monotonic() < deadline:
        v, t = inlet.pull_chunk(timeout=0.2, max_samples=1024)
        values += v
        stamps += t
    return values, stamps


def test_the_pressure_outlets_describe_themselves_to_an_inlet() -> None:
    name = unique("mat")
    with PressureOutlets((3, 5), rate_hz=100.0, pitch_cm=1.5, serial="BOX0042", name=name) as out:
        assert out.names == {"pressure": f"{name}-pressure", "cop": f"{name}-cop", "markers": f"{name}-markers"}
        with LslInlet(f"{name}-pressure", 10.0) as inlet:
            assert (inlet.name, inlet.type, inlet.channel_count) == (f"{name}-pressure", "Pressure", 15)
            assert inlet.nominal_srate == 100.0 and inlet.source_id == "BOX0042"
            assert inlet.channel_format == "float32"
            d = inlet.info.desc()
            assert (d.child_value("rows"), d.child_value("columns"), d.child_value("pitch_cm"),
                    d.child_value("unit")) == ("3", "5", "1.5", "kPa")
            # row-major: the second label is row 0, column 1; the last row 2, column 4
            assert inlet.channel_labels == ["r00c00", "r00c01", "r00c02", "r00c03", "r00c04",
                                            "r01c00", "r01c01", "r01c02", "r01c03", "r01c04",
                                            "r02c00", "r02c01", "r02c02", "r02c03", "r02c04"]
            assert inlet.channel_units == ["kPa"] * 15
        with LslInlet(f"{name}-cop", 10.0) as cop:
            assert (cop.type, cop.channel_count, cop.nominal_srate, cop.channel_format) == ("CoP", 2, 100.0, "float32")
            assert cop.channel_labels == ["ml_cm", "ap_cm"] and cop.channel_units == ["cm", "cm"]
            assert cop.info.desc().child_value("unit") == "cm"
        with LslInlet(f"{name}-markers", 10.0) as markers:
            assert (markers.type, markers.channel_count, markers.channel_format) == ("Markers", 1, "string")
            assert markers.nominal_srate == 0.0  # irregular


def test_an_inlet_finds_a_stream_by_its_type_when_no_stream_has_that_name() -> None:
    kind = unique("Force")
    info = pylsl.StreamInfo(unique("fp"), kind, 3, 100.0, pylsl.cf_double64, unique("src"))
    outlet = pylsl.StreamOutlet(info)
    with LslInlet(kind, 10.0) as inlet:
        assert inlet.type == kind and inlet.channel_count == 3
    del outlet


def test_pushed_frames_arrive_equal_with_timestamps_on_lsl_clock() -> None:
    name = unique("mat")
    clock = HostClock()
    rng = np.random.default_rng(7)
    T = 12
    pressure = rng.uniform(0.0, 80.0, (T, 4, 3))
    pressure[5] = np.nan  # a missing frame keeps its place
    cop = rng.uniform(-10.0, 10.0, (T, 2))
    host = clock.now() + 0.01 * np.arange(T)
    with PressureOutlets((4, 3), rate_hz=100.0, pitch_cm=1.0, serial="BOX1", name=name, clock=clock) as out:
        raw = raw_inlet(f"{name}-pressure")
        raw_cop = raw_inlet(f"{name}-cop")
        raw_markers = raw_inlet(f"{name}-markers")
        ours = LslInlet(f"{name}-pressure", 10.0, clock=clock)
        time.sleep(0.2)  # the inlets connected before the push
        assert out.push(SimpleNamespace(pressure_kpa=pressure, cop_cm=cop), host) == T
        out.push_marker("eyes closed", host_time_s=float(host[3]))
        values, stamps = pull_until(raw, T, 10.0)
        cvalues, cstamps = pull_until(raw_cop, T, 10.0)
        mvalues, mstamps = pull_until(raw_markers, 1, 10.0)
        chunk = ours.pull(timeout_s=5.0)
        while len(chunk) < T:
            more = ours.pull(timeout_s=5.0)
            assert len(more), "samples went missing"
            chunk = type(chunk)(np.vstack([chunk.values, more.values]), np.r_[chunk.host_time_s, more.host_time_s],
                                np.r_[chunk.lsl_time_s, more.lsl_time_s])
        ours.close()
    # values: float32 of the kPa, row-major; NaN stays NaN
    want = pressure.reshape(T, -1).astype(np.float32)
    np.testing.assert_array_equal(np.asarray(values, np.float32), want)
    np.testing.assert_array_equal(np.asarray(cvalues, np.float32), cop.astype(np.float32))
    assert mvalues == [["eyes closed"]]
    # LSL timestamps: the host times moved onto local_clock, by the test's own reading of the two clocks
    offset = host_minus_local(clock.now)
    np.testing.assert_allclose(np.asarray(stamps) + offset, host, atol=2e-3, rtol=0)
    np.testing.assert_allclose(np.asarray(cstamps) + offset, host, atol=2e-3, rtol=0)
    np.testing.assert_allclose(np.asarray(mstamps) + offset, host[3:4], atol=2e-3, rtol=0)
    # psmat's inlet puts them back on the host clock
    np.testing.assert_array_equal(chunk.values, want.astype(np.float64))
    np.testing.assert_allclose(chunk.host_time_s, host, atol=2e-3, rtol=0)


def test_stamps_stay_in_order_when_a_chunk_arrived_late() -> None:
    """A late frame ends one push; the next push's two frames arrived just after it but are 10 ms apart on
    the device: by the device clock the first would be stamped before the late frame. LSL gets them in
    order (spread between the two arrivals) instead."""
    name = unique("late")
    clock = HostClock()
    t0 = clock.now()
    with PressureOutlets((2, 2), rate_hz=100.0, pitch_cm=1.0, serial="BOX2", name=name, clock=clock) as out:
        raw = raw_inlet(f"{name}-pressure")
        time.sleep(0.2)  # the inlet connected before the pushes
        frames = SimpleNamespace(pressure_kpa=np.ones((2, 2, 2)), cop_cm=np.zeros((2, 2)))
        out.push(frames, [t0, t0 + 0.0293], [0, 10_000])            # the second frame arrived late
        out.push(frames, [t0 + 0.0297, t0 + 0.0297], [20_000, 30_000])
        _, stamps = pull_until(raw, 4, 10.0)
    assert len(stamps) == 4 and np.all(np.diff(stamps) > 0), np.diff(stamps)
    offset = host_minus_local(clock.now)
    np.testing.assert_allclose(np.asarray(stamps) + offset, [t0, t0 + 0.0293, t0 + 0.0295, t0 + 0.0297], atol=2e-3)


def test_psmat_lsl_simulate_publishes_streams_another_process_reads(tmp_path: Path) -> None:
    name = unique("twin")
    p = subprocess.Popen([sys.executable, "-m", "psmat", "lsl", "--simulate", "--seconds", "3", "--name", name],
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=ENV, cwd=tmp_path,
                         preexec_fn=child_preexec())
    try:
        first = p.stdout.readline()
        assert f"{name}-pressure" in first, (first, p.stderr.read() if p.poll() is not None else "")
        pressure = raw_inlet(f"{name}-pressure", 10.0)
        cop = raw_inlet(f"{name}-cop", 10.0)
        info = pressure.info(5.0)
        assert (info.type(), info.channel_count(), info.source_id()) == ("Pressure", 256, "TWIN0001")
        values, stamps = pull_until(pressure, 20, 10.0)
        cvalues, _ = pull_until(cop, 20, 10.0)
        out, err = p.communicate(timeout=60)
    finally:
        if p.poll() is None:
            p.kill()
            p.wait()
    assert p.returncode == 0, err[-2000:]
    assert len(stamps) >= 20 and np.all(np.diff(stamps) >= 0)
    v = np.asarray(values, np.float64)
    assert v.shape[1] == 256
    assert np.isfinite(v).any() and np.nanmin(v) >= 0.0  # pressures in kPa, never negative
    c = np.asarray(cvalues, np.float64)
    finite = c[np.isfinite(c).all(axis=1)]
    assert len(finite) and np.all(np.abs(finite) < 100.0)  # on a mat of tens of cm, not far off
    assert "frames published" in out


def _push_known(outlet, stop: threading.Event, log: list[tuple[int, float, float]]) -> None:
    """Sample k = (k, k + 0.5, -k) at 100 Hz, logged with its LSL timestamp and the wall time."""
    k = 0
    while not stop.is_set():
        ts = pylsl.local_clock()
        outlet.push_sample([float(k), k + 0.5, -float(k)], ts)
        log.append((k, ts, time.time()))
        k += 1
        time.sleep(0.01)


def test_psmat_record_lsl_stores_a_streams_samples_on_the_host_clock(tmp_path: Path) -> None:
    name = unique("FP")
    outlet = pylsl.StreamOutlet(pylsl.StreamInfo(name, "Force", 3, 100.0, pylsl.cf_double64, unique("fp")))
    stop = threading.Event()
    log: list[tuple[int, float, float]] = []
    pusher = threading.Thread(target=_push_known, args=(outlet, stop, log), daemon=True)
    pusher.start()
    out = tmp_path / "S.h5"
    try:
        r = subprocess.run([sys.executable, "-m", "psmat", "record", "--simulate", "--seconds", "2", "--lsl", name,
                            "-o", str(out)], capture_output=True, text=True, env=ENV, timeout=120, cwd=tmp_path)
    finally:
        stop.set()
        pusher.join(5)
    assert r.returncode == 0, r.stderr[-2000:]
    s = load_session(out)
    st = s.streams[f"lsl_{name}"]
    assert st.kind == "lsl" and st.frame_shape == (3,) and st.counts.dtype == np.float64
    assert st.device["name"] == name and st.device["channel_count"] == 3 and st.device["nominal_srate_hz"] == 100.0
    n = st.n_frames
    assert n >= 50  # about 200 in 2 s; generous
    k = st.counts[:, 0]
    np.testing.assert_array_equal(k, k[0] + np.arange(n))  # consecutive samples, none lost or repeated
    np.testing.assert_array_equal(st.counts, np.stack([k, k + 0.5, -k], axis=1))
    assert st.valid.all()
    # each sample's times against the test's own log of when it pushed it
    sent = {kk: (ts, wall) for kk, ts, wall in log}
    ts = np.array([sent[int(kk)][0] for kk in k])
    wall = np.array([sent[int(kk)][1] for kk in k])
    np.testing.assert_array_equal(st.device_time_us, np.round(ts * 1e6).astype(np.int64))
    # host time = LSL timestamp + the recorder's offset of local_clock against its host clock (loopback:
    # time_correction ~ microseconds) ...
    offset = st.device["lsl_to_host_offset_s"]
    np.testing.assert_allclose(st.host_time_s, ts + offset, atol=2e-3, rtol=0)
    # ... and that offset is the one between time.time() and local_clock(), by the test's own reading of
    # both clocks (the recorder's host clock reads like time.time(); 20 ms: clock readings, not timing)
    assert abs(offset - host_minus_local(time.time)) < 0.02
    # the pusher logged its wall time after stamping: an ordering, not a duration (a loaded machine only
    # delays the log); within the 20 ms the offset is known to
    assert np.all(wall >= ts + offset - 0.02)
    assert np.all(np.diff(st.host_time_s) > 0)
    t0, t1 = np.nanmin(s.host_time_s), np.nanmax(s.host_time_s)
    assert t0 - 0.5 <= st.host_time_s[0] and st.host_time_s[-1] <= t1 + 0.5  # inside the recording's span
    assert f"[lsl_{name}]" in r.stdout
    del outlet


def test_psmat_record_lsl_without_such_a_stream_is_one_line_and_no_file(tmp_path: Path) -> None:
    out = tmp_path / "S.h5"
    r = subprocess.run([sys.executable, "-m", "psmat", "record", "--simulate", "--seconds", "1", "--lsl",
                        unique("absent"), "-o", str(out)], capture_output=True, text=True, env=ENV, timeout=120)
    assert r.returncode == 1
    lines = [ln for ln in r.stderr.splitlines() if ln.startswith("psmat record:")]
    assert len(lines) == 1 and "no LSL stream" in lines[0], r.stderr
    assert not out.exists()


def test_psmat_lsl_replay_publishes_every_frame_of_a_session_and_ends(tmp_path: Path) -> None:
    session = tmp_path / "S.h5"
    r = subprocess.run([sys.executable, "-m", "psmat", "record", "--simulate", "--seconds", "1", "-o", str(session)],
                       capture_output=True, text=True, env=ENV, timeout=120)
    assert r.returncode == 0, r.stderr[-2000:]
    n = load_session(session).n_frames
    name = unique("replay")
    r = subprocess.run([sys.executable, "-m", "psmat", "lsl", "--replay", str(session), "--speed", "4", "--name", name,
                        "--seconds", "60"], capture_output=True, text=True, env=ENV, timeout=120)
    assert r.returncode == 0, r.stderr[-2000:]
    assert r.stdout.splitlines()[0].startswith(f"LSL stream {name}-pressure (Pressure, 256 channels in kPa")
    assert f"psmat lsl: {n} frames published" in r.stdout  # the replay's end ends the command, not --seconds


def test_psmat_lsl_wants_one_source(tmp_path: Path) -> None:
    r = subprocess.run([sys.executable, "-m", "psmat", "lsl", "--simulate", "/dev/ttyACM9"], capture_output=True,
                       text=True, env=ENV, timeout=60)
    assert r.returncode == 1 and r.stderr.strip() == "psmat lsl: give one of PORT, --simulate or --replay FILE"

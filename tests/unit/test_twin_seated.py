"""The seated twin (docs/spec.md §8 "Data", psmat.twin.seated): one posture drives the cushion and the IMUs.

Physics checked against hand calculations: the seat's force is the weight's share (and the
bounce's acceleration), the moment balance holds, leaning forward loads the thighs and leaning
back the sacrum, the IMU pitches are the tangents of the back's curve as eq. 4.4 reads them, the
drift stays within its stated bounds, and the protocol's phases are those of thesis §4.3.
"""

from __future__ import annotations

import dataclasses
import math

import time

import numpy as np
import pytest
import serial

from psmat import protocol
from psmat.posture import spine_points
from psmat.twin import ImuSource, SerialTwin
from psmat.twin.field import cell_force_n
from psmat.twin.seated import (DRIFT_SD_DEG, DRIFT_TAU_S, EULER_LSB_DEG, GRID_HZ, HAT_SHARE, ImuDevice, PostureState,
                               SeatedDay, SeatedSession, draw_seated_subject, hat_offset_cm, imu_identity, imu_packets,
                               imu_readings, posture_trajectory, protocol_phases, seat_scene, seat_targets,
                               seated_session)
from hang_guard import HANG_GUARD_S

G = 9.80665
PITCH = 2.0


def _day(**kw) -> SeatedDay:
    """A session sitting unturned with the tuberosities 4 cm behind the mat's centre, sensors mounted true."""
    base = dict(seat_origin_cm=(15.0, 11.0), seat_rotation_deg=0.0, top_sensor_cm=0.0, mount_deg=np.zeros((5, 3)),
                room_heading_deg=90.0, forward_scale=1.0, back_scale=1.0, pelvis_offset_deg=0.0,
                lateral_bias_deg=0.0, slump_deg=0.0)
    base.update(kw)
    return SeatedDay(**base)


def _still(subject):
    """The subject without slow sway or breathing: the posture is the protocol's lean alone."""
    return dataclasses.replace(subject, sway_deg=0.0, lateral_sway_deg=0.0, breath_deg=0.0)


def _state(n: int = 1, **kw) -> PostureState:
    f = {k: np.zeros(n) for k in PostureState.FIELDS}
    f.update({k: np.full(n, float(v)) for k, v in kw.items()})
    return PostureState(**f)


@pytest.fixture(scope="module")
def subject():
    return _still(draw_seated_subject(np.random.default_rng(11), sex="F"))


def _session(subject, day=None, seed=0):
    day = day or _day()
    return SeatedSession.build(subject, day, posture_trajectory(subject, day, np.random.default_rng(seed)))


# ------------------------------------------------------------------------------ the seat's force
def test_seat_force_is_the_weights_seat_share_and_the_bounce(subject):
    sess = _session(subject)
    upright, bouncing = _state(), _state(bounce=0.3)
    w = subject.weight_kg * G
    for state, expected in ((upright, w * subject.seat_share), (bouncing, 1.3 * w * subject.seat_share)):
        tg = seat_targets(subject, state, sess.layout)
        assert tg.force_n[0] == pytest.approx(expected, rel=1e-12)
    # the image's Σ p·A is that force within the quadrature (the seat lies on the mat)
    t = np.linspace(0.0, sess.duration_s, 400)
    scene = sess.pressure(t)
    assert scene.meta["force_on_mat_fraction"].min() > 0.995
    np.testing.assert_allclose(cell_force_n(scene.pressure_psi, PITCH), scene.force_n, rtol=1e-2)
    # and the force follows the weight's share on the cushion times (1 + bounce), frame by frame
    state = sess.trajectory.at(t)
    np.testing.assert_allclose(scene.force_n, w * scene.meta["seat_share"] * (1.0 + state.bounce), rtol=1e-12)


def test_a_pelvis_tilt_turns_the_trunk_rigidly_about_the_tuberosities(subject):
    # a stiff spine turned by P at the hips: the HAT's centre rotates about the contact by P
    (w0, z0) = (a[0] for a in hat_offset_cm(subject, _state()))
    for p_deg in (-20.0, 10.0, 25.0):
        p = math.radians(p_deg)
        w, z = (a[0] for a in hat_offset_cm(subject, _state(pelvis_deg=p_deg)))
        assert w == pytest.approx(w0 * math.cos(p) + z0 * math.sin(p), abs=1e-9)
        assert z == pytest.approx(-w0 * math.sin(p) + z0 * math.cos(p), abs=1e-9)


def test_seat_and_floor_take_the_trunks_moment(subject):
    # leaning forward by Δd: the cushion's moment grows by β·0.678·W·Δd (its force times its CoP, from
    # the rendered field) and the floor's force at the knees takes the rest
    sess = _session(subject)
    w = subject.weight_kg * G
    knee = subject.thigh_length_cm * math.cos(math.radians(subject.thigh_splay_deg))
    states = [_state(), _state(pelvis_deg=8.0, lumbar_deg=4.0, thoracic_deg=3.0)]
    moment, floor = [], []
    for st in states:
        tg = seat_targets(subject, st, sess.layout)
        sc = seat_scene("lean", sess.layout, np.zeros(1), tg.force_n, tg.cop_seat_cm, tg.contact_cm,
                        subject.thigh_share, (16, 16), PITCH, 5, 0.02, {})
        assert sc.meta["n_clipped"] == 0
        cop_w = sess.layout.to_seat(sc.cop_true_cm)[0, 1]  # the field's CoP back in the seat frame
        moment.append(tg.force_n[0] * cop_w)
        floor.append(w - tg.force_n[0])
        dd = tg.hat_forward_cm[0]
    assert dd > 3.0
    beta = subject.moment_share
    assert moment[1] - moment[0] == pytest.approx(beta * HAT_SHARE * w * dd, rel=1e-9)
    assert (floor[1] - floor[0]) * knee == pytest.approx((1.0 - beta) * HAT_SHARE * w * dd, rel=1e-9)


def test_leaning_far_forward_the_knees_take_what_the_cushion_cannot(subject):
    # beyond the thighs' reach (80 % of the cushion's load) the whole moment still balances, the
    # knees on the floor (x_knee forward of the tuberosities) taking the rest
    sess = _session(subject)
    w = subject.weight_kg * G
    knee = subject.thigh_length_cm * math.cos(math.radians(subject.thigh_splay_deg))
    up = seat_targets(subject, _state(), sess.layout)
    far = seat_targets(subject, _state(pelvis_deg=35.0, lumbar_deg=15.0, thoracic_deg=15.0), sess.layout)
    sc = seat_scene("far", sess.layout, np.zeros(1), far.force_n, far.cop_seat_cm, far.contact_cm,
                    subject.thigh_share, (16, 16), PITCH, 5, 0.02, {})
    assert sc.meta["n_clipped"] == 0
    assert sc.meta["rows"][0, 1] == pytest.approx(0.8, abs=0.02)
    dd = far.hat_forward_cm[0]
    moment = lambda f, cop_w: f * cop_w + (w - f) * knee  # noqa: E731 - cushion plus floor about the tuberosities
    cop_far = sess.layout.to_seat(sc.cop_true_cm)[0, 1]
    cop_up = up.cop_seat_cm[0, 1]
    assert moment(far.force_n[0], cop_far) - moment(up.force_n[0], cop_up) == pytest.approx(HAT_SHARE * w * dd,
                                                                                             rel=1e-6)
    assert far.force_n[0] < up.force_n[0]


# ------------------------------------------------------------------------------ leaning
def test_leaning_forward_loads_the_thighs_and_back_the_sacrum(subject):
    sess = _session(subject)
    ph = {p.name: p for p in sess.trajectory.phases}
    mid = {n: 0.5 * (ph[n].start_s + ph[n].end_s) for n in ("straight", "forward", "back")}
    scene = sess.pressure(np.array([mid["straight"], mid["forward"], mid["back"]]))
    rows = scene.meta["rows"]  # ischial, thigh, sacral shares
    cop_y = scene.cop_true_cm[:, 1]
    # forward: the CoP moves towards the thighs (+y, the seat unturned) and the thighs' share rises
    assert cop_y[1] > cop_y[0] + 2.0
    assert rows[1, 1] > rows[0, 1] + 0.15
    assert rows[1, 2] == 0.0
    # the thighs' area (in front of the tuberosities by 6 cm and more) carries more of the image
    front = np.s_[:, 9:, :]
    share_front = scene.pressure_psi[front].sum(axis=(1, 2)) / scene.pressure_psi.sum(axis=(1, 2))
    assert share_front[1] > share_front[0] + 0.1
    # back: the sacral lobe (on the midline, behind the tuberosities) takes load, the CoP moves back
    assert rows[0, 2] < 0.02 and rows[2, 2] > 0.05
    assert cop_y[2] < cop_y[0] - 1.0
    sacrum = scene.meta["group_lobes"][6].cop_cm
    i, p = int(round(sacrum[1] / PITCH)), int(round(sacrum[0] / PITCH))
    assert scene.pressure_psi[2, i, p] > 2.0 * scene.pressure_psi[0, i, p]


def test_the_same_lean_differs_between_people_and_stays_within_one():
    # the posture-to-pressure and posture-to-angle maps are each subject's own (thesis §4.4)
    a, b = (_still(draw_seated_subject(np.random.default_rng(s))) for s in (1, 2))
    sa, sb = _session(a), _session(b)
    for sess in (sa, sb):
        assert 150.0 < sess.duration_s < 200.0
    fa, fb = (s.pressure(np.array([1.0])).pressure_psi[0] for s in (sa, sb))
    assert np.abs(fa - fb).sum() > 0.1 * fa.sum()  # same place on the cushion, another body
    pa, pb = (s.true_angles(np.array([1.0]))[0, :, 2] for s in (sa, sb))
    assert np.abs(pa - pb).max() > 2.0
    # within a session the straight posture comes back: settle vs straight phase angles agree
    for sess in (sa, sb):
        ph = {p.name: p for p in sess.trajectory.phases}
        t = np.array([1.0, 0.5 * (ph["straight"].start_s + ph["straight"].end_s)])
        ang = sess.true_angles(t)[:, :, 2]
        np.testing.assert_allclose(ang[0], ang[1], atol=1e-9)


# ------------------------------------------------------------------------------ the IMUs and eq. 4.4
def test_a_straight_back_gives_equal_pitches_up_to_the_mountings(subject):
    mount = np.column_stack([np.zeros(5), np.zeros(5), [1.5, -2.0, 0.5, 3.0, -1.0]])
    flat = dataclasses.replace(subject, upright_pitch_deg=(7.0,) * 5)
    sess = _session(flat, _day(mount_deg=mount))
    pitch = sess.true_angles(np.array([1.0, 2.0]))[:, :, 2]  # settling: straight, no sway
    np.testing.assert_allclose(pitch - mount[:, 2], 7.0, atol=1e-9)
    pts = spine_points(np.radians(pitch - mount[:, 2]))
    np.testing.assert_allclose(pts[0], [[0, 0], [90, 0], [180, 0], [270, 0], [360, 0]], atol=1e-9)


def test_a_uniform_bend_puts_the_sensors_where_eq_4_4_does(subject):
    # a back of constant curvature: pitch θ(v) = −20° + 45°·v along it (v = share of S3..C7)
    knots = (0.0, 0.2, 0.45, 0.7, 1.0)
    bent = dataclasses.replace(subject, upright_pitch_deg=tuple(-20.0 + 45.0 * v for v in knots))
    day = _day(top_sensor_cm=1.0)
    sess = _session(bent, day)
    pitch = sess.true_angles(np.array([1.0]))[0, :, 2]
    # by hand (docs/spec.md §8): the top sensor 1 cm below C7, the others every 9 cm down the back
    length = bent.back_length_cm
    v = 1.0 - (1.0 + 9.0 * np.arange(5)) / length
    assert v[-1] > 0.0
    np.testing.assert_allclose(pitch, -20.0 + 45.0 * v, atol=1e-9)
    # the back's own curve (integrated along it, vertical up, forward +x) at those sites ...
    vv = np.linspace(0.0, 1.0, 200001)
    th = np.radians(-20.0 + 45.0 * vv)
    dv = vv[1] - vv[0]
    xz = np.vstack([[0.0, 0.0], np.cumsum(0.5 * dv * length * 10.0 * np.column_stack(
        [np.sin(th[1:]) + np.sin(th[:-1]), np.cos(th[1:]) + np.cos(th[:-1])]), axis=0)])  # mm
    sites = np.array([np.interp(v, vv, xz[:, 0]), np.interp(v, vv, xz[:, 1])]).T
    # ... are where eq. 4.4 puts the sensors from their five pitches (exact for a constant curvature)
    pts = spine_points(np.radians(pitch))
    d_curve = np.linalg.norm(sites[:, None] - sites[None], axis=-1)
    d_eq44 = np.linalg.norm(pts[:, None] - pts[None], axis=-1)
    np.testing.assert_allclose(d_eq44, d_curve, atol=1e-3)


def test_drift_is_an_ou_process_bounded_as_stated():
    rate, n, sessions = 10.0, 1800, 400
    true = np.zeros((n, 5, 3))
    dev = ImuDevice("T", (0.2,) * 5, 0.0)
    rng = np.random.default_rng(5)
    ends, peaks = [], []
    for _ in range(sessions):
        out, drift = imu_readings(true, rate, dev, rng)
        ends.append(drift[-1])
        peaks.append(np.abs(drift).max(axis=(0, 1)))
        # what is sent: the true angles plus drift and noise, in 1/16 degree steps
        assert np.all(np.abs(out[:, :, 1:] / EULER_LSB_DEG - np.round(out[:, :, 1:] / EULER_LSB_DEG)) == 0)
        assert np.std(out[:, :, 2] - drift[:, :, 2]) == pytest.approx(np.hypot(0.2, EULER_LSB_DEG / math.sqrt(12)),
                                                                      rel=0.05)
    ends = np.array(ends)  # (sessions, 5, 3)
    t_end = (n - 1) / rate
    for c in range(3):
        expected = DRIFT_SD_DEG[c] * math.sqrt(1.0 - math.exp(-2.0 * (t_end + 1 / rate) / DRIFT_TAU_S[c]))
        assert ends[:, :, c].std() == pytest.approx(expected, rel=0.08)
        assert np.max(np.array(peaks)[:, c]) < 5.0 * DRIFT_SD_DEG[c]
    # the drift starts from zero at power-on: one step of the process, SD σ·sqrt(1 − a²), a = exp(−Δt/τ)
    first = np.array([imu_readings(true[:2], rate, dev, rng)[1][0] for _ in range(400)])  # (400, 5, 3)
    for c in range(3):
        a = math.exp(-1.0 / (rate * DRIFT_TAU_S[c]))
        assert first[:, :, c].std() == pytest.approx(DRIFT_SD_DEG[c] * math.sqrt(1.0 - a * a), rel=0.08)


# ------------------------------------------------------------------------------ the protocol
def test_the_protocol_phases_are_the_thesis_plan(subject):
    for seed in range(20):
        phases = protocol_phases(subject, np.random.default_rng(seed))
        names = [p.name for p in phases]
        assert names == ["settle", "bounce", "straight", "to_forward", "forward", "to_back", "back", "to_straight",
                         "bounce", "rocking", "bounce", "rocking", "settle"]
        starts = np.array([p.start_s for p in phases])
        ends = np.array([p.end_s for p in phases])
        assert starts[0] == 0.0 and np.all(starts[1:] == ends[:-1])
        length = dict(zip(names, ends - starts))
        for held in ("straight", "forward", "back"):  # thesis §4.3: 30 s each
            d = [p.end_s - p.start_s for p in phases if p.name == held][0]
            assert 28.0 <= d <= 32.0
        assert 2.0 <= length["to_forward"] <= 3.0
        for p in phases:
            if p.name == "bounce":
                assert 3 <= p.cycles <= 5
            if p.name == "rocking":
                assert 3 <= p.cycles <= 4
                assert p.end_s - p.start_s == pytest.approx(p.cycles * subject.rock_period_s, rel=0.11)
        assert 150.0 <= ends[-1] <= 200.0  # about 175 s: ~1740 windows of 50 at 10 Hz (thesis §4.3)


def test_the_lean_follows_the_phases(subject):
    traj = posture_trajectory(subject, _day(), np.random.default_rng(3))
    st = traj.state
    for p in traj.phases:
        m = (traj.t_s >= p.start_s) & (traj.t_s < p.end_s)
        lean, bounce = st.lean[m], st.bounce[m]
        if p.name in ("settle", "straight", "bounce"):
            assert np.all(lean == 0.0)
        if p.name == "forward":
            assert np.all(lean == 1.0)
        if p.name == "back":
            assert np.all(lean == -1.0)
        if p.name == "rocking":  # through the three postures: forward, straight, back
            assert lean.max() > 0.99 and lean.min() < -0.99
            assert np.count_nonzero(np.diff(np.sign(lean[np.abs(lean) > 1e-6])) > 0) == p.cycles - 1
        if p.name == "bounce":
            # whole bounces at the subject's amplitude: zero mean, peaks at ±amplitude, `cycles` of them
            assert abs(bounce.mean()) < 0.02 * subject.bounce
            assert bounce.max() == pytest.approx(subject.bounce, rel=1e-3)
            peaks = np.count_nonzero((bounce[1:-1] > bounce[:-2]) & (bounce[1:-1] >= bounce[2:]) & (bounce[1:-1] > 0))
            assert peaks == p.cycles
        else:
            assert np.all(bounce == 0.0)
    # forward: the top of the back turns by the subject's forward lean; back: the trunk reclines
    fw = traj.at(np.array([0.5 * (traj.phases[4].start_s + traj.phases[4].end_s)]))
    assert fw.pelvis_deg[0] + fw.lumbar_deg[0] + fw.thoracic_deg[0] == pytest.approx(subject.forward_deg, rel=1e-9)
    bk = traj.at(np.array([0.5 * (traj.phases[6].start_s + traj.phases[6].end_s)]))
    assert bk.pelvis_deg[0] + bk.lumbar_deg[0] + bk.thoracic_deg[0] == pytest.approx(-subject.back_deg, rel=1e-9)
    assert traj.t_s[1] - traj.t_s[0] == pytest.approx(1.0 / GRID_HZ)


def test_a_short_session_is_the_plan_scaled():
    s = seated_session(4, duration_s=20.0)
    full = seated_session(4)
    assert s.duration_s == pytest.approx(20.0, rel=1e-12)
    assert [p.name for p in s.trajectory.phases] == [p.name for p in full.trajectory.phases]
    assert [p.cycles for p in s.trajectory.phases] == [p.cycles for p in full.trajectory.phases]
    k = 20.0 / full.duration_s
    np.testing.assert_allclose([p.end_s for p in s.trajectory.phases], [k * p.end_s for p in full.trajectory.phases],
                               rtol=1e-12)


# ------------------------------------------------------------------------------ the volunteers
def test_volunteers_are_those_of_table_4_2():
    rng = np.random.default_rng(0)
    people = [draw_seated_subject(rng, sex="M" if i % 12 < 5 else "F") for i in range(2400)]  # 5 men : 7 women
    w = np.array([p.weight_kg for p in people])
    h = np.array([p.height_cm for p in people]) / 100.0
    assert w.mean() == pytest.approx(62.0, abs=1.0) and w.std() == pytest.approx(9.0, abs=1.0)
    assert h.mean() == pytest.approx(1.68, abs=0.005) and h.std() == pytest.approx(0.07, abs=0.01)
    assert all(18 <= p.age <= 70 for p in people)
    it = {s: np.mean([p.tuberosity_distance_cm for p in people if p.sex == s]) for s in "MF"}
    assert it["F"] > it["M"]  # the wider female pelvis
    with pytest.raises(ValueError, match="sex"):
        draw_seated_subject(rng, sex="X")


def test_same_seed_same_session_and_different_seed_different():
    a, b, c = seated_session(7, duration_s=30.0), seated_session(7, duration_s=30.0), seated_session(8, duration_s=30.0)
    t = np.linspace(0.0, 30.0, 61)
    np.testing.assert_array_equal(a.pressure(t).pressure_psi, b.pressure(t).pressure_psi)
    np.testing.assert_array_equal(a.true_angles(t), b.true_angles(t))
    assert not np.array_equal(a.true_angles(t), c.true_angles(t))


# ------------------------------------------------------------------------------ the IMU twin
def _read(port: serial.Serial, n_bytes: int) -> bytes:
    data, deadline = b"", time.monotonic() + HANG_GUARD_S
    while len(data) < n_bytes:
        if time.monotonic() > deadline:
            pytest.fail(f"the IMU twin sent {len(data)} of {n_bytes} bytes within the hang guard")
        data += port.read(4096)
    return data


@pytest.mark.parametrize("proto", ["v1", "v2"])
def test_the_imu_twin_sends_psmat_protocol_bytes_of_the_seated_angles(proto):
    rate, seed, n = 50, 3, 30
    served = ImuSource(float(rate), seed).angles_deg  # an independent copy of what the twin serves
    # the seated twin's angles, float32 as on the wire: a posture protocol, not a fixed pattern
    sess = seated_session(seed)
    np.testing.assert_allclose(served[:, :, 2], sess.true_angles(np.arange(len(served)) / rate)[:, :, 2], atol=1.5)
    size = protocol.v1_frame_size(protocol.IMU_SHAPE) if proto == "v1" else protocol.v2_frame_size((5, 3), "imu")
    with SerialTwin("imu", rate, proto, seed=seed) as twin, serial.serial_for_url(twin.port, timeout=0.05) as port:
        data = _read(port, (n + 1) * size)
    if proto == "v1":
        expected = b"".join(protocol.encode_imu_v1(a) for a in served[: n + 40])
        # the host may have joined mid-frame: from the first whole frame on, the bytes are the encoder's
        found = [expected.find(data[j:j + n * size]) for j in range(size)]
        assert len([pos for pos in found if pos >= 0 and pos % size == 0]) == 1
    else:
        dec = protocol.decode_v2(data, kind="imu")
        ok = dec["valid"]
        seq, t_us = dec["seq"][ok], dec["t_us"][ok]
        assert seq.size >= n and np.all(np.diff(seq) == 1)
        expected = b"".join(protocol.encode_v2(served[s], int(s), int(t), kind="imu") for s, t in zip(seq, t_us))
        first = data.find(expected[:size])
        assert first >= 0 and data[first:first + len(expected)] == expected
        # stamped on the firmware timer's grid at the rate
        k = t_us * rate / 1e6
        np.testing.assert_allclose(k, np.round(k), atol=rate * 1e-6)


@pytest.mark.parametrize("proto", ["v1", "v2"])
def test_imu_packets_are_the_firmware_cores_bytes_for_given_readings_and_stamps(proto):
    # what a simulated study records goes through the same firmware core as the serial twin: its
    # bytes equal the Python encoders' (written apart from the C core), one packet per reading, the
    # sequence numbers from 0 and the stamps wrapped to the MCU's 32-bit µs counter
    rng = np.random.default_rng(5)
    angles = rng.uniform(-90.0, 360.0, (7, 5, 3)).astype(np.float32)
    stamps = (2**32 - 250_000) + np.arange(7, dtype=np.int64) * 100_000  # the counter wraps after the third
    data = imu_packets(angles, stamps, "SIMIMU", proto)
    if proto == "v1":
        assert data == b"".join(protocol.encode_imu_v1(a) for a in angles)
    else:
        assert data == b"".join(protocol.encode_v2(a, k, int(t) % 2**32, kind="imu")
                                for k, (a, t) in enumerate(zip(angles, stamps)))
    assert imu_identity("SIMIMU")["serial"] == "SIMIMU" and imu_identity("SIMIMU")["device"] == "imu"
    with pytest.raises(ValueError, match=r"^angles_deg must be \(T, 5, 3\) degrees and t_us \(T,\) µs, got"):
        imu_packets(angles[:, :4], stamps, "SIMIMU")
    with pytest.raises(ValueError, match="protocol must be 'v1' or 'v2'"):
        imu_packets(angles, stamps, "SIMIMU", "v3")

"""The honest simulation of a posture study (docs/spec.md §8 "Data", §6 study layout; thesis §4.3).

:func:`simulate_posture_study` writes a study folder that the posture pipeline
(:func:`psmat.posture.data.load_posture_study`) reads without knowing the truth: each subject
of the seated twin (:mod:`psmat.twin.seated`; who they are, how they sit and lean: every choice
is stated in :mod:`psmat.twin.seated._subject`) follows the thesis' protocol once per day
(:func:`psmat.twin.seated.posture_trajectory`), and one posture trajectory per session drives both the
cushion's mat and the five spine IMUs. What the simulator knows and a lab does not goes to
``DIR/truth/``, which nothing but the evaluation of the simulation reads.

Choices, with their sources
---------------------------
Subjects
    ``P01``, ``P02``, …; thesis Table 4.2 (5 men and 7 women: a study of n subjects has
    round(5n/12) men, which ones drawn from the seed), 3 days each by default (thesis §4.3:
    "3 times on different days"), three days apart, twenty minutes between subjects.
Each subject's mat and box (as the balance study's: :func:`psmat.synth._lab.equip`)
    The thesis used one mat; we give each subject their own, unknown to the processing as in the
    balance study: the pneumatic fit made 1/f times more conductive, f ∈ [0.25, 0.75], with a
    spread on every parameter; cell-to-cell gains log-normal with SD 0.15–0.33; R_mux and
    R_adc of the box found by the real estimator on simulated calibration recordings
    (``DIR/calibration/<serial>.json``, stored in each session too); the box's clock off by
    2 ppm–1e-3 and its µs counter restarting 20 s–15 min before each session; frames lost on the
    wire with probability 0–2e-4; noise 1 mV on the ADC node, 12 bits (thesis Table 2.4). The
    sensor is at rest at the start of each day (days apart: its creep has relaxed, eq. 2.23).
    Counts through :class:`psmat.twin.MatPhysics` at ``rate_hz`` (100 Hz).
The spine IMUs (one back device for the whole study, as the thesis' single prototype)
    Five BNO055 read at 10 Hz (thesis §4.2): each sample's true angles
    (:meth:`psmat.twin.SeatedSession.true_angles`) plus the device's drift, noise and 1/16°
    steps (:func:`psmat.twin.seated.imu_readings`), through the twin's IMU firmware core
    (:func:`psmat.twin.seated.imu_packets`, protocol v2: float32 on the wire, its sequence
    number and µs stamp) and decoded by :func:`psmat.protocol.decode_v2`; its clock off by
    2 ppm–1e-3, its counter restarting 5–60 s before each session (the strip is powered and
    calibrated on a table first, thesis §4.3). The device description is its IDENTIFY reply.
One session (``DIR/sessions/<subject>_d<day>.h5``)
    The mat at the root, the IMUs as stream ``imu`` (:meth:`psmat.io.SessionWriter.add_stream`),
    both on the one host clock: a sample's host time is its instant plus a USB latency (1 ms +
    exponential 1 ms, never backwards). Each device starts 0–0.5 s after the protocol's start
    and stops 0–0.5 s before its end, at its own rate. Metadata ``subject``, ``trial`` =
    "posture", ``day``, ``simulated``, ``study`` = "posture". Written in chunks of 1000 mat
    frames. ``duration_s`` shortens a session by scaling the protocol in time (tests; the thesis'
    timing is ``duration_s=None``).
Determinism
    Every draw comes from ``numpy.random.SeedSequence(seed)`` spawned per subject and per day,
    so a subject is the same whatever the number of subjects (except which are men); the same
    seed gives the same files except the HDF5 sessions' creation time.

``DIR/truth/`` is described by its README.txt (:data:`TRUTH_README`).
"""

from __future__ import annotations

import datetime as _dt
import math
import os
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .. import _checks, protocol
from ..io import SessionWriter
from ..twin import MatPhysics
from ..twin.field import mat_centre_cm
from ..twin.seated import (TABLE_4_2, ImuDevice, SeatedSession, SeatedSubject, back_pitch_deg, draw_imu_device,
                           draw_seated_day, draw_seated_subject, imu_identity, imu_packets, imu_readings,
                           posture_trajectory, sensor_sites)
from ._draws import Box
from ._lab import NOISE_V, PITCH_CM, MatTally, equip, host_times, new_root, write_mat_chunk, write_subjects
from ._truth import save_npz_stable, truth_json

__all__ = ["simulate_posture_study", "IMU_RATE_HZ", "TRUTH_README"]

#: The spine IMUs' rate (thesis §4.2: "read sequentially at a frequency of 10 Hz").
IMU_RATE_HZ = 10.0
#: Host clock of the first subject's first day; days three days apart, subjects 20 min apart.
HOST_EPOCH = _dt.datetime(2024, 6, 3, 9, 0, tzinfo=_dt.timezone.utc)
#: Mat frames simulated and written at a time.
CHUNK = 1000
#: Shortest session (s): the protocol's thirteen phases need room.
MIN_SECONDS = 5.0
TRUTH_README = """\
This folder holds what the simulator knows and a lab does not. Nothing but the evaluation of the
simulation itself may read it: a processing that reads it is no longer measuring anything.

study.json               the simulation's arguments, the IMU device (noise, drift, clock) and the choices
subjects/Pnn.json        person and anatomy (psmat.twin.SeatedSubject: pelvis, thighs, back length, upright
                         curvature, how they lean), mat (sensor model, 1/f, cell spread), box (R_mux,
                         R_adc, clock, loss rate) and the calibration a lab found
subjects/Pnn.npz         gain (R, C) cell gains; r_mux_ohm (R, C) true R_mux per row-column pair
sessions/<stem>.json     the day (seat position and turn on the cushion, IMU strip placement and mounting
                         offsets, the day's lean), sensor sites (share of S3..C7 and cm below C7), the
                         protocol's phases (name, start_s, end_s, cycles; protocol clock, host_start_s is
                         its 0 on the host clock), both devices' timing, lost mat frames, clipping
sessions/<stem>.npz      imu_t_s (N,) protocol clock and imu_t_host_s; angles_true_deg (N, 5, 3) heading,
                         roll, pitch without noise or drift (mounting offsets included: what a perfect
                         sensor reads); back_pitch_deg (N, 5) the back's own pitch at the sensors (no
                         offsets); drift_deg (N, 5, 3); the posture at the IMU samples: lean, pelvis_deg,
                         lumbar_deg, thoracic_deg, lateral_deg, bounce (N,); mat_t_s, mat_t_host_s,
                         mat_valid (M,), cop_cm (M, 2) the seat field's CoP in mat coordinates (cell (i, p)
                         at (2p, 2i) cm), force_n (M,), seat_share (M,), rows (M, 3) the ischial, thigh and
                         sacral shares; pressure_mean_psi (R, C)
"""


def _check(subjects: Any, days: Any, seed: Any, rate_hz: Any, duration_s: Any, shape: Any
           ) -> tuple[int, int, int, float, float | None, tuple[int, int]]:
    """The checked arguments of :func:`simulate_posture_study` (one-line ValueErrors)."""
    n = _checks.positive_int("subjects", subjects)
    d = _checks.positive_int("days", days)
    k = _checks.nonneg_int("seed", seed)
    rate = _checks.rate_hz("rate_hz", rate_hz)
    secs = None if duration_s is None else _checks.duration_s("duration_s", duration_s)
    if secs is not None and secs < MIN_SECONDS:
        raise ValueError(f"duration_s must be at least {MIN_SECONDS:g} s (the protocol's phases need room), got {secs:g}")
    R, C = _checks.shape2(shape)
    if R < 16 or C < 16:
        raise ValueError(f"shape must be at least (16, 16) cells of {PITCH_CM:g} cm so that the seat fits, got {(R, C)}")
    if rate * (secs or MIN_SECONDS) < 8:
        raise ValueError(f"rate_hz={rate:g} gives fewer than 8 mat frames per session")
    return n, d, k, rate, secs, (R, C)


def _sexes(n: int, seed: int) -> list[str]:
    """Table 4.2's 5:7 men to women: round(5n/12) men, which subjects drawn from the seed."""
    men = int(round(TABLE_4_2["men"] * n))
    order = np.random.default_rng([seed, 4, 2]).permutation(n)
    return ["M" if r < men else "F" for r in np.argsort(order)]


def simulate_posture_study(root: str | os.PathLike[str], *, subjects: int = 12, days: int = 3, seed: int = 0,
                           rate_hz: float = 100.0, duration_s: float | None = None, shape: tuple[int, int] = (16, 16),
                           progress: bool = False) -> Path:
    """Write a simulated posture study to ``root`` (see the module docstring for every choice).

    Parameters
    ----------
    root : path
        A new (or empty) folder.
    subjects : int
        Number of subjects (thesis: 12).
    days : int
        Sessions per subject, one a day (thesis: 3).
    seed : int
        Seeds every draw; the same seed gives the same study.
    rate_hz : float
        The mat's nominal frame rate (Hz); the IMUs run at 10 Hz.
    duration_s : float, optional
        Length of each session (s): the protocol scaled in time (at least 5 s); default the
        protocol's own, about 175 s.
    shape : (R, C)
        Cells of the mat (2 cm pitch), at least (16, 16).
    progress : bool
        A progress bar over sessions.

    Returns
    -------
    pathlib.Path
        ``root``.

    Raises
    ------
    ValueError
        A bad argument (one line).
    FileExistsError
        ``root`` exists and is not an empty folder.
    """
    from psmat._progress import tqdm

    n, n_days, seed_, rate, secs, shape_ = _check(subjects, days, seed, rate_hz, duration_s, shape)
    out = new_root(root, "a simulated posture study")
    ids = [f"P{i + 1:0{max(2, len(str(n)))}d}" for i in range(n)]
    streams = [child.spawn(4) for child in np.random.SeedSequence(seed_).spawn(n)]  # person, mat, box, days
    people = [draw_seated_subject(np.random.default_rng(s[0]), sex) for s, sex in zip(streams, _sexes(n, seed_))]
    imu_device = draw_imu_device(np.random.default_rng([seed_, 1, 0]), f"SIM{seed_}-IMU")
    for sub in ("sessions", "calibration", "truth/subjects", "truth/sessions"):
        (out / sub).mkdir(parents=True, exist_ok=True)
    write_subjects(out, ids, people)
    with tqdm(total=n * n_days, unit="session", desc="simulating", disable=not progress) as bar:
        for i, (pid, person, s) in enumerate(zip(ids, people, streams)):
            _subject(out, i, pid, person, s, n_days, rate, secs, shape_, seed_, imu_device, bar)
    study = {"seed": seed_, "subjects": n, "days": n_days, "seconds": secs, "rate_hz": rate,
             "imu_rate_hz": IMU_RATE_HZ, "shape": list(shape_), "pitch_cm": PITCH_CM, "noise_v": NOISE_V,
             "subject_ids": ids, "imu_device": imu_device.as_dict(), "boxes": "one mat and box per subject",
             "simulator": "psmat.synth.simulate_posture_study", "twin": "psmat.twin.seated"}
    (out / "truth" / "study.json").write_text(truth_json(study), encoding="utf-8")
    (out / "truth" / "README.txt").write_text(TRUTH_README, encoding="utf-8")
    return out


def _subject(out: Path, index: int, pid: str, person: SeatedSubject, streams: list[np.random.SeedSequence],
             n_days: int, rate: float, duration_s: float | None, shape: tuple[int, int], seed: int,
             imu_device: ImuDevice, bar: Any) -> None:
    """Draw the subject's mat and box, calibrate the box, record one session a day."""
    first = HOST_EPOCH + _dt.timedelta(minutes=20 * index)
    kit = equip(out, f"SIM{seed}-{pid}", np.random.default_rng(streams[1]), np.random.default_rng(streams[2]), shape,
                rate, first.date().isoformat())
    kit.save_truth(out / "truth" / "subjects", pid, kit.truth(pid, person.as_dict()))
    mat = kit.mat
    centre = mat_centre_cm(shape, PITCH_CM)
    for d, day_seq in enumerate(streams[3].spawn(n_days), start=1):
        rng = np.random.default_rng(day_seq)
        day = draw_seated_day(rng, centre)
        session = SeatedSession.build(person, day, posture_trajectory(person, day, rng, duration_s))
        mat.reset()  # a day later: the sensor has relaxed
        stem = f"{pid}_d{d}"
        host0 = (first + _dt.timedelta(days=3 * (d - 1))).timestamp()
        meta = {"subject": pid, "trial": "posture", "day": d, "simulated": True, "study": "posture",
                "operator": "psmat.synth.simulate_posture_study"}
        _session(out, stem, session, mat, kit.box, imu_device, rng, rate, host0, kit.device, kit.calibration.to_dict(),
                 meta, profile=kit.profile)
        bar.update(1)


def _imu_stream(session: SeatedSession, device: ImuDevice, rng: np.random.Generator, host0: float
                ) -> tuple[dict[str, Any], dict[str, NDArray[Any]], dict[str, Any]]:
    """The IMU samples through the firmware core and the decoder: (what is appended, truth arrays, timing)."""
    start = float(rng.uniform(0.0, 0.5))
    end = session.duration_s - float(rng.uniform(0.0, 0.5))
    period = (1.0 / IMU_RATE_HZ) * (1.0 + device.clock_error)
    k = np.arange(int(math.floor((end - start) / period)) + 1)
    t = start + k * period
    true = session.true_angles(t)
    sent, drift = imu_readings(true, IMU_RATE_HZ, device, rng)
    counter = int(rng.integers(5_000_000, 60_000_000))  # powered 5-60 s before (calibrated on a table)
    stamps = counter + np.round(k * 1e6 / IMU_RATE_HZ).astype(np.int64)
    dec = protocol.decode_v2(imu_packets(sent, stamps, device.serial), kind="imu")
    state = session.trajectory.at(t)
    truth = {"imu_t_s": t, "imu_t_host_s": host_times(t, host0, rng), "angles_true_deg": true,
             "back_pitch_deg": back_pitch_deg(session.subject, state, sensor_sites(session.subject, session.day)),
             "drift_deg": drift, **state.as_arrays()}
    frames = {"angles": dec["frames"], "host": truth["imu_t_host_s"], "valid": dec["valid"], "seq": dec["seq"],
              "t_us": dec["t_us"]}
    timing = {"rate_hz": IMU_RATE_HZ, "clock_error": device.clock_error, "sample_period_true_s": period,
              "first_sample_s": start, "samples": int(k.size), "first_sample_device_us": counter}
    return frames, truth, timing


def _session(out: Path, stem: str, session: SeatedSession, mat: MatPhysics, box: Box, imu_device: ImuDevice,
             rng: np.random.Generator, rate: float, host0: float, device: dict[str, Any], calibration: dict[str, Any],
             metadata: dict[str, Any], profile: dict[str, Any] | None = None) -> None:
    """Simulate and write one session (mat at the root, IMUs as stream ``imu``) and its truth."""
    imu, imu_truth, imu_timing = _imu_stream(session, imu_device, rng, host0)
    start = float(rng.uniform(0.0, 0.5))
    end = session.duration_s - float(rng.uniform(0.0, 0.5))
    period, period_true = 1.0 / rate, mat.dt
    k = np.arange(int(math.floor((end - start) / period_true)) + 1)
    t = start + k * period_true
    frames = k.size
    d0 = int(rng.integers(20_000_000, 900_000_000))  # the box is powered 20 s - 15 min before each session
    device_us = (d0 + np.round(k * period * 1e6).astype(np.int64)) % (1 << 32)
    host = host_times(t, host0, rng)
    lost = rng.random(frames) < box.loss_rate
    lost[[0, -1]] = False
    R, C = mat.shape
    cop, force, share = np.empty((frames, 2)), np.empty(frames), np.empty(frames)
    rows = np.empty((frames, 3))
    tally = MatTally.empty((R, C))
    imu_dev = imu_identity(imu_device.serial)
    with SessionWriter(out / "sessions" / f"{stem}.h5", (R, C), device, calibration=calibration,
                       metadata=metadata, profile=profile) as w:
        stream = w.add_stream("imu", kind="imu", shape=(5, 3), device=imu_dev)
        stream.append(imu["angles"], imu["host"], imu["valid"], seq=imu["seq"], device_time_us=imu["t_us"])
        for a in range(0, frames, CHUNK):
            b = min(a + CHUNK, frames)
            scene = session.pressure(t[a:b], (R, C), PITCH_CM)
            write_mat_chunk(w, mat, scene, slice(a, b), host, lost, k, device_us, tally)
            cop[a:b], force[a:b], share[a:b] = scene.cop_true_cm, scene.force_n, scene.meta["seat_share"]
            rows[a:b] = scene.meta["rows"]
        w.set_counters(bad_frames=int(lost.sum()))
    v = sensor_sites(session.subject, session.day)
    info = {"stem": stem, "subject": metadata["subject"], "day": metadata["day"], "seated_day": session.day.as_dict(),
            "sensor_sites_v": v, "sensor_cm_below_c7": (1.0 - v) * session.subject.back_length_cm,
            "phases": [p.as_dict() for p in session.trajectory.phases], "protocol_s": session.duration_s,
            "host_start_s": host0,
            "mat": {"rate_hz": rate, "frame_period_true_s": period_true, "first_frame_s": start, "frames": frames,
                    "first_frame_device_us": d0, "frames_lost": np.flatnonzero(lost).tolist()},
            "imu": imu_timing, "clipped_frames": tally.clipped_frames,
            "saturated_fraction": tally.saturated_fraction(frames), "force_on_mat_min": tally.force_on_mat_min}
    (out / "truth" / "sessions" / f"{stem}.json").write_text(truth_json(info), encoding="utf-8")
    save_npz_stable(out / "truth" / "sessions" / f"{stem}.npz", {
        **imu_truth, "mat_t_s": t, "mat_t_host_s": host, "mat_valid": ~lost, "cop_cm": cop, "force_n": force,
        "seat_share": share, "rows": rows, "pressure_mean_psi": tally.pressure_sum_psi / frames})

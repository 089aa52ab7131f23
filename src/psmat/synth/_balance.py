"""The honest simulation of a balance study (docs/spec.md §7 "Honest simulation", §6 study layout).

:func:`simulate_study` writes a study folder that ``psmat study run`` processes without knowing
the truth: real sway (force-platform trajectories of the BDS data set) drives the digital twin
through a mat, a box and a clock the processing does not know; what the simulator knows and a
lab does not goes to ``DIR/truth/``, which nothing but the evaluation of the simulation reads.

Choices, with their sources
---------------------------
Volunteers (:mod:`psmat.synth._draws`)
    ``V01``, ``V02``, …; sex (29 of 42 men), height, weight and age from the per-sex rows of
    thesis Table 3.1 (overall 1.74 ± 0.09 m, 74.3 ± 16.3 kg, 31 ± 13 years), clipped to
    150–200 cm, 45–130 kg, 18–70 years; weight to 0.1 kg in ``subjects.csv``, and the
    trajectory's force scaled to exactly that weight. Foot length 0.152 and width 0.055 of
    the height (Winter's anthropometry after Drillis & Contini 1966).
Trials (:mod:`psmat.synth._balance_trials`)
    Thesis §3.2.1, in that order: "right-leg" and "left-leg" (flamingo stance on that foot:
    ``twin.trajectory_sway(stance="right" | "left")``) and "rotation" (two feet, trunk circles
    "about half cycle per second" — drawn 0.4–0.6 Hz, CoP semi-axes 2–4 cm, our choice as the
    thesis gives none — on top of the quiet sway, starting 1–3 s into the recording, frequency
    and amplitude wandering by 10 %). Each trial's sway is one of the source recordings (the 24
    BDS trials shipped with psmat, ``psmat.io.bds_files()``, or ``bds_paths``), three different ones per
    volunteer, cut at a random start, played back and forth when too short, mean removed. A
    single-leg trial's sway is scaled by 2 (eyes open, single-leg sway is about twice the
    double-leg one: J. Biomech. 2020, "Transition from double-leg to single-leg stance in the
    assessment of postural stability", young healthy volunteers), and any trial's by less
    when needed to keep the trajectory within 80 % of the way to the edge of the feet's reach
    (the steering's own reach, so the field's CoP is the trajectory exactly). The feet stand
    within ±1 cm of the mat centre.
Each volunteer's mat (one 16×16 mat of 2 cm cells by default)
    The pneumatic fit (thesis Table 2.11) made 1/f times more conductive, f ∈ [0.25, 0.75]
    (the large mat was 1.3–4× more conductive, thesis §3.2.2, eq. 3.3): rho, a1..a3 and w
    scaled by 1/f with a 10 % log-normal spread (a1..a3 together), tau by 10 % and the creep
    rates by 20 %; cell-to-cell gains log-normal with SD 0.15–0.33 (thesis Table 2.5: Velostat
    CV² = 0.108); leakage 1e-7 S; the noise of docs/spec.md §10 "noisy": 1 mV on the ADC node, 12 bits
    (thesis Table 2.4).
Each volunteer's box (one box per volunteer, serial ``SIM<seed>-Vnn``)
    R_mux log-uniform in 100–210 Ω around the thesis' typical 145 Ω ("estimated for each box
    independently", §2.2.1) plus a 2.5 Ω mismatch per row and per column line ("all the
    channels have the same value for practical purposes", §2.1.4); R_adc 6.9 MΩ ± 25 % (docs/spec.md
    §2). Its calibration is what ``psmat calibrate`` gives: the real estimator
    (:func:`psmat.circuit.from_recordings`) on simulated recordings through the box's true chain —
    1 s open circuit, the four corner pairs shorted, CAL_HOLD — written to
    ``DIR/calibration/<serial>.json`` and stored in each session as ``psmat record
    --calibration`` does (:func:`psmat.process.session_circuit` reads it). Its clock: the frame period
    off by a crystal-to-oscillator error of 2 ppm–1e-3 (log-uniform, either sign), the frames
    stamped by the box's µs counter (protocol v2), which starts 20 s–15 min after power-on and
    runs on through the volunteer's three trials; a frame is lost on the wire with a
    probability of 0–2e-4 (kept as the reader keeps it: counts 0, ``valid`` False, device time
    and sequence number -1). The sensor rests unloaded 30–120 s between trials (its creep
    relaxes, eq. 2.23). Host times: the arrival of each frame (1 ms + exponential 1 ms
    latency) on a host clock from 2024-05-06 09:00 UTC, eight volunteers a day.
Force platform (``DIR/forceplate/<stem>.csv``: time,x,y,Fz in s, cm, N)
    100 Hz (thesis Table 3.4, the second experiment), its clock from 0 at its own start; the
    mat's first frame 0–3 s after it (or up to 1 s, at most a tenth of the trial, before), its
    end 0–3 s after the mat's (or as much before); the mat's axes (M-L = x, A-P = y) with the
    platform's own origin (its centre, the mat laid on it within ±3 cm); Fz to 0.1 N (thesis
    §3.2.1, PS-2141). When the source is at 100 Hz (BDS) the platform's samples are the
    source's own.

Sessions, memory and determinism
    ``DIR/sessions/<subject>_<trial>.h5`` through :class:`psmat.io.SessionWriter` (metadata
    subject and trial; the device as IDENTIFY describes it), simulated and written in chunks of
    1000 frames. Every draw comes from ``numpy.random.SeedSequence(seed)`` spawned per
    volunteer, so a volunteer is the same whatever the number of volunteers; the same seed
    gives byte-identical files except the HDF5 sessions' creation time.

Romberg (``romberg=True``, ``psmat study simulate --romberg``)
    A fourth trial per volunteer, ``romberg``, after the three: two feet, eyes open then eyes
    closed, each ``duration_s`` long, in one mat session (``2·duration_s``) and one platform
    file. Its sway is an eyes-open BDS trial (``Vision`` Open, ``Surface`` Firm in the
    ``trials.tsv`` beside the files) then an eyes-closed one of the same BDS subject and surface,
    both drawn per volunteer from its own stream (so the three trials are the same with or
    without it); the feet stay where they stood, and the sway passes from one to the other over
    :data:`BLEND_S`. The session holds the markers ``eyes open`` (at its first frame) and ``eyes
    closed`` (at the switch), each at the host time its frame (the first, the first eyes-closed
    one) arrived, as an operator's clicks would be. ``truth/sessions/<stem>_romberg.json`` names both BDS trials
    and the switch (platform clock, host clock, frame index).

``DIR/truth/`` (see its README.txt): ``study.json``; per volunteer ``volunteers/Vnn.json``
(person, mat, box, calibration found) and ``Vnn.npz`` (``gain`` and ``r_mux_ohm`` per cell);
per session ``sessions/<stem>.json`` (source, timing, lags) and ``<stem>.npz``
(``t_device_s``, ``t_platform_s``, ``t_host_s``, ``cop_cm`` — the field's CoP in mat
coordinates — ``force_n``, ``valid``, ``pressure_mean_psi``). ``lag_s`` is the clocks' lag
(platform minus device clock, ``cop(t) ≈ cop_ref(t + lag_s)``, the mean over the frames the
platform saw); the mat's CoP besides lags the true one by the sensor's hysteresis (a few ms to
a few frames), which an alignment of the two CoPs includes.
"""

from __future__ import annotations

import csv
import datetime as _dt
import math
import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from .. import _checks
from ..io import bds_files, load_bds
from ..twin import MatPhysics
from ..twin.field import mat_centre_cm
from ..units import n_from_kg
from ._balance_trials import (PLATFORM_RATE_HZ, TRIALS, Source, Trajectory, plan_trajectory, platform_table,
                              record_session)
from ._draws import Box, Person, draw_person
from ._lab import NOISE_V, PITCH_CM, equip, new_root, write_subjects
from ._truth import save_npz_stable, truth_json

__all__ = ["simulate_study", "TRIALS"]
#: Host clock of the first volunteer's first trial: 2024-05-06 09:00 UTC; eight volunteers a day, 45 min apart.
HOST_EPOCH = _dt.datetime(2024, 5, 6, 9, 0, tzinfo=_dt.timezone.utc)
#: Unloaded rest between a volunteer's trials (s).
REST_S = (30.0, 120.0)
#: The platform starts up to this long before the mat (s); and stops up to this long after it.
PLATFORM_MARGIN_S = 3.0
#: The Romberg trial's sway passes from the eyes-open source to the eyes-closed one over this long (s).
BLEND_S = 0.5
_TRUTH_README = """\
This folder holds what the simulator knows and a lab does not: each volunteer's true sensor
parameters, cell gains, R_mux and clock; each session's true lag, timing and CoP trajectory.

Nothing but the evaluation of the simulation itself may read it: `psmat study run` never does,
and a processing that reads it is no longer measuring anything.

study.json               the simulation's arguments and choices
volunteers/Vnn.json      person, mat (sensor model, 1/f, cell spread), box (R_mux, R_adc, clock,
                         loss rate) and the calibration a lab found
volunteers/Vnn.npz       gain (R, C) cell gains; r_mux_ohm (R, C) true R_mux per row-column pair
sessions/<stem>.json     source trajectory, placement, sway scale, rotation, platform timing and
                         origin, lag_s (platform clock minus device clock, cop(t) ~ cop_ref(t + lag_s),
                         the mean over the frames the platform saw) and its drift, lost frames
sessions/<stem>.npz      t_device_s, t_platform_s, t_host_s (N,), cop_cm (N, 2) the true CoP in mat
                         coordinates (cell (i, p) at (2p, 2i) cm), force_n (N,), valid (N,),
                         pressure_mean_psi (R, C)
"""


def _sources(bds_paths: Sequence[str | os.PathLike[str]] | None) -> list[Path]:
    """The source recordings: the BDS trials shipped with psmat (or ``$PSMAT_BDS_DIR``), or the files
    (and folders of ``BDS?????.txt[.xz]``) given."""
    if bds_paths is None:
        files = bds_files()
    else:
        paths = [bds_paths] if isinstance(bds_paths, (str, os.PathLike)) else list(bds_paths)
        files = []
        for p in map(Path, paths):
            if p.is_dir():
                files.extend(sorted(p.glob("BDS[0-9][0-9][0-9][0-9][0-9].txt*")))
            elif p.is_file():
                files.append(p)
            else:
                raise FileNotFoundError(f"BDS trajectory file not found: {p}")
    if not files:
        raise ValueError("no trajectory file to simulate from (bds_paths is empty or its folders hold no BDS?????.txt)")
    return files


def _romberg_pairs(files: Sequence[Path]) -> list[tuple[tuple[str, str], list[int], list[int]]]:
    """Per BDS subject (folder, ``Subject``) with both: the indices into ``files`` of its firm-surface
    eyes-open and eyes-closed trials (from the ``trials.tsv`` beside the files)."""
    rows: dict[tuple[Path, str], dict[str, str]] = {}
    for parent in sorted({f.parent for f in files}):
        tsv = parent / "trials.tsv"
        if tsv.is_file():
            with open(tsv, newline="", encoding="utf-8") as fh:
                for row in csv.DictReader(fh, delimiter="\t"):
                    rows[(parent, (row.get("Trial") or "").strip())] = row
    found: dict[tuple[str, str], tuple[list[int], list[int]]] = {}
    for i, f in enumerate(files):
        row = rows.get((f.parent, Path(f.name.removesuffix(".xz")).stem))
        if row is None or (row.get("Surface") or "").strip().lower() != "firm":
            continue
        vision = (row.get("Vision") or "").strip().lower()
        if vision in ("open", "closed"):
            found.setdefault((str(f.parent), (row.get("Subject") or "").strip()), ([], []))[vision == "closed"].append(i)
    pairs = [(key, eo, ec) for key, (eo, ec) in sorted(found.items()) if eo and ec]
    if not pairs:
        raise ValueError("romberg needs an eyes-open and an eyes-closed BDS trial of one subject on a firm surface "
                         "(Vision, Surface in the trials.tsv beside the files); none among the sources")
    return pairs


def _check(volunteers: Any, duration_s: Any, seed: Any, rate_hz: Any, shape: Any
           ) -> tuple[int, float, int, float, tuple[int, int]]:
    """The checked arguments of :func:`simulate_study` (one-line ValueErrors)."""
    n = _checks.positive_int("volunteers", volunteers)
    s = _checks.duration_s("duration_s", duration_s)
    k = _checks.nonneg_int("seed", seed)
    rate = _checks.rate_hz("rate_hz", rate_hz)
    R, C = _checks.shape2(shape)
    if R < 16 or C < 16:
        raise ValueError(f"shape must be at least (16, 16) cells of {PITCH_CM:g} cm so that the feet fit, got {(R, C)}")
    if round(s * rate) < 8:
        raise ValueError(f"duration_s * rate_hz = {s * rate:g} frames; a session needs at least 8")
    return n, s, k, rate, (R, C)


def _load(path: Path) -> Source:
    """A BDS trial as a :class:`Source` (M-L, A-P in cm, Fz in N)."""
    rec = load_bds(path, with_trial_info=False)
    if rec.n < 2 or rec.fz_n is None or not np.all(rec.fz_n > 0):
        raise ValueError(f"{path}: needs at least 2 samples and a positive Fz (someone standing)")
    return Source(Path(path.name.removesuffix(".xz")).stem, rec.t, rec.cop_ml_cm, rec.cop_ap_cm, rec.fz_n)


def _rest(mat: MatPhysics, seconds: float) -> None:
    """The volunteer steps off: the mat unloaded for ``seconds`` (its creep relaxes, eq. 2.23)."""
    zero = np.zeros((1, *mat.shape))
    mat.conductance(zero)  # one frame at its period: the last load leaves the creep input
    period, mat.dt = mat.dt, max(seconds - mat.dt, mat.dt)
    mat.conductance(zero)
    mat.dt = period


def simulate_study(root: str | os.PathLike[str], *, volunteers: int, duration_s: float, seed: int,
                   rate_hz: float = 100.0, bds_paths: Sequence[str | os.PathLike[str]] | None = None,
                   shape: tuple[int, int] = (16, 16), progress: bool = False, romberg: bool = False) -> Path:
    """Write a simulated balance study to ``root`` (see the module docstring for every choice).

    Parameters
    ----------
    root : path
        A new (or empty) folder.
    volunteers : int
        Number of volunteers (>= 1), three trials each.
    duration_s : float
        Length of each mat session (s).
    seed : int
        Seeds every draw; the same seed gives the same study.
    rate_hz : float
        The mat's nominal frame rate (Hz).
    bds_paths : sequence of paths, optional
        Source trajectories (BDS files, or folders of them); default the 24 BDS trials shipped with psmat.
    shape : (R, C)
        Cells of the mat (2 cm pitch), at least (16, 16).
    progress : bool
        A progress bar over sessions.
    romberg : bool
        Add a fourth trial per volunteer, ``romberg`` (eyes open then closed, each ``duration_s``;
        see the module docstring). The three trials stay the same, file for file.

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

    n_vol, secs, seed_, rate, (R, C) = _check(volunteers, duration_s, seed, rate_hz, shape)
    out = new_root(root, "simulate_study")
    files = _sources(bds_paths)
    width = max(2, len(str(n_vol)))
    ids = [f"V{i + 1:0{width}d}" for i in range(n_vol)]
    streams = [child.spawn(6) for child in np.random.SeedSequence(seed_).spawn(n_vol)]  # V_i's whatever n_vol
    people = [draw_person(np.random.default_rng(s[0])) for s in streams]
    picks = []
    for s in streams:
        rng = np.random.default_rng(s[1])
        picks.append(rng.choice(len(files), size=3, replace=len(files) < 3).tolist())
    rombergs: list[tuple[int, int, str] | None] = [None] * n_vol
    if romberg:
        pairs = _romberg_pairs(files)
        for v, s in enumerate(streams):  # the sixth stream: the three trials draw nothing more with it
            rng = np.random.default_rng(s[5])
            key, eo, ec = pairs[int(rng.integers(len(pairs)))]
            rombergs[v] = (eo[int(rng.integers(len(eo)))], ec[int(rng.integers(len(ec)))], key[1])
    used = {i for p in picks for i in p} | {i for r in rombergs if r is not None for i in r[:2]}
    cache = {i: _load(files[i]) for i in sorted(used)}
    for sub in ("sessions", "forceplate", "calibration", "truth/volunteers", "truth/sessions"):
        (out / sub).mkdir(parents=True, exist_ok=True)
    write_subjects(out, ids, people)
    frames = int(round(secs * rate))
    per = 4 if romberg else 3
    with tqdm(total=per * n_vol, unit="session", desc="simulating", disable=not progress) as bar:
        for i, (vid, person, s, pick, rb) in enumerate(zip(ids, people, streams, picks, rombergs)):
            pair = None if rb is None else (cache[rb[0]], cache[rb[1]], rb[2])
            _volunteer(out, i, vid, person, s, [cache[j] for j in pick], frames, rate, (R, C), seed_, bar, pair)
    study = {"seed": seed_, "volunteers": n_vol, "seconds": secs, "rate_hz": rate, "frames": frames,
             "shape": [R, C], "pitch_cm": PITCH_CM, "platform_rate_hz": PLATFORM_RATE_HZ, "noise_v": NOISE_V,
             "trials": list(TRIALS), "sources": [f.name.removesuffix(".xz") for f in files], "subjects": ids,
             "boxes": "one per volunteer", "simulator": "psmat.synth.simulate_study"}
    if romberg:
        study["trials"] = [*TRIALS, "romberg"]
        study["romberg"] = {"seconds_each": secs, "blend_s": BLEND_S, "volunteers": {
            vid: {"eyes_open": cache[r[0]].name, "eyes_closed": cache[r[1]].name, "bds_subject": r[2]}
            for vid, r in zip(ids, rombergs) if r is not None}}
    (out / "truth" / "study.json").write_text(truth_json(study), encoding="utf-8")
    (out / "truth" / "README.txt").write_text(_TRUTH_README, encoding="utf-8")
    return out


def _volunteer(out: Path, index: int, vid: str, person: Person, streams: list[np.random.SeedSequence],
               sources: list[Source], frames: int, rate: float, shape: tuple[int, int], seed: int, bar: Any,
               romberg: tuple[Source, Source, str] | None = None) -> None:
    """Draw the volunteer's mat and box, calibrate the box, record the three trials (and the Romberg one)."""
    rng_box = np.random.default_rng(streams[3])
    day = HOST_EPOCH + _dt.timedelta(days=index // 8, minutes=45 * (index % 8))
    kit = equip(out, f"SIM{seed}-{vid}", np.random.default_rng(streams[2]), rng_box, shape, rate,
                day.date().isoformat())
    box, mat = kit.box, kit.mat
    period_true = (1.0 / rate) * (1.0 + box.clock_error)
    # the platform's origin is its centre; the mat laid on it within ±3 cm: x_fp = x_mat + origin
    origin = -mat_centre_cm(shape, PITCH_CM) + rng_box.uniform(-3.0, 3.0, 2)
    kit.save_truth(out / "truth" / "volunteers", vid,
                   {**kit.truth(vid, person.as_dict()), "platform_origin_cm": origin.tolist()})
    foot = {"foot_length_cm": person.foot_length_cm, "foot_width_cm": person.foot_width_cm}
    rng = np.random.default_rng(streams[4])
    host0 = day.timestamp()  # the platform's start of the first trial on the host clock
    platform_start = 0.0  # the same instant on a continuous clock of the volunteer's visit (s)
    first_mat_start: float | None = None
    mat_end_prev = 0.0
    seconds = frames / rate
    for trial, src in zip(TRIALS, sources):
        early = min(1.0, 0.1 * seconds)
        lead = float(rng.uniform(-early, PLATFORM_MARGIN_S))
        mat_end = lead + (frames - 1) * period_true
        fp_end = max(mat_end + float(rng.uniform(-early, PLATFORM_MARGIN_S)), 1.0)
        traj = plan_trajectory(trial, src, (min(0.0, lead), max(fp_end, mat_end)), n_from_kg(person.weight_kg),
                               shape, PITCH_CM, foot, rng)
        stem = f"{vid}_{trial}"
        n_fp = int(math.floor(fp_end * PLATFORM_RATE_HZ + 1e-9)) + 1
        (out / "forceplate" / f"{stem}.csv").write_text(platform_table(traj, n_fp, origin), encoding="utf-8")
        mat_start = platform_start + lead  # on the visit's clock
        if first_mat_start is None:
            first_mat_start = mat_start
        else:
            _rest(mat, mat_start - mat_end_prev)
        # the box's µs counter runs on its own clock through the visit; v2 sends it modulo 2**32
        ticks = int(round((mat_start - first_mat_start) / (1.0 + box.clock_error) * 1e6))
        d0 = (box.counter_start_us + ticks) % (1 << 32)
        st = record_session(out / "sessions" / f"{stem}.h5", traj, mat, trial=trial, lead_s=lead, frames=frames,
                            rate_hz=rate, clock_error=box.clock_error, device_start_us=d0,
                            host_start_s=host0 + platform_start, loss_rate=box.loss_rate, pitch_cm=PITCH_CM,
                            foot=foot, device=kit.device, profile=kit.profile, calibration=kit.calibration.to_dict(),
                            metadata={"subject": vid, "trial": trial, "simulated": True,
                                      "operator": "psmat.synth.simulate_study"}, rng=rng)
        _session_truth(out, stem, traj, st, frames, rate, box, d0, host0 + platform_start, n_fp, fp_end, lead)
        mat_end_prev = platform_start + lead + frames * period_true
        platform_start += fp_end + float(rng.uniform(*REST_S))
        bar.update(1)
    if romberg is None:
        return
    # the Romberg trial: the same draws as a trial above, in the same order, from the same stream, after them
    eo_src, ec_src, bds_subject = romberg
    early = min(1.0, 0.1 * seconds)
    lead = float(rng.uniform(-early, PLATFORM_MARGIN_S))
    switch = lead + frames * period_true  # platform time of the first eyes-closed frame
    mat_end = lead + (2 * frames - 1) * period_true
    fp_end = max(mat_end + float(rng.uniform(-early, PLATFORM_MARGIN_S)), 1.0)
    weight = n_from_kg(person.weight_kg)
    eo = plan_trajectory("romberg", eo_src, (min(0.0, lead), switch + BLEND_S), weight, shape, PITCH_CM, foot, rng)
    ec = plan_trajectory("romberg", ec_src, (switch, max(fp_end, mat_end)), weight, shape, PITCH_CM, foot, rng,
                         position_cm=np.asarray(eo.info["position_cm"]))
    traj = _join(eo, ec, switch)
    stem = f"{vid}_romberg"
    n_fp = int(math.floor(fp_end * PLATFORM_RATE_HZ + 1e-9)) + 1
    (out / "forceplate" / f"{stem}.csv").write_text(platform_table(traj, n_fp, origin), encoding="utf-8")
    mat_start = platform_start + lead
    assert first_mat_start is not None  # the three trials came first
    _rest(mat, mat_start - mat_end_prev)
    ticks = int(round((mat_start - first_mat_start) / (1.0 + box.clock_error) * 1e6))
    d0 = (box.counter_start_us + ticks) % (1 << 32)
    host_start = host0 + platform_start
    traj.info["romberg"] = {"eyes_open": eo_src.name, "eyes_closed": ec_src.name, "bds_subject": bds_subject,
                            "surface": "Firm", "switch_platform_s": switch,
                            "switch_frame": frames, "seconds_each": seconds, "blend_s": BLEND_S}
    st = record_session(out / "sessions" / f"{stem}.h5", traj, mat, trial="romberg", lead_s=lead, frames=2 * frames,
                        rate_hz=rate, clock_error=box.clock_error, device_start_us=d0, host_start_s=host_start,
                        loss_rate=box.loss_rate, pitch_cm=PITCH_CM, foot=foot, device=kit.device, profile=kit.profile,
                        calibration=kit.calibration.to_dict(),
                        metadata={"subject": vid, "trial": "romberg", "simulated": True,
                                  "operator": "psmat.synth.simulate_study"},
                        rng=rng, events=[(0, "eyes open"), (frames, "eyes closed")])
    traj.info["romberg"]["switch_host_s"] = float(st.t_host_s[frames])  # the "eyes closed" marker
    _session_truth(out, stem, traj, st, 2 * frames, rate, box, d0, host_start, n_fp, fp_end, lead)
    bar.update(1)


def _join(eo: Trajectory, ec: Trajectory, switch: float) -> Trajectory:
    """The eyes-open trajectory up to ``switch`` (platform clock, s), the eyes-closed one from it, passing
    linearly from the first to the second over :data:`BLEND_S` (both on the one grid of the source's rate)."""
    a, b = eo.t < switch, ec.t >= switch
    t = np.concatenate([eo.t[a], ec.t[b]])
    if t.size > 2 and not np.allclose(np.diff(t), t[1] - t[0], rtol=1e-6, atol=0.0):
        raise ValueError("the eyes-open and eyes-closed sources of the Romberg trial have different rates")
    w = np.clip((ec.t[b] - switch) / BLEND_S, 0.0, 1.0)[:, None]
    cop_eo, fz_eo = eo.at(ec.t[b])
    cop = np.concatenate([eo.cop_cm[a], (1.0 - w) * cop_eo + w * ec.cop_cm[b]])
    fz = np.concatenate([eo.fz_n[a], (1.0 - w[:, 0]) * fz_eo + w[:, 0] * ec.fz_n[b]])
    info = {"trial": "romberg", "stance": "two", "source": f"{eo.info['source']} then {ec.info['source']}",
            "position_cm": eo.info["position_cm"], "rotation": None,
            "sway_scale": min(eo.info["sway_scale"], ec.info["sway_scale"]), "sway_scale_wanted": 1.0,
            "eyes_open_part": eo.info, "eyes_closed_part": ec.info}
    return Trajectory(t, cop, fz, info)


def _session_truth(out: Path, stem: str, traj: Any, st: Any, frames: int, rate: float, box: Box, d0: int,
                   host_start: float, n_fp: int, fp_end: float, lead: float) -> None:
    """truth/sessions/<stem>.json and .npz."""
    k = np.arange(frames)
    t_dev = (d0 + np.round(k / rate * 1e6)) * 1e-6
    lag = st.t_platform_s - t_dev  # cop(t) ≈ cop_ref(t + lag), t on the device clock
    seen = (st.t_platform_s >= 0.0) & (st.t_platform_s <= fp_end)
    info = dict(traj.info)
    info.update(
        stem=stem, frames=frames, frames_lost=np.flatnonzero(~st.valid).tolist(),
        lag_s=float(np.mean(lag[seen])), lag_start_s=float(lag[0]), lag_end_s=float(lag[-1]),
        lag_drift=box.clock_error, lag_host_s=float(np.mean((st.t_platform_s - st.t_host_s)[seen])),
        mat={"rate_hz": rate, "frame_period_true_s": (1.0 / rate) * (1.0 + box.clock_error),
             "first_frame_platform_s": lead, "first_frame_device_us": d0, "host_start_s": host_start},
        platform={"rate_hz": PLATFORM_RATE_HZ, "start_s": 0.0, "samples": n_fp, "end_s": fp_end},
        clipped_frames=st.clipped_frames, saturated_fraction=st.saturated_fraction,
        force_on_mat_min=st.force_on_mat_min,
    )
    (out / "truth" / "sessions" / f"{stem}.json").write_text(truth_json(info), encoding="utf-8")
    save_npz_stable(out / "truth" / "sessions" / f"{stem}.npz", {
        "t_device_s": t_dev, "t_platform_s": st.t_platform_s, "t_host_s": st.t_host_s, "cop_cm": st.cop_cm,
        "force_n": st.force_n, "valid": st.valid, "pressure_mean_psi": st.pressure_mean_psi})

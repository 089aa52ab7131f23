"""``psmat demo``: acquisition end to end on the digital twin.

With no mat given, the twin (:class:`psmat.twin.SerialTwin`: the PSM firmware core on a
pseudo-terminal) streams a person swaying whose centre of pressure follows a recorded
force-platform trajectory (BDS data set, :func:`psmat.io.bds_trial`). The demo reads it
with :mod:`psmat.acquire` exactly as it would read a mat, records a session file
(:mod:`psmat.io`), runs the processing chain (:mod:`psmat.process`: counts → G → IECM →
inverse sensor model → CoP), stores the products in the session, and compares the mat's
CoP with the force platform's.

On the twin the corrected CoP sits a few mm off the platform's. That offset is the twin's
cell-to-cell gain variability (15 % by default, :class:`psmat.twin.mat.MatPhysics`), which
a sensor model shared by all cells cannot know: the demo measures it by processing the same
frames once more with the twin's own gains divided out (known only to the simulation) and
shows both on the figure.

The mat is a device profile's (:class:`psmat.Profile`, default the thesis' ``psm16``): the twin
has its shape, pitch, circuit and wire order, the port is read with its protocol, and the session
stores it, so that :func:`psmat.process.process_session` computes the CoP on its geometry (cm,
its origin and axis directions); the platform's CoP is expressed in the same coordinates.
"""

from __future__ import annotations

import time
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["run_sway_demo", "record_sway", "sway_figure", "SwayRecording", "scene_to_mat_cm"]


def _rms(d: np.ndarray) -> float:
    """RMS length (cm) of (T, 2) CoP differences, NaN rows left out."""
    return float(np.sqrt(np.nanmean(np.sum(d**2, axis=1))))


@dataclass
class SwayRecording:
    """What :func:`record_sway` recorded and computed.

    Attributes
    ----------
    session : psmat.io.Session
        The recorded session file, loaded.
    processed : psmat.process.Processed
        The chain's products (CoP in cm).
    truth_cm : ndarray (T, 2) or None
        The force platform's CoP at each frame (twin only), cm.
    cop_known_gains_cm : ndarray (T, 2) or None
        The CoP of the same frames with the twin's cell gains divided out (twin only), cm.
    gain_sd : float or None
        SD of the log of the twin's cell gains (0.15: about 15 % cell to cell).
    res : dict
        The figures it printed (plain data).
    """

    session: Any
    processed: Any
    truth_cm: np.ndarray | None
    cop_known_gains_cm: np.ndarray | None
    gain_sd: float | None
    res: dict[str, Any]


def _mat_profile(profile: Any, shape: tuple[int, int] | None) -> Any:
    """The mat's profile: ``profile`` (default the default profile) for ``shape`` when given."""
    from ..profile import default_profile

    prof = default_profile() if profile is None else profile
    if prof.geometry is None:
        raise ValueError(f"profile {prof.name!r} describes a {prof.kind} device, not a mat")
    return prof if shape is None else prof.with_shape(tuple(shape))


def scene_to_mat_cm(xy_cm: np.ndarray, geometry: Any) -> np.ndarray:
    """Points (..., 2) in a scene's coordinates (cm; cell (i, p) at (p·pitch, i·pitch), the twin's
    convention) in the coordinates of ``geometry`` (a :class:`psmat.profile.Geometry` of the same
    pitch: its origin and axis directions). Affine, so a CoP maps to the CoP."""
    xy = np.asarray(xy_cm, np.float64)
    index = {"columns": xy[..., 0] / geometry.pitch_cm, "rows": xy[..., 1] / geometry.pitch_cm}  # fractional p, i
    out = []
    for direction, origin in zip((geometry.x, geometry.y), geometry.origin_cm):
        sign = 1.0 if direction[0] == "+" else -1.0
        out.append(origin + sign * index[direction[1:]] * geometry.pitch_cm)
    return np.stack(out, axis=-1)


def record_sway(*, seconds: float = 8.0, rate_hz: int = 100, session: str | Path = "psmat_demo.h5",
                bds_trial: int = 1, port: str | None = None, shape: tuple[int, int] | None = None, seed: int = 0,
                progress: bool | None = None, log=print, overwrite: bool = False, profile: Any = None
                ) -> SwayRecording:
    """Record ``seconds`` from the twin (or the mat on ``port``), process and compare.

    ``profile`` (a mat's :class:`psmat.Profile`, default the default profile ``psm16``) is the
    mat: the twin's shape, pitch, circuit and wire order, the protocol the port is read with, and
    what the session stores; ``shape`` (rows, columns), when given, reshapes it
    (:meth:`psmat.Profile.with_shape`). Prints the frames, the losses and the CoP errors (cm RMS)
    against the force platform. An existing ``session`` is an error
    (:class:`psmat._atomic.OutputRefused`) unless ``overwrite``; it is then replaced only when the
    new recording is complete (:class:`psmat.io.SessionWriter`).
    """
    from psmat._progress import tqdm

    from .._atomic import check_outputs
    from ..acquire import open_device
    from ..io import SessionWriter, load_session
    from ..process import process_session
    from ..sensor import MPICreep
    from ..twin import PsmSource, SerialTwin

    session = Path(session)
    prof = _mat_profile(profile, shape)
    shape = (int(prof.shape[0]), int(prof.shape[1]))
    check_outputs([session], overwrite=overwrite)  # before the twin or the port is touched
    twin = source = None
    if port is None:
        source = PsmSource.named("sway", rate_hz, duration_s=max(60.0, seconds + 1), bds_trial=bds_trial,
                                 seed=seed, profile=prof)
        twin = SerialTwin("psm", rate_hz, prof.protocol, source=source, shape=shape).start()
        port = twin.port
        log(f"no mat given: the digital twin of {prof.name} serves {shape[0]}x{shape[1]} frames "
            f"({prof.pitch_cm:g} cm pitch, {prof.protocol}) at {rate_hz:g} Hz on {port} "
            f"({source.scene.meta.get('source', 'quiet standing')})")
    circuit = prof.circuit()
    try:
        with open_device(port, "psm", prof.protocol, shape, baudrate=prof.baudrate, bits=prof.bits,
                         row_order=prof.row_order, col_order=prof.col_order) as dev:
            desc = dict(dev.description or {})
            desc.setdefault("rate", rate_hz)
            meta = {"subject": "digital twin" if twin else "unknown", "task": "quiet standing, eyes open",
                    "force_platform": (source.scene.meta.get("source") if source else None)}
            with SessionWriter(session, shape, device=desc, calibration=circuit.as_dict(), metadata=meta,
                               profile=prof.to_dict(), overwrite=overwrite) as writer:
                dev.record_to(writer)
                dev.start()
                t0 = time.monotonic()
                with tqdm(total=round(seconds, 1), unit="s", desc="recording", leave=False,
                          disable=None if progress is None else not progress) as bar:
                    while (el := time.monotonic() - t0) < seconds:
                        dev.read(timeout_s=0.2)  # keep the live buffer drained; the writer has every frame
                        bar.update(round(min(el, seconds) - bar.n, 1))
                dev.stop()
                dev.stop_recording()
                stats = dev.stats
                n_recorded = writer.n_frames
    finally:
        if twin is not None:
            twin.stop()
    log(f"recorded {session}: {n_recorded} frames, {stats.invalid} invalid, {stats.dropped_wire} lost on the wire")

    sensor = MPICreep.thesis()  # one model for every cell, as a lab has it
    g_rest = source.physics.g_rest if source is not None else 0.0
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", RuntimeWarning)
        proc = process_session(session, circuit=circuit, sensor=sensor, g_rest=g_rest, progress=progress)
    not_converged = sum("did not converge" in str(w.message) for w in caught)

    s = load_session(session)
    res: dict[str, Any] = {"frames": int(s.n_frames), "invalid": int((~s.valid).sum()), "lost": int(stats.dropped_wire),
                           "session": str(session), "iecm_warnings": not_converged}
    truth = known = None
    if source is not None and s.seq is not None:
        T = source.scene.pressure_psi.shape[0]
        # the platform's CoP, from the scene's coordinates into the profile's (those of the chain's CoP)
        truth = scene_to_mat_cm(source.scene.cop_true_cm[np.asarray(s.seq) % T], _geometry(proc))
        known = _cop_with_known_gains(proc, sensor, g_rest, source.physics.gain)
        ok = proc.usable & np.all(np.isfinite(proc.cop_cm), axis=1) & np.all(np.isfinite(known), axis=1)
        d_raw, d, d_known = (c[ok] - truth[ok] for c in (proc.cop_raw_cm, proc.cop_cm, known))
        res.update(cop_rms_raw_cm=_rms(d_raw), cop_rms_cm=_rms(d), cop_offset_cm=d.mean(axis=0).tolist(),
                   cop_rms_after_offset_cm=_rms(d - d.mean(axis=0)),
                   cop_rms_raw_after_offset_cm=_rms(d_raw - d_raw.mean(axis=0)),
                   cop_rms_known_gains_cm=_rms(d_known), cop_offset_known_gains_cm=d_known.mean(axis=0).tolist(),
                   gain_sd=float(source.physics.variability))
        log(f"CoP against the force platform (cm RMS): raw G {res['cop_rms_raw_cm']:.3f} -> "
            f"IECM + sensor model {res['cop_rms_cm']:.3f}; after removing the mean offset "
            f"(instruments are aligned in space, thesis §3.2.1): {res['cop_rms_raw_after_offset_cm']:.3f} -> "
            f"{res['cop_rms_after_offset_cm']:.3f}")
        log(f"the mean offset {_xy(res['cop_offset_cm'])} cm is the twin's cell-to-cell gains "
            f"({100 * res['gain_sd']:.0f} %), unknown to a shared sensor model: with the twin's own gains divided "
            f"out (known only to the simulation) {res['cop_rms_known_gains_cm']:.3f} cm RMS, offset "
            f"{_xy(res['cop_offset_known_gains_cm'])} cm")
    return SwayRecording(s, proc, truth, known, float(source.physics.variability) if source else None, res)


def _xy(v) -> str:
    x, y = (round(float(a), 2) + 0.0 for a in v)  # + 0.0: no "-0.00"
    return f"({x:+.2f}, {y:+.2f})"


def _geometry(proc) -> Any:
    """The geometry the chain computed the CoP on (its params, a profile's ``[geometry]`` table)."""
    from ..profile import Geometry

    return Geometry.from_dict(proc.params["geometry"])


def _cop_with_known_gains(proc, sensor, g_rest: float, gain: np.ndarray) -> np.ndarray:
    """CoP (T, 2) cm of the chain's g with each cell's gain divided out before the inverse
    model: the twin's cells are ``g = gain · direct(p) + g_rest`` (MatPhysics)."""
    from ..balance import cop
    from ..units import PSI_KPA

    u = np.maximum(proc.g - g_rest, 0.0) / gain  # NaN frames stay NaN: the model skips them
    p = sensor.inverse(u, proc.clock.periods_s) * PSI_KPA  # each frame stepped with its own period (s)
    with np.errstate(invalid="ignore"):
        return cop(np.nan_to_num(p), geometry=_geometry(proc))


def run_sway_demo(out: str | Path = "psmat_demo.png", *, seconds: float = 8.0, rate_hz: int = 100,
                  session: str | Path = "psmat_demo.h5", bds_trial: int = 1, port: str | None = None,
                  shape: tuple[int, int] | None = None, seed: int = 0, progress: bool | None = None,
                  log=print, overwrite: bool = False, profile: Any = None) -> dict[str, Any]:
    """Record ``seconds`` from the twin (or the mat on ``port``), process, compare, plot.

    ``profile`` and ``shape``: the mat, as in :func:`record_sway`.

    Returns a dict of what it printed: frames, losses, CoP errors (cm) and the paths. Existing
    files ``out`` and ``session`` are an error (:class:`psmat._atomic.OutputRefused`, before
    anything is recorded) unless ``overwrite``; each is replaced only by a complete new one.
    """
    import matplotlib

    from .._atomic import check_outputs, replacing

    check_outputs([out, session], overwrite=overwrite)

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rec = record_sway(seconds=seconds, rate_hz=rate_hz, session=session, bds_trial=bds_trial, port=port,
                      shape=shape, seed=seed, progress=progress, log=log, overwrite=overwrite, profile=profile)
    fig = sway_figure(rec)
    out = Path(out)
    with replacing(out, overwrite=overwrite) as tmp:
        fig.savefig(tmp, dpi=110)
    plt.close(fig)
    rec.res["figure"] = str(out)
    log(f"figure: {out}")
    return rec.res


def sway_figure(rec: SwayRecording):
    """The demo's figure (a matplotlib Figure): one frame's G and pressure on the mat (cm, in the
    coordinates of the session's profile, as in ``psmat view``), and the CoP traces against the
    force platform with their RMS errors."""
    import matplotlib.pyplot as plt

    from ..live import mat_extent_cm, mat_image

    s, proc, truth, res = rec.session, rec.processed, rec.truth_cm, rec.res
    t = s.host_time_s - s.host_time_s[0] if s.device_time_us is None else (s.device_time_us - s.device_time_us[0]) * 1e-6
    usable = np.flatnonzero(proc.usable)
    k = int(usable[len(usable) // 2])
    geometry = _geometry(proc)  # the profile's: pitch, origin, axis directions (docs/spec.md §7)
    extent = mat_extent_cm(geometry)
    fig = plt.figure(figsize=(12.5, 8.2), layout="constrained")
    gs = fig.add_gridspec(2, 3)
    maps = ((proc.G[k] * 1e3, "viridis", "G (mS)", f"raw: equivalent conductance G\nframe {k}, crosstalk included",
             proc.cop_raw_cm[k], "x", "mat CoP, raw G"),
            (np.nan_to_num(proc.pressure_kpa[k]), "magma", "pressure (kPa)",
             "corrected: pressure\nIECM + inverse sensor model", proc.cop_cm[k], "+", "mat CoP, corrected"))
    for row, (img, cmap, unit, title, c, mk, lab) in enumerate(maps):
        ax = fig.add_subplot(gs[row, 0])
        im = ax.imshow(mat_image(img, geometry), origin="lower", cmap=cmap, extent=extent,
                       interpolation="nearest")
        fig.colorbar(im, ax=ax, shrink=0.8, label=unit)
        ax.plot(*c, mk, color="cyan", ms=10, mew=2, label=lab)
        if truth is not None:
            ax.plot(*truth[k], "o", mfc="none", mec="w", ms=10, mew=1.5, label="force platform CoP")
        ax.set_title(title, fontsize=10)
        ax.set_xlabel("M-L x (cm)")
        ax.set_ylabel("A-P y (cm)")
        ax.legend(loc="upper center", fontsize=7, facecolor="0.25", labelcolor="w", framealpha=0.8)
    lab_raw, lab = "mat, raw G", "mat, IECM + sensor model"
    if truth is not None:
        lab_raw += f": {res['cop_rms_raw_cm']:.3f} cm RMS ({res['cop_rms_raw_after_offset_cm']:.3f} without the mean offset)"
        lab += f": {res['cop_rms_cm']:.3f} cm RMS ({res['cop_rms_after_offset_cm']:.3f} without the mean offset)"
    for row, (j, name) in enumerate(((0, "M-L (x)"), (1, "A-P (y)"))):
        ax = fig.add_subplot(gs[row, 1:])
        if truth is not None:
            ax.plot(t, truth[:, j], "k", lw=2, label="force platform (true)")
        ax.plot(t, proc.cop_raw_cm[:, j], color="tab:gray", lw=0.8, label=lab_raw)
        ax.plot(t, proc.cop_cm[:, j], color="tab:red", lw=1, label=lab)
        if rec.cop_known_gains_cm is not None:
            ax.plot(t, rec.cop_known_gains_cm[:, j], color="tab:blue", lw=0.8, ls="--",
                    label=f"same frames, the twin's own cell gains divided out: {res['cop_rms_known_gains_cm']:.3f} cm RMS")
        ax.set_ylabel(f"CoP {name} (cm)")
        ax.grid(alpha=0.3)
    ax.set_xlabel("time (s, device clock)" if s.device_time_us is not None else
                  "time (s, host clock: the device sends no timestamps; no platform trace without sequence numbers)")
    fig.legend(*ax.get_legend_handles_labels(), loc="outside lower right", ncols=2, fontsize=8)
    title = f"psmat demo: {s.n_frames} frames recorded through the serial link ({Path(s.path).name})"
    if rec.cop_known_gains_cm is not None:
        title += (f"\nThe corrected CoP's mean offset {_xy(res['cop_offset_cm'])} cm (x, y) is the twin's "
                  f"{100 * rec.gain_sd:.0f} % cell-to-cell gain variability, which one sensor model for all cells "
                  f"cannot know;\nwith the twin's own gains divided out (known only to the simulation) it is "
                  f"{_xy(res['cop_offset_known_gains_cm'])} cm. Per-cell models: psmat.sensor.fit_cells.")
    fig.suptitle(title, fontsize=10)
    return fig

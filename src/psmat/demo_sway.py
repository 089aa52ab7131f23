"""``psmat demo``: acquisition end to end on the digital twin (issue 4, item 8).

With no mat given, the twin (:class:`psmat.twin.SerialTwin`: the PSM firmware core on a
pseudo-terminal) streams a person swaying whose centre of pressure follows a recorded
force-platform trajectory (BDS data set, :mod:`psmat.io.forceplate`). The demo reads it
with :mod:`psmat.acquire` exactly as it would read a mat, records a session file
(:mod:`psmat.io`), runs the processing chain (:mod:`psmat.process`: counts → G → IECM →
inverse sensor model → CoP), stores the products in the session, and compares the mat's
CoP with the force platform's.
"""

from __future__ import annotations

import time
import warnings
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["run_sway_demo"]


def _rms(d: np.ndarray) -> float:
    return float(np.sqrt(np.nanmean(np.sum(d**2, axis=1))))


def run_sway_demo(out: str | Path = "psmat_demo.png", *, seconds: float = 8.0, rate_hz: int = 100,
                  session: str | Path = "psmat_demo.h5", bds_trial: int = 1, port: str | None = None,
                  shape: tuple[int, int] = (16, 16), seed: int = 0, progress: bool | None = None,
                  log=print) -> dict[str, Any]:
    """Record ``seconds`` from the twin (or the mat on ``port``), process, compare, plot.

    Returns a dict of what it printed: frames, losses, CoP errors (cm) and the paths.
    """
    from tqdm.auto import tqdm

    from .acquire import open_device
    from .circuit import Circuit
    from .io import SessionWriter
    from .process import process_session
    from .twin import PsmSource, SerialTwin

    session = Path(session)
    if session.exists():
        session.unlink()
    twin = source = None
    if port is None:
        source = PsmSource.named("sway", rate_hz, shape, duration_s=max(60.0, seconds + 1), bds_trial=bds_trial,
                                 seed=seed)
        twin = SerialTwin("psm", rate_hz, "v2", source=source, shape=shape).start()
        port = twin.port
        log(f"no mat given: the digital twin serves {shape[0]}x{shape[1]} frames at {rate_hz} Hz on {port} "
            f"({source.scene.meta.get('source', 'quiet standing')})")
    circuit = Circuit()
    try:
        with open_device(port, "psm", "v2", shape) as dev:
            desc = dict(dev.description or {})
            desc.setdefault("rate", rate_hz)
            meta = {"subject": "digital twin" if twin else "unknown", "task": "quiet standing, eyes open",
                    "force_platform": (source.scene.meta.get("source") if source else None)}
            with SessionWriter(session, shape, device=desc, calibration=circuit.as_dict(), metadata=meta) as writer:
                dev.record_to(writer)
                dev.start()
                t0 = time.monotonic()
                with tqdm(total=round(seconds, 1), unit="s", desc="recording", leave=False,
                          disable=None if progress is None else not progress) as bar:
                    while (el := time.monotonic() - t0) < seconds:
                        dev.read(timeout=0.2)  # keep the live buffer drained; the writer has every frame
                        bar.update(round(min(el, seconds) - bar.n, 1))
                dev.stop()
                dev.stop_recording()
                stats = dev.stats
                n_recorded = writer.n_frames
    finally:
        if twin is not None:
            twin.stop()
    log(f"recorded {session}: {n_recorded} frames, {stats.invalid} invalid, {stats.dropped_wire} lost on the wire")

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", RuntimeWarning)
        proc = process_session(session, circuit=circuit, g_rest=1e-7 if twin else 0.0, progress=progress)
    not_converged = sum("did not converge" in str(w.message) for w in caught)

    from .io import load_session

    s = load_session(session)
    res: dict[str, Any] = {"frames": int(s.n_frames), "invalid": int((~s.valid).sum()), "lost": int(stats.dropped_wire),
                           "session": str(session), "iecm_warnings": not_converged}
    truth = None
    if source is not None and s.seq is not None:
        T = source.scene.pressure.shape[0]
        truth = source.scene.cop_true_cm[np.asarray(s.seq) % T]
        ok = proc.usable & np.all(np.isfinite(proc.cop_cm), axis=1)
        d_raw = proc.cop_raw_cm[ok] - truth[ok]
        d = proc.cop_cm[ok] - truth[ok]
        res.update(cop_rms_raw_cm=_rms(d_raw), cop_rms_cm=_rms(d), cop_offset_cm=d.mean(axis=0).tolist(),
                   cop_rms_after_offset_cm=_rms(d - d.mean(axis=0)),
                   cop_rms_raw_after_offset_cm=_rms(d_raw - d_raw.mean(axis=0)))
        log(f"CoP against the force platform (cm RMS): raw G {res['cop_rms_raw_cm']:.3f} -> "
            f"IECM + sensor model {res['cop_rms_cm']:.3f}; after removing the mean offset "
            f"(instruments are aligned in space, thesis §3.2.1): {res['cop_rms_raw_after_offset_cm']:.3f} -> "
            f"{res['cop_rms_after_offset_cm']:.3f}")
    res["figure"] = str(_figure(out, s, proc, truth))
    log(f"figure: {res['figure']}")
    return res


def _figure(out: str | Path, s, proc, truth) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t = s.host_time_s - s.host_time_s[0] if s.device_time_us is None else (s.device_time_us - s.device_time_us[0]) * 1e-6
    k = int(np.flatnonzero(proc.usable)[len(np.flatnonzero(proc.usable)) // 2])
    fig = plt.figure(figsize=(12, 7.5), layout="constrained")
    gs = fig.add_gridspec(2, 3)
    ax = fig.add_subplot(gs[0, 0])
    im = ax.imshow(proc.G[k] * 1e3, origin="lower", cmap="viridis")
    ax.set_title(f"raw: equivalent conductance G (mS)\nframe {k}, crosstalk included")
    fig.colorbar(im, ax=ax, shrink=0.8)
    ax = fig.add_subplot(gs[1, 0])
    im = ax.imshow(np.nan_to_num(proc.pressure_kpa[k]), origin="lower", cmap="magma")
    ax.set_title("corrected: pressure (kPa)\nIECM + inverse sensor model")
    fig.colorbar(im, ax=ax, shrink=0.8)
    for row, (j, name) in enumerate(((0, "M-L (x)"), (1, "A-P (y)"))):
        ax = fig.add_subplot(gs[row, 1:])
        if truth is not None:
            ax.plot(t, truth[:, j], "k", lw=2, label="force platform (true)")
        ax.plot(t, proc.cop_raw_cm[:, j], color="tab:gray", lw=0.8, label="mat, raw G")
        ax.plot(t, proc.cop_cm[:, j], color="tab:red", lw=1, label="mat, IECM + sensor model")
        ax.set_ylabel(f"CoP {name} (cm)")
        ax.grid(alpha=0.3)
        if row == 0:
            ax.legend(loc="upper right", fontsize=8)
        else:
            ax.set_xlabel("time (s, device clock)")
    fig.suptitle(f"psmat demo: {s.n_frames} frames recorded through the serial link ({Path(s.path).name})")
    out = Path(out)
    fig.savefig(out, dpi=110)
    plt.close(fig)
    return out

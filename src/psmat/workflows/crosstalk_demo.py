"""`psmat demo`: crosstalk removal on a simulated 16x16 mat, end to end, with a figure.

Two feet standing on the twin's mat (:func:`psmat.twin.swaying_feet`: the pressure field
through the thesis' sensor model, unloaded cells at the leakage g_rest) -> equivalent
conductances through the array's crosstalk (IECM forward model, eq. 2.5) -> the measurement chain with 1 mV noise and
12-bit quantisation (``psmat.Circuit``, docs/spec.md §2) -> counts -> back to G -> IECM -> cell
conductances with their propagated uncertainty (eq. 2.11). Prints the ghost level and the
centre-of-pressure error before and after, and writes a figure.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .. import iecm, twin
from ..balance import cop
from ..circuit import Circuit

__all__ = ["run_crosstalk_demo"]


def run_crosstalk_demo(out: str | Path = "psmat_demo.png", *, rows: int = 16, cols: int = 16,
                       noise_v: float = 1e-3, seed: int = 0, show: bool = False) -> dict:
    """Run the demo; returns the figures it printed (and writes the PNG to ``out``)."""
    pitch = twin.mat_pitch_cm((rows, cols))
    g_true = twin.swaying_feet(1, (rows, cols), seed=seed)[0]
    rng = np.random.default_rng(np.random.SeedSequence(seed).spawn(1)[0])  # noise independent of the twin's gains
    circuit = Circuit()  # improved prototype: R_o 2.2 kOhm, R_mux 145 Ohm, R_adc 6.9 MOhm
    counts = circuit.counts(iecm.forward(g_true), noise_v=noise_v, rng=rng)
    G_meas, flags = circuit.conductance(counts, return_flags=True)
    if np.any(flags):
        raise RuntimeError(f"{int(np.count_nonzero(flags))} cells read as open/short; the demo scene should not do that")
    g_hat, info = iecm.solve(G_meas, return_info=True)
    sigma = iecm.propagate_uncertainty(g_hat)

    loaded = g_true >= 1e-4
    ghost_before = G_meas[~loaded].sum() / G_meas.sum()
    ghost_after = g_hat[~loaded].sum() / g_hat.sum()
    cop_true = cop(g_true, pitch)
    err_raw = np.linalg.norm(cop(G_meas, pitch) - cop_true)
    err_iecm = np.linalg.norm(cop(g_hat, pitch) - cop_true)
    rel_err = np.abs(g_hat[loaded] / g_true[loaded] - 1)
    res = {
        "ghost_fraction_raw": float(ghost_before),
        "ghost_fraction_iecm": float(ghost_after),
        "cop_error_raw_cm": float(err_raw),
        "cop_error_iecm_cm": float(err_iecm),
        "loaded_cells_median_rel_error": float(np.median(rel_err)),
        "loaded_cells_median_rel_uncertainty": float(np.median(sigma[loaded] / g_hat[loaded])),
        "iterations": int(info.iterations),
        "status": str(info.status),
        "figure": str(Path(out).resolve()),
    }
    _figure(g_true, G_meas, g_hat, sigma, pitch, out, res, show)
    return res


def _figure(g_true, G_meas, g_hat, sigma, pitch, out, res, show):
    import matplotlib

    if not show:
        matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.colors import LogNorm

    R, C = g_true.shape
    extent = (-pitch / 2, (C - 0.5) * pitch, -pitch / 2, (R - 0.5) * pitch)  # cell (i, p) at (p, i)·pitch, docs/spec.md §7
    norm = LogNorm(vmin=1e-7, vmax=1e-2)  # the twin's unloaded cells are at g_rest = 1e-7 S
    fig, ax = plt.subplots(1, 4, figsize=(17, 4.4), constrained_layout=True)
    panels = [
        (g_true, "true cell conductance g"),
        (G_meas, f"measured G (crosstalk: {100 * res['ghost_fraction_raw']:.0f} % ghost)"),
        (g_hat, f"after IECM ({100 * res['ghost_fraction_iecm']:.1f} % ghost)"),
    ]
    for a, (img, title) in zip(ax[:3], panels):
        im = a.imshow(np.clip(img, 1e-7, None), norm=norm, cmap="viridis", extent=extent, origin="lower",
                      interpolation="nearest")
        a.set_title(title, fontsize=10)
        a.set_xlabel("x, medial-lateral (cm)")
    ax[0].set_ylabel("y, anterior-posterior (cm)")
    fig.colorbar(im, ax=ax[:3], label="conductance (S)", shrink=0.9)
    for img, mk, lab in ((g_true, "o", "true"), (G_meas, "x", "raw"), (g_hat, "+", "IECM")):
        cx, cy = cop(img, pitch)
        ax[0].plot(cx, cy, mk, color={"true": "w", "raw": "r", "IECM": "m"}[lab], ms=9, mew=2, label=f"CoP {lab}")
    ax[0].legend(loc="lower right", fontsize=7)
    free = g_hat > 1e-9  # cells held at the bound g ~ 0 (noise) have no meaningful eq. 2.11
    rel = sigma[free] / g_hat[free]
    ax[3].loglog(g_hat[free], rel, ".", ms=4, label=f"{int(free.sum())} cells ({int((~free).sum())} at g = 0 not shown)")
    ax[3].legend(loc="upper right", fontsize=7)
    ax[3].axhline(0.1, color="k", lw=0.8, ls="--")
    ax[3].set_xlabel("recovered g (S)")
    ax[3].set_ylabel("relative uncertainty (eq. 2.11)")
    ax[3].set_title("uncertainty, 1 mV noise (Table 2.4)", fontsize=10)
    fig.suptitle(
        f"psmat: crosstalk removal on a simulated {R}x{C} mat - CoP error {res['cop_error_raw_cm']:.2f} cm raw, "
        f"{res['cop_error_iecm_cm']:.3f} cm after IECM",
        fontsize=11,
    )
    from .._atomic import replacing

    with replacing(out) as tmp:  # the figure whole or not at all
        fig.savefig(tmp, dpi=110)
    if show:
        plt.show()
    plt.close(fig)

"""Thesis §2.3.3 (Fig. 2.17–2.20) in simulation: a 6×6 resistor board read by the 16×16 DAQ.

The thesis plugged a 6×6 array of through-hole resistors (100 Ω, 1 kΩ, 10 kΩ, 100 kΩ)
into its 16×16 DAQ box (the other lines open, read as infinite resistances), recorded
~300 frames (30 s) in static conditions, cropped the images to 6×6 and solved IECM on
every frame. *Experimental* uncertainty: the SD of each cell over the frames.
*Propagated*: eq. 2.11 at ``g = F⁻¹(median G)``. Configurations: random resistors
(Fig. 2.19) and a strong ghost case, three corners at 100 Ω and higher values elsewhere
(Fig. 2.20) — the case simulated here by default.

Simulation: the 6×6 block sits in rows/columns 0–5 of a 16×16 array whose other cells are
open (``g = 0``), so every line outside the block floats and the 6×6 equivalent
conductances are those of the board alone; the full 16×16 frame of counts is read through
:class:`psmat.Circuit` (first prototype: R_adc 123 kΩ, R_mux 145 Ω) with Gaussian noise
σ_v on the node voltage and 12-bit quantisation, inverted to G and cropped.
Propagation uses σ_G of the same chain at the median G, with the voltage noise
``sqrt(σ_v² + LSB²/12)`` (quantisation included), or the Table 2.4 model
(``noise_model="table"``).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field

import numpy as np

from .. import iecm
from ..circuit import OK, Circuit
from ..noise import table_sigma_G, voltage_sigma_G
from ._common import as_rng, fmt, format_table, plt, timed

__all__ = ["BoardResult", "resistor_board_6x6", "board_resistors"]

VALUES_OHM = (100.0, 1e3, 10e3, 100e3)


def board_resistors(config: str = "corners", seed=0, n: int = 6) -> np.ndarray:
    """Resistances (Ω) of the board, drawn from 100 Ω / 1 kΩ / 10 kΩ / 100 kΩ.

    ``"corners"``: three corners (top left, top right, bottom left) at 100 Ω, every other
    cell drawn uniformly from 1 kΩ, 10 kΩ, 100 kΩ (Fig. 2.20: "three corners are filled
    with 100 Ω resistor and the rest with higher values"). ``"random"``: every cell from
    all four values (Fig. 2.19).
    """
    rng = as_rng(seed)
    if config == "corners":
        r = rng.choice(VALUES_OHM[1:], size=(n, n))
        r[0, 0] = r[0, -1] = r[-1, 0] = 100.0
    elif config == "random":
        r = rng.choice(VALUES_OHM, size=(n, n))
    else:
        raise ValueError(f"config must be 'corners' or 'random', got {config!r}")
    return r


@dataclass
class BoardResult:
    """Per-cell results of the board experiment (6×6 arrays unless stated)."""

    resistance: np.ndarray       #: true resistors (Ω)
    g_true: np.ndarray           #: 1/resistance (S)
    g_frames: np.ndarray         #: IECM solution of every frame, (n_frames, 6, 6) (S)
    G_median: np.ndarray         #: median measured G over the frames (S)
    g_median: np.ndarray         #: F⁻¹(median G) (S)
    sigma_exp: np.ndarray        #: SD of g over the frames (S)
    sigma_prop: np.ndarray       #: eq. 2.11 at g_median (S)
    sigma_G: np.ndarray          #: σ_G used for the propagation (S)
    n_frames: int
    seed: int | None
    seconds: float
    status: dict = field(default_factory=dict)
    params: dict = field(default_factory=dict)

    @property
    def rel_exp(self) -> np.ndarray:
        return self.sigma_exp / self.g_median

    @property
    def rel_prop(self) -> np.ndarray:
        return self.sigma_prop / self.g_median

    @property
    def ratio(self) -> np.ndarray:
        """Experimental / propagated SD."""
        return self.sigma_exp / self.sigma_prop

    @property
    def recovery_error(self) -> np.ndarray:
        """|g_median - g_true| / g_true."""
        return np.abs(self.g_median - self.g_true) / self.g_true

    def loaded(self, max_ohm: float = 1e3) -> np.ndarray:
        """Mask of the cells the thesis plots (resistors ≤ 1 kΩ: relative precision ~10 % or better)."""
        return self.resistance <= max_ohm

    def table(self, max_ohm: float = 1e3) -> str:
        idx = np.argwhere(self.loaded(max_ohm))
        rows = [[f"({i},{p})", f"{self.resistance[i, p]:g}", fmt(self.g_true[i, p], 3), fmt(self.g_median[i, p], 4),
                 fmt(self.rel_exp[i, p]), fmt(self.rel_prop[i, p]), fmt(self.ratio[i, p], 3)]
                for i, p in idx]
        return format_table(["cell", "R (Ω)", "g true (S)", "g from median G (S)", "σ/g experimental",
                             "σ/g eq. 2.11", "exp/prop"], rows)

    def plot(self, fig=None, max_ohm: float = 1e3):
        """Fig. 2.19/2.20-like: conductance map; bars of relative σ (experimental, eq. 2.11) for R ≤ max_ohm."""
        pyplot = plt()
        if fig is None:
            fig = pyplot.figure(figsize=(9, 3.6))
        ax1, ax2 = fig.subplots(1, 2, gridspec_kw={"width_ratios": [1, 1.6]})
        im = ax1.imshow(np.log10(self.g_median), cmap="viridis")
        fig.colorbar(im, ax=ax1, label="log10 g (S)")
        ax1.set_title("6×6 board, IECM g")
        m = self.loaded(max_ohm)
        order = np.argsort(self.g_median[m])
        x = np.arange(order.size)
        ax2.bar(x - 0.2, self.rel_exp[m][order], 0.4, color="navy", label="experimental (SD over frames)")
        ax2.bar(x + 0.2, self.rel_prop[m][order], 0.4, color="lightskyblue", label="eq. 2.11")
        ax2.set_xticks(x, [f"{v:.1e}" for v in self.g_median[m][order]], rotation=70, fontsize=7)
        ax2.set_ylabel("relative uncertainty")
        ax2.set_xlabel("g (S)")
        ax2.legend(fontsize=8)
        fig.tight_layout()
        return fig


def resistor_board_6x6(
    n_frames: int = 300,
    seed: int | None = 0,
    *,
    config: str = "corners",
    resistance: np.ndarray | None = None,
    sigma_v: float = 1e-3,
    circuit: Circuit | None = None,
    daq_shape: tuple[int, int] = (16, 16),
    noise_model: str = "circuit",
) -> BoardResult:
    """Simulated §2.3.3 experiment; see the module docstring.

    Parameters
    ----------
    n_frames : int
        Frames recorded (thesis ~300, 30 s).
    seed : int or None
        Resistors from ``seed``, noise from ``seed + 1``.
    config : {"corners", "random"}
        Board layout (:func:`board_resistors`), unless ``resistance`` (6×6 Ω) is given.
    sigma_v : float
        Voltage noise SD (V), Table 2.4: ~1 mV.
    circuit : Circuit
        Default the first prototype's box.
    daq_shape : (R, C)
        The DAQ's array (the board occupies its first 6 rows and columns).
    noise_model : {"circuit", "table"}
        σ_G for eq. 2.11: the chain's first-order σ_G (with quantisation) or Table 2.4's.
    """
    if int(n_frames) != n_frames or n_frames < 3:
        raise ValueError(f"n_frames must be an integer >= 3, got {n_frames!r}")
    n_frames = int(n_frames)
    r = board_resistors(config, seed) if resistance is None else np.asarray(resistance, dtype=np.float64)
    n, m = r.shape
    cir = Circuit.first_prototype() if circuit is None else circuit
    with timed() as t:
        g_true = 1.0 / r
        G_board = iecm.forward(g_true)
        G_full = np.zeros(daq_shape)
        G_full[:n, :m] = G_board  # lines outside the board float: their pairs read open (G = 0)
        counts = cir.counts(np.broadcast_to(G_full, (n_frames,) + tuple(daq_shape)), noise_v=sigma_v,
                            rng=as_rng(None if seed is None else seed + 1))
        G_meas, flags = cir.conductance(counts, return_flags=True)
        G_crop, fl = G_meas[:, :n, :m], flags[:, :n, :m]
        if np.any(fl != OK):
            raise RuntimeError(f"{int(np.sum(fl != OK))} board readings flagged short/open: noise too large")
        G_med = np.median(G_crop, axis=0)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            g_frames, info = iecm.solve(G_crop, warm_start=False, return_info=True)
            g_med = iecm.solve(G_med)
        if noise_model == "circuit":
            sv_eff = np.hypot(sigma_v, cir.lsb / np.sqrt(12.0))
            sG = voltage_sigma_G(G_med, sv_eff, cir)
        elif noise_model == "table":
            sG = table_sigma_G(G_med)
        else:
            raise ValueError(f"noise_model must be 'circuit' or 'table', got {noise_model!r}")
        prop = iecm.propagate_uncertainty(g_med, sG)
        sd = g_frames.std(axis=0, ddof=1)
    status = dict(zip(*np.unique(np.asarray(info.status), return_counts=True)))
    return BoardResult(resistance=r, g_true=g_true, g_frames=g_frames, G_median=G_med, g_median=g_med,
                       sigma_exp=sd, sigma_prop=prop, sigma_G=sG, n_frames=n_frames, seed=seed, seconds=t[0],
                       status={str(k): int(v) for k, v in status.items()},
                       params={"config": config, "sigma_v": sigma_v, "circuit": cir.as_dict(),
                               "daq_shape": tuple(daq_shape), "noise_model": noise_model})

"""Synthetic but realistic conductance images for tests, examples and benchmarks.

Everything here is pure NumPy, vectorised and seeded. Units: lengths in cm, pressures in
kPa, forces in N, conductances in S.

Geometry
--------
The mat is ``rows × cols`` cells at ``pitch_cm``; by default the physical mat stays the
thesis' 32 cm × 32 cm and the pitch shrinks with the cell count (16×16 → 2 cm,
32×32 → 1 cm, 64×64 → 0.5 cm), so the same feet cover more cells on finer mats. Cell
``(i, p)`` has its centre at ``x = (p + 0.5) · pitch`` (medial-lateral, along the columns)
and ``y = (i + 0.5) · pitch`` (anterior-posterior, along the rows; toes towards larger
``y``).

Feet
----
Each foot is ~25 cm long and ~9 cm wide, built from smooth elliptical bumps
(``w · (1 - d²)₊^1.5``, ``d`` the normalised elliptical distance): heel, lateral midfoot
band, forefoot (metatarsal heads) and toes. The heel centres are ``stance_cm`` apart and
the feet are turned out by ``toe_out_deg``. The pressure is averaged over each cell's area
(4×4 sub-samples per cell) and scaled so that the load on the mat equals ``weight_n``:
quiet standing of a 70 kg person gives cell-averaged peaks of ~75 kPa under the heels.

Centre of pressure
------------------
``cop_offset_cm = (dx, dy)`` shifts the centre of pressure of the whole body-weight
distribution without moving the feet, as a person swaying on the spot does: the nominal
pressure ``p₀`` (CoP ``c₀``, covariance ``Σ`` over the cells) is re-weighted by
``1 + (r - c₀)ᵀ Σ⁻¹ δ``, which keeps the total load and moves the CoP by exactly ``δ``
(as long as no weight goes negative; they are clipped at 0, which never happens for
excursions of a few cm).

Pressure → conductance
----------------------
A simple monotone stand-in for the Velostat response (the fitted sensor model lives in
:mod:`psmat.sensor`)::

    g = g_bg + g_ref · (p / p_ref)^γ        g_ref = 1e-2 S, p_ref = 80 kPa, γ = 1.5

so loaded cells lie in ~1e-3…1e-2 S (100 Ω–1 kΩ), the foot outline in between, and
unloaded cells keep their background conductance ``g_bg``: log-uniform in
``background_s`` = (1e-6, 1e-5) S (100 kΩ–1 MΩ), fixed per cell (cell-to-cell
variability of the unloaded sensor), drawn from ``rng``.
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "MAT_SIZE_CM",
    "two_feet",
    "swaying_feet",
    "sway_trajectory",
    "feet_pressure",
    "pressure_to_conductance",
    "random_array",
    "default_pitch",
]

MAT_SIZE_CM = 32.0
"""Side of the thesis mat (cm); the default pitch keeps it for any cell count."""

# Pressure -> conductance stand-in (see module docstring).
G_REF_S = 1e-2
P_REF_KPA = 80.0
GAMMA = 1.5
BACKGROUND_S = (1e-6, 1e-5)

# Foot blobs in the foot's own frame: u along the foot (cm, toes positive, foot centre at
# 0, heel end at -12.5, toe end at +12.5), v across it (cm, positive = lateral side).
# Columns: centre_u, centre_v, semi-axis_u, semi-axis_v, relative weight.
_FOOT_BLOBS = np.array(
    [
        [-8.5, 0.0, 4.0, 3.2, 1.00],   # heel
        [-2.0, 2.3, 5.0, 1.8, 0.30],   # lateral midfoot band
        [4.5, 0.0, 4.0, 4.5, 0.80],    # forefoot, metatarsal heads
        [10.0, -0.5, 2.2, 4.0, 0.40],  # toes
    ]
)
_SUBSAMPLES = 4


def _as_rng(rng) -> np.random.Generator:
    return rng if isinstance(rng, np.random.Generator) else np.random.default_rng(rng)


def _check_shape(rows: int, cols: int) -> tuple[int, int]:
    if int(rows) != rows or int(cols) != cols or rows < 2 or cols < 2:
        raise ValueError(f"rows and cols must be integers >= 2, got {rows!r} x {cols!r}")
    return int(rows), int(cols)


def default_pitch(rows: int, cols: int) -> float:
    """Pitch (cm) that keeps the thesis' 32 cm mat: ``32 / max(rows, cols)``."""
    return MAT_SIZE_CM / max(rows, cols)


def _cell_centres(rows: int, cols: int, pitch: float) -> tuple[np.ndarray, np.ndarray]:
    y = (np.arange(rows) + 0.5) * pitch
    x = (np.arange(cols) + 0.5) * pitch
    return np.meshgrid(x, y)  # X, Y of shape (rows, cols)


def feet_pressure(
    rows: int = 16,
    cols: int = 16,
    pitch_cm: float | None = None,
    *,
    weight_n: float = 700.0,
    foot_length_cm: float = 25.0,
    foot_width_cm: float = 9.0,
    stance_cm: float = 10.0,
    toe_out_deg: float = 7.0,
    centre_cm: tuple[float, float] | None = None,
) -> np.ndarray:
    """Nominal pressure (kPa) of two feet in quiet standing, averaged over each cell.

    Parameters
    ----------
    rows, cols : int
        Mat size in cells (>= 2).
    pitch_cm : float, optional
        Cell pitch in cm; default :func:`default_pitch` (32 cm mat).
    weight_n : float
        Load carried by the mat in N (the pressure integrates to it).
    foot_length_cm, foot_width_cm : float
        Foot size; the blob layout is scaled to it (default 25 cm × 9 cm).
    stance_cm : float
        Distance between the two heel centres (cm).
    toe_out_deg : float
        Each foot turned outwards by this angle.
    centre_cm : (x, y), optional
        Where the feet are centred; default the middle of the mat.

    Returns
    -------
    numpy.ndarray, shape (rows, cols)
        Pressure in kPa (0 outside the feet).
    """
    rows, cols = _check_shape(rows, cols)
    pitch = default_pitch(rows, cols) if pitch_cm is None else float(pitch_cm)
    if not pitch > 0:
        raise ValueError(f"pitch_cm must be > 0, got {pitch_cm!r}")
    cx, cy = (cols * pitch / 2.0, rows * pitch / 2.0) if centre_cm is None else map(float, centre_cm)

    # Sub-sample points inside every cell: shape (rows*s, cols*s).
    s = _SUBSAMPLES
    sub = (np.arange(s) + 0.5) / s
    ys = ((np.arange(rows)[:, None] + sub[None, :]) * pitch).ravel()
    xs = ((np.arange(cols)[:, None] + sub[None, :]) * pitch).ravel()
    X, Y = np.meshgrid(xs, ys)

    su = foot_length_cm / 25.0
    sv = foot_width_cm / 9.0
    blobs = _FOOT_BLOBS * np.array([su, sv, su, sv, 1.0])
    p = np.zeros_like(X)
    for side in (-1.0, 1.0):  # left foot (smaller x), right foot
        ang = np.deg2rad(toe_out_deg) * side
        # Foot axis: toes towards +y, rotated outwards; heel centre at (cx + side*stance/2, ...).
        ax = np.array([np.sin(ang), np.cos(ang)])       # unit vector along the foot (u)
        lat = np.array([ax[1], -ax[0]]) * side          # unit vector across, towards lateral
        # Foot origin (u = 0) at the mat's mid-height, placed so that the heel centres
        # are stance_cm apart.
        ox = cx + side * stance_cm / 2.0 - blobs[0, 0] * ax[0]
        oy = cy
        dx, dy = X - ox, Y - oy
        u = dx * ax[0] + dy * ax[1]
        v = dx * lat[0] + dy * lat[1]
        d2 = ((u[..., None] - blobs[:, 0]) / blobs[:, 2]) ** 2 + ((v[..., None] - blobs[:, 1]) / blobs[:, 3]) ** 2
        p += np.sum(blobs[:, 4] * np.clip(1.0 - d2, 0.0, None) ** 1.5, axis=-1)
    # Average over each cell's sub-samples.
    p = p.reshape(rows, s, cols, s).mean(axis=(1, 3))
    area_m2 = (pitch * 1e-2) ** 2
    total = p.sum() * area_m2  # in (relative units)·m²
    if total <= 0:
        raise ValueError("the feet fall outside the mat; enlarge the mat or move centre_cm")
    return p * (weight_n / total) * 1e-3  # kPa: N/m² / 1000


def pressure_to_conductance(p_kpa, g_background) -> np.ndarray:
    """Monotone stand-in sensor response ``g = g_bg + g_ref (p/p_ref)^γ`` (S, from kPa).

    ``g_ref = 1e-2 S`` at ``p_ref = 80 kPa``, ``γ = 1.5``; ``p <= 0`` gives ``g_bg``.
    """
    p = np.clip(np.asarray(p_kpa, dtype=np.float64), 0.0, None)
    return np.asarray(g_background, dtype=np.float64) + G_REF_S * (p / P_REF_KPA) ** GAMMA


def _background(rows: int, cols: int, rng: np.random.Generator, background_s) -> np.ndarray:
    lo, hi = (float(b) for b in background_s)
    if not 0 < lo <= hi:
        raise ValueError(f"background_s must be 0 < low <= high (S), got {background_s!r}")
    return np.exp(rng.uniform(np.log(lo), np.log(hi), size=(rows, cols)))


def _cop_weights(p0: np.ndarray, X: np.ndarray, Y: np.ndarray, offsets: np.ndarray) -> np.ndarray:
    """Weights (T, R, C) that move the CoP of p0 by offsets (T, 2) cm, keeping the total."""
    w = p0 / p0.sum()
    c = np.array([np.sum(w * X), np.sum(w * Y)])
    dX, dY = X - c[0], Y - c[1]
    cov = np.array([[np.sum(w * dX * dX), np.sum(w * dX * dY)], [np.sum(w * dX * dY), np.sum(w * dY * dY)]])
    coef = np.linalg.solve(cov, offsets.T).T  # (T, 2)
    return np.clip(1.0 + coef[:, 0, None, None] * dX + coef[:, 1, None, None] * dY, 0.0, None)


def two_feet(
    rows: int = 16,
    cols: int = 16,
    pitch_cm: float | None = None,
    cop_offset_cm: tuple[float, float] = (0.0, 0.0),
    rng: np.random.Generator | int | None = None,
    *,
    weight_n: float = 700.0,
    background_s: tuple[float, float] = BACKGROUND_S,
    **geometry,
) -> np.ndarray:
    """Cell conductances (S) of two feet standing on a quiet background.

    Parameters
    ----------
    rows, cols : int
        Mat size in cells (>= 2).
    pitch_cm : float, optional
        Cell pitch in cm; default keeps a 32 cm mat (2 cm for 16×16, 1 cm for 32×32,
        0.5 cm for 64×64).
    cop_offset_cm : (dx, dy)
        Shift of the centre of pressure (cm; x along the columns, y along the rows) of the
        whole body-weight distribution; the feet stay where they are.
    rng : numpy.random.Generator, int or None
        Seed or generator for the unloaded cells' background conductances.
    weight_n : float
        Load on the mat in N (default 700 N, a 71 kg person).
    background_s : (low, high)
        Range (S) of the log-uniform background conductance of unloaded cells.
    **geometry
        Passed to :func:`feet_pressure` (``foot_length_cm``, ``stance_cm`` ...).

    Returns
    -------
    numpy.ndarray, shape (rows, cols)
        Cell conductances g in S: ~1e-3…1e-2 S under the feet, ``background_s`` elsewhere.
    """
    rows, cols = _check_shape(rows, cols)
    pitch = default_pitch(rows, cols) if pitch_cm is None else float(pitch_cm)
    gen = _as_rng(rng)
    p0 = feet_pressure(rows, cols, pitch, weight_n=weight_n, **geometry)
    X, Y = _cell_centres(rows, cols, pitch)
    off = np.asarray(cop_offset_cm, dtype=np.float64).reshape(1, 2)
    p = p0 * _cop_weights(p0, X, Y, off)[0]
    return pressure_to_conductance(p, _background(rows, cols, gen, background_s))


def sway_trajectory(
    frames: int,
    rate_hz: float = 100.0,
    sway_cm: tuple[float, float] = (0.5, 1.0),
    freq_hz: tuple[float, float] = (0.2, 0.35),
    rng: np.random.Generator | int | None = None,
    noise_fraction: float = 0.15,
    noise_cutoff_hz: float = 1.0,
) -> np.ndarray:
    """CoP offsets (T, 2) in cm for quiet standing.

    Each axis mixes two sinusoids at ``freq_hz`` (weights 0.7 and 0.3, random phases) with
    amplitude ``sway_cm`` = (medial-lateral x, anterior-posterior y), plus Gaussian noise
    low-passed at ``noise_cutoff_hz`` (FFT, second-order Butterworth magnitude) with an RMS of
    ``noise_fraction · sway``.
    """
    T = int(frames)
    if T < 1:
        raise ValueError(f"frames must be >= 1, got {frames!r}")
    if not rate_hz > 0:
        raise ValueError(f"rate_hz must be > 0, got {rate_hz!r}")
    gen = _as_rng(rng)
    amp = np.asarray(sway_cm, dtype=np.float64).reshape(2)
    f = np.asarray(freq_hz, dtype=np.float64).reshape(2)
    t = np.arange(T) / rate_hz
    phase = gen.uniform(0.0, 2 * np.pi, size=(2, 2))  # (axis, component)
    mix = np.array([0.7, 0.3])
    s = np.sin(2 * np.pi * f[None, :, None] * t[None, None, :] + phase[:, :, None])  # (2, 2, T)
    traj = amp[:, None] * np.einsum("c,act->at", mix, s)
    if noise_fraction > 0 and T > 1:
        white = gen.standard_normal((2, T))
        spec = np.fft.rfft(white, axis=-1)
        fr = np.fft.rfftfreq(T, d=1.0 / rate_hz)
        spec *= 1.0 / np.sqrt(1.0 + (fr / noise_cutoff_hz) ** 4)
        noise = np.fft.irfft(spec, n=T, axis=-1)
        noise -= noise.mean(axis=-1, keepdims=True)
        rms = np.sqrt(np.mean(noise**2, axis=-1, keepdims=True))
        traj += noise / np.where(rms > 0, rms, 1.0) * (noise_fraction * amp[:, None])
    return traj.T


def swaying_feet(
    frames: int,
    rows: int = 16,
    cols: int = 16,
    rate_hz: float = 100.0,
    sway_cm: tuple[float, float] = (0.5, 1.0),
    freq_hz: tuple[float, float] = (0.2, 0.35),
    rng: np.random.Generator | int | None = None,
    *,
    pitch_cm: float | None = None,
    weight_n: float = 700.0,
    background_s: tuple[float, float] = BACKGROUND_S,
    return_cop: bool = False,
    **geometry,
):
    """A recording (T, R, C) of cell conductances (S) of two feet swaying in quiet standing.

    The feet and the background stay fixed; the load distribution moves with the CoP
    offsets of :func:`sway_trajectory` (amplitudes ``sway_cm`` = (x, y) cm, frequencies
    ``freq_hz``, sampled at ``rate_hz``). At 100 Hz the CoP moves well under a millimetre
    per frame, so consecutive frames are close, as in a real recording.

    Parameters
    ----------
    frames : int
        Number of frames T.
    rows, cols : int
        Mat size in cells.
    rate_hz : float
        Frame rate (Hz).
    sway_cm, freq_hz : (float, float)
        Sway amplitude per axis (cm) and the two mixed sinusoid frequencies (Hz).
    rng : numpy.random.Generator, int or None
        Seed or generator (background conductances, phases, noise).
    pitch_cm, weight_n, background_s, **geometry
        As in :func:`two_feet`.
    return_cop : bool
        Also return the (T, 2) CoP offsets in cm.

    Returns
    -------
    g : numpy.ndarray, shape (T, rows, cols)
        Cell conductances in S.
    cop_offset : numpy.ndarray, shape (T, 2)
        Only with ``return_cop``.
    """
    rows, cols = _check_shape(rows, cols)
    pitch = default_pitch(rows, cols) if pitch_cm is None else float(pitch_cm)
    gen = _as_rng(rng)
    bg = _background(rows, cols, gen, background_s)
    off = sway_trajectory(frames, rate_hz, sway_cm, freq_hz, gen)
    p0 = feet_pressure(rows, cols, pitch, weight_n=weight_n, **geometry)
    X, Y = _cell_centres(rows, cols, pitch)
    g = pressure_to_conductance(p0 * _cop_weights(p0, X, Y, off), bg)
    return (g, off) if return_cop else g


def random_array(
    rows: int,
    cols: int,
    low: float = 1e-5,
    high: float = 1e-2,
    log: bool = True,
    rng: np.random.Generator | int | None = None,
) -> np.ndarray:
    """Random cell conductances (S) in [low, high]: the thesis' Fig. 2.13 case (16×16, 1e-5…1e-2 S).

    ``log=True`` draws log-uniformly (every decade equally likely), otherwise uniformly.
    """
    rows, cols = _check_shape(rows, cols)
    if not 0 < low <= high:
        raise ValueError(f"need 0 < low <= high (S), got {low!r}, {high!r}")
    gen = _as_rng(rng)
    if log:
        return np.exp(gen.uniform(np.log(low), np.log(high), size=(rows, cols)))
    return gen.uniform(low, high, size=(rows, cols))

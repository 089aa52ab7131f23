"""Per-cell equilibration of the mat learned from one standing trial (beyond the thesis: its
chapter 3 conclusions and chapter 4 name "an equilibration or calibration step for large arrays"
as future work).

Every cell of a real mat has its own gain: the same pressure gives ``a_j·D(p)`` instead of
``D(p)`` (the twin draws log-normal gains, :class:`psmat.twin.MatPhysics`). SCHC (eq. 3.3)
fits one factor ``f`` for the whole mat and leaves the gains in; they bias the CoP toward the
high-gain cells. During a standing trial the load moves over the cells while the vertical force
stays the body weight ``W`` (or follows the platform's ``Fz(t)``), so the total force the mat
reports tells which cells are too sensitive. With ``a_j = e^{u_j}``:

    F(t; u) = Σ_j M(f · e^{-u_j} · g_j)(t) · A  ≈  W(t)

``M`` the nominal inverse sensor model run over the trial (hysteresis and creep), ``A`` the
cell area, ``g_j`` the cell conductance after IECM. The gain divides the *conductance* inside
``M`` — where the physics puts it (a cell's material and contact scale its conductance; the
twin does ``a_j·D(p) + g_rest``) — and not the pressure: ``M`` is not homogeneous, so no
constant pressure factor undoes a conductance gain over a trial whose load varies.

The fit is a ridge-penalised least squares solved by Gauss–Newton on ``u`` (gains positive by
construction), on the means over blocks of ``block_s`` seconds (the load moves at the sway's
frequencies, under ~1 Hz; the ADC noise the chain turns into force averages out):

    min_u  Σ_b (W̄_b − F̄_b(u))²  +  λ ‖u − ū·1‖²

Identified directions: ``J_bj = ∂F̄_b/∂u_j`` has the rank of the trial's load *motion*. A
combination of cells whose loads move together, or never change, enters only through the total
and stays at the prior (``u = ū``); a load that moves from cells B to cells A fixes the gain
of A relative to B. On a twin trial two modes (M-L and A-P sway) carry 98–99.9 % of the load
motion, so beyond the level about two combinations are identified. The mean ``ū`` is not
penalised: a uniform gain is ``f``'s.

``λ = σ²/τ²`` is chosen from the data alone by maximising the marginal likelihood of the first
linearisation (empirical Bayes: ``v = u − ū ~ N(0, τ²)``, block residuals ``~ N(0, σ²)``), and
kept for the Gauss–Newton steps. Generalised cross-validation and the L-curve were tried first
on development trials and rejected: the block residuals are correlated in time and carry the
chain's load-dependent errors, and both kept 15–45 effective directions (``dof``) with a worse
CoP; the marginal likelihood keeps 4–19. The map is normalised to a geometric mean of 1 over
the loaded cells and ``f`` solved again (eq. 3.3) on the equilibrated conductances ``g_j / a_j``.

What it buys, measured in simulation (``python -m psmat.experiments equilibration``): most of
the static CoP offset the gains cause goes; the mean-removed trace, which Eu and σ see, was
hardly moved by the gains and is not made better.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .. import _checks
from ..profile import default_geometry
from ..sensor import MPICreep, frame_periods
from ..units import PSI_PA
from ._scale import scale_factor, trial_cells, usable_steps

__all__ = ["Equilibration", "equilibrate"]

_EPS = 1e-4  # step in u of the finite-difference Jacobian (a 0.01 % gain change)
_STEP_TOL = 1e-4  # Gauss-Newton stops when no log-gain moves more than this


@dataclass(frozen=True)
class Equilibration:
    """A learned per-cell gain map.

    Attributes
    ----------
    gain : (R, C) array
        ``a_j``: each cell's conductance relative to the mat's typical loaded cell; exactly 1
        on cells that never carry load; geometric mean 1 over the loaded ones.
    loaded : (R, C) bool array
        The cells the map was learned on.
    factor : float
        SCHC's ``f`` (eq. 3.3) on the equilibrated conductances ``g / gain``.
    ridge : float
        ``λ`` (N²), chosen by the marginal likelihood.
    dof : float
        Effective number of directions of ``log a`` the trial identified (the trace of the
        ridge's influence matrix, ``Σ s_k² / (s_k² + λ)``, the mean direction left out).
    force_rms_n : (float, float)
        RMS of ``W̄_b − F̄_b`` over the blocks (N) with the gains at 1 and with the learned map.
    """

    gain: NDArray[np.float64]
    loaded: NDArray[np.bool_]
    factor: float
    ridge: float
    dof: float
    force_rms_n: tuple[float, float]

    def apply(self, g: ArrayLike) -> NDArray[np.float64]:
        """``f · g / gain``: the conductances (T, R, C) in S that SCHC-EQ gives the inverse model."""
        return self.factor * np.asarray(g, dtype=np.float64) / self.gain


def _weights(weight_n: float | ArrayLike | None, T: int) -> NDArray[np.float64]:
    if weight_n is None:
        raise ValueError("equilibration needs the body weight (weight_n, N) or the platform's Fz per frame")
    if np.ndim(weight_n) == 0:
        return np.full(T, _checks.positive("weight_n", weight_n))
    w = _checks.vector("weight_n", weight_n)
    if w.shape != (T,) or not np.all(np.isfinite(w) & (w > 0)):
        raise ValueError(f"weight_n must be one weight or {T} positive forces (N), one per frame; got shape {w.shape}")
    return w


def _blocks(steps: NDArray[np.float64], block_s: float) -> NDArray[np.float64]:
    """Averaging matrix (m, U): row b the mean over the usable frames of block b (by elapsed time)."""
    idx = np.floor((np.cumsum(steps) - steps[0]) / block_s).astype(np.int64)
    B = np.zeros((int(idx[-1]) + 1, steps.size))
    B[idx, np.arange(steps.size)] = 1.0
    n = B.sum(axis=1)
    return B[n > 0] / n[n > 0, None]


def _centred(J: NDArray[np.float64], r: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The problem without its uniform direction: ``u = c·1 + v``, ``c`` free (it is ``f``'s),
    so ``r`` and ``J`` are projected off ``J·1`` and ``v`` is kept off ``1``."""
    k = J.shape[1]
    Q, _ = np.linalg.qr(np.column_stack([J.sum(axis=1), np.eye(r.size)]))
    N = Q[:, 1:]  # orthonormal basis of the block space orthogonal to J·1
    return N.T @ J @ (np.eye(k) - 1.0 / k), N.T @ r


def _ridge(J: NDArray[np.float64], r: NDArray[np.float64]) -> tuple[float, float]:
    """``λ = σ²/τ²`` maximising the marginal likelihood of ``r`` under ``r = J v + e``,
    ``v ~ N(0, τ² I)``, ``e ~ N(0, σ² I)`` (σ² profiled out), on a grid of 0.05 decades; and
    the effective number of identified directions ``Σ s² / (s² + λ)``.

    ``-2 log L = m log σ̂² + Σ_i log d_i + m``, ``d_i = s_i²/λ + 1`` (``s_i`` the singular values
    of J, zero past its rank), ``σ̂² = Σ_i β_i² / (m d_i)``, ``β = Uᵀ r``.
    """
    m = r.size
    U, s, _ = np.linalg.svd(J, full_matrices=True)
    s2 = np.zeros(m)
    s2[: min(m, s.size)] = s[:m] ** 2
    beta2 = (U.T @ r) ** 2
    grid = max(float(s2.max()), np.finfo(float).tiny) * np.logspace(-12, 2, 281)
    d = s2[None, :] / grid[:, None] + 1.0
    nll = m * np.log(np.mean(beta2 / d, axis=1) + np.finfo(float).tiny) + np.sum(np.log(d), axis=1)
    lam = float(grid[int(np.argmin(nll))])
    return lam, float(np.sum(s2 / (s2 + lam)))


def _fit(forces: Callable[[NDArray[np.float64]], NDArray[np.float64]], B: NDArray[np.float64],
         Wb: NDArray[np.float64], k: int, iters: int) -> tuple[NDArray[np.float64], float, float, float, float]:
    """Gauss-Newton on the ridge-penalised cost: log-gains u (k,), λ, dof, RMS before and after (N)."""

    def linearise(u: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        Fc = forces(u)
        # the cells are independent: one run with every u_j moved gives every column
        return Wb - B @ Fc.sum(axis=1), B @ ((forces(u + _EPS) - Fc) / _EPS)

    u = np.zeros(k)
    r, J = linearise(u)
    rms0 = float(np.sqrt(np.mean(r**2)))
    lam, dof = _ridge(*_centred(J, r))
    C = np.eye(k) - 1.0 / k  # the ridge acts on u minus its mean (CᵀC = C)

    def cost(u: NDArray[np.float64], r: NDArray[np.float64]) -> float:
        return float(r @ r + lam * u @ C @ u)

    now = cost(u, r)
    for _ in range(iters):
        step = np.linalg.solve(J.T @ J + lam * C, J.T @ r - lam * (C @ u))
        for _ in range(30):  # halved until the penalised cost goes down
            r_new = Wb - B @ forces(u + step).sum(axis=1)
            if cost(u + step, r_new) < now:
                break
            step = step / 2
        else:
            break
        u, r, now = u + step, r_new, cost(u + step, r_new)
        if np.max(np.abs(step)) < _STEP_TOL:
            break
        r, J = linearise(u)
    return u, lam, dof, rms0, float(np.sqrt(np.mean(r**2)))


def equilibrate(g: ArrayLike, periods: float | ArrayLike, weight_n: float | ArrayLike | None, *,
                sensor: MPICreep | None = None, cell_area_cm2: float | None = None, block_s: float = 0.5,
                contrast: float = 100.0, max_iter: int = 20) -> Equilibration:
    """Learn the per-cell gains of a mat from one standing trial.

    Parameters
    ----------
    g : array (T, R, C)
        Cell conductances of the trial (S), after IECM; frames with NaN are missing (left out,
        the sensor model stepped over them, as :mod:`psmat.process`).
    periods : float or (T,)
        Frame period(s) (s).
    weight_n : float or (T,) array
        Body weight W (N), or the platform's vertical force on the mat's frames (N).
    sensor : MPICreep, optional
        The nominal sensor model (default the thesis' Table 2.11).
    cell_area_cm2 : float, optional
        Cell area A (cm²); default the default profile's (docs/spec.md §5 "Device profiles").
    block_s : float
        Length (s) of the blocks whose mean force is fitted: the bandwidth of the fit.
    contrast : float
        A cell carries load when its mean conductance over the trial is at least ``contrast``
        times the mat's rest level (the 10th percentile of the cells' means).
    max_iter : int
        Gauss–Newton steps at most.

    Returns
    -------
    Equilibration

    Raises
    ------
    ValueError
        No weight; no cell that carries load; a trial shorter than two blocks; bad values.
    """
    cells = trial_cells(g)
    T, n = cells.shape
    shape = np.shape(g)[1:]
    per = frame_periods(periods, T)
    w_all = _weights(weight_n, T)
    area = _checks.positive("cell_area_cm2", default_geometry().cell_area_cm2 if cell_area_cm2 is None
                            else cell_area_cm2)
    block = _checks.positive("block_s", block_s)
    ratio = _checks.positive("contrast", contrast)
    iters = _checks.positive_int("max_iter", max_iter)
    sensor = sensor or MPICreep.thesis()
    usable, steps = usable_steps(cells, per)
    if not usable.any():
        raise ValueError("g has no complete frame: nothing to equilibrate")
    x = cells[usable]
    mean_g = x.mean(axis=0)
    loaded = (mean_g > ratio * np.percentile(mean_g, 10)) & (mean_g > 0)
    if not loaded.any():
        raise ValueError(f"no cell carries load (none has a mean conductance {ratio:g}× the mat's rest level): "
                         "nothing to equilibrate")
    B = _blocks(steps, block)
    if B.shape[0] < 2:
        raise ValueError(f"the trial lasts less than two blocks of {block:g} s: nothing to fit")
    w = w_all[usable]
    f0 = scale_factor(cells.reshape((T,) + shape), per, float(np.mean(w)), sensor, area)
    xl = f0 * x[:, loaded]
    to_n = PSI_PA * area * 1e-4  # psi on one cell -> N

    def forces(u: NDArray[np.float64]) -> NDArray[np.float64]:
        """Per-cell force (U, k) in N of the loaded cells with log-gains u."""
        return sensor.inverse(xl * np.exp(-u), steps) * to_n

    u, lam, dof, rms0, rms1 = _fit(forces, B, B @ w, int(loaded.sum()), iters)
    gain = np.ones(n)
    gain[loaded] = np.exp(u - u.mean())  # a uniform gain is f's: eq. 3.3 is solved again below
    gain = gain.reshape(shape)
    f = scale_factor(cells.reshape((T,) + shape) / gain, per, float(np.mean(w)), sensor, area)
    return Equilibration(gain, loaded.reshape(shape), f, lam, dof, (rms0, rms1))

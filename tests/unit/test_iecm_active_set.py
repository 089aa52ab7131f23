"""The active-set Newton on what a mat delivers: noisy twin frames, 1 mV and 12 bits.

Every real frame is noisy, so the quiet cells end at the bound g = g_floor and the streaming
path runs the bounded (complementarity) solver of docs/spec.md §3 on every frame. The reference is the
Fischer-Burmeister bounded Newton (``method="bounded_newton"``, an independent formulation and
globalisation of the same unique solution), run here, and its solution recorded on noisy twin
frames before the active-set solver existed (tests/data/iecm_noisy_bounded.npz).
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

import psmat.iecm as iecm
from psmat import twin
from psmat.circuit import Circuit

G_FLOOR = 1e-12  # S, psmat.iecm.solve's default
RTOL = 1e-10  # psmat.iecm.solve's default stopping rule: max |phi| <= RTOL (relative to G)
# Both solvers stop at a residual <= RTOL relative to G, so a free cell is fixed to about
# RTOL * G_a / lambda, lambda the smallest eigenvalue of S on the free cells (~3e-4 on these
# frames: quiet cells of quiet rows are nearly interchangeable). Where a cell carries its own
# reading (loaded cells, g >= 1e-4 S) that is far below 1e-8 g; for a quiet cell under a
# ghost 1e5 x its own conductance it is not, and tightening RTOL stops helping near 1e-12 (the
# round-off of F). Cell by cell, free cells are therefore compared within
# 1e-8 g + AMPLIFICATION * RTOL * G; over the free cells of a frame, within 1e-8 relative.
AMPLIFICATION = 1e3


def _noisy_frames(size: int, frames: int, seed: int = 0) -> np.ndarray:
    """G (S) of a swaying-feet recording as the mat measures it: 1 mV on the ADC node, 12 bits."""
    g = twin.swaying_feet(frames, (size, size), seed=seed)
    c = Circuit()
    return c.conductance(c.counts(iecm.forward(g), noise_v=1e-3, rng=seed + 1))


def _stream(G: np.ndarray, method: str):
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)  # every frame must converge
        return iecm.solve(G, method, warm_start=True, threads=1, return_info=True, progress=False)


def _assert_same_solution(g: np.ndarray, g_ref: np.ndarray, G: np.ndarray) -> None:
    bound, bound_ref = g <= G_FLOOR * (1 + 1e-9), g_ref <= G_FLOOR * (1 + 1e-9)
    assert np.array_equal(bound, bound_ref), f"{int((bound != bound_ref).sum())} cells differ in the bound set"
    free = ~bound_ref
    # the acceptance criterion: within 1e-8 relative on the free cells, frame by frame (2-norm over the cells)
    for k in range(len(g)):
        d, r = (g[k] - g_ref[k])[free[k]], g_ref[k][free[k]]
        assert np.linalg.norm(d) <= 1e-8 * np.linalg.norm(r), (k, float(np.linalg.norm(d) / np.linalg.norm(r)))
    err = np.abs(g - g_ref)
    loaded = free & (g_ref >= 1e-4)
    assert loaded.any()
    assert np.all(err[loaded] <= 1e-8 * g_ref[loaded]), float(np.max(err[loaded] / g_ref[loaded]))
    tol = 1e-8 * g_ref + AMPLIFICATION * RTOL * G
    assert np.all(err[free] <= tol[free]), float(np.max(err[free] / tol[free]))


@pytest.mark.parametrize("size, frames", [(16, 150), (32, 6)])
def test_active_set_returns_the_fischer_burmeister_solution(size, frames):
    G = _noisy_frames(size, frames)
    g_ref, info_ref = _stream(G, "bounded_newton")
    assert np.all(info_ref.at_bound > 0)  # the noise puts quiet cells at the bound in every frame
    for method in ("active_set", "newton"):  # newton hands frames with bound cells to active_set
        g, info = _stream(G, method)
        assert np.all(info.residual <= RTOL)
        assert np.array_equal(info.at_bound, info_ref.at_bound)
        _assert_same_solution(g, g_ref, G)


@pytest.mark.parametrize("size", [16, 32])
def test_the_solution_recorded_before_the_active_set_solver(size):
    # the earlier default's solution, recorded: noisy twin frames and what bounded_newton returned
    # for them at commit 34b050e, before the active-set solver (and the forward model's later
    # round-off changes) existed; made_by in the file says how
    with np.load(Path(__file__).resolve().parents[1] / "data" / "iecm_noisy_bounded.npz") as f:
        G, g_ref = f[f"G{size}"], f[f"g{size}"]
    for method in ("active_set", "newton"):
        g, info = _stream(G, method)
        assert np.all(info.residual <= RTOL)
        _assert_same_solution(g, g_ref, G)


def test_no_noisy_frame_needs_more_than_50_iterations():
    # docs/spec.md §10: 16x16 noisy streaming, complementarity residual <= 1e-6 and no frame over 50
    # iterations. The Fischer-Burmeister fallback needed up to 133 on these frames (2 over 50).
    G = _noisy_frames(16, 150)
    g, info = _stream(G, "newton")
    assert np.all(info.converged)
    assert int(np.max(info.iterations)) <= 50
    a = (g - G_FLOOR) / G
    b = (iecm.forward(g) - G) / G
    assert float(np.max(np.hypot(a, b) - a - b)) <= 1e-6  # measured from g, not the report


def test_cold_noisy_frames_reach_the_same_solution():
    G = _noisy_frames(16, 4, seed=3)
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        g_cold, info = iecm.solve(G, "newton", warm_start=False, threads=1, return_info=True, progress=False)
        g_ref = iecm.solve(G, "bounded_newton", warm_start=False, threads=1, progress=False)
    assert np.all(info.converged)
    _assert_same_solution(g_cold, g_ref, G)

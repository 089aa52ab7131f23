"""IECM on a noisy recording from the twin (1 mV, 12 bits, 15 % cell variability): with the
default settings every frame is solved, and the solution is the one docs/spec.md §3 defines for noisy
G - the bounded (complementarity) problem - checked by its optimality conditions."""

from __future__ import annotations

import numpy as np

import psmat
from psmat.process import open_floor
from psmat.twin import PsmSource

RTOL = 1e-10  # solve()'s default stopping tolerance (relative to G)
G_FLOOR = 1e-12  # solve()'s default bound, S


def test_every_noisy_frame_is_solved_with_the_defaults():
    src = PsmSource.named("sway", 100, (16, 16), duration_s=5, seed=0)
    counts = np.stack([src.next() for _ in range(200)])
    circuit = psmat.Circuit()
    G = circuit.conductance(counts)
    G = np.where(np.isnan(G), open_floor(circuit), G)
    g, info = psmat.iecm.solve(G, threads=1, progress=False, return_info=True)  # no warning (pytest: error)
    assert info.all_converged and set(np.unique(info.status)) <= {"converged", "bounded"}
    assert np.all(info.residual <= RTOL)
    # KKT conditions of the bounded problem (docs/spec.md §3), cell by cell, with the forward model
    # evaluated here: g >= g_floor, F(g) >= G, and (g - g_floor)(F(g) - G) = 0
    b = psmat.iecm.forward(g) / G - 1
    free = g > G_FLOOR * (1 + 1e-9)
    assert np.all(g >= G_FLOOR)
    assert np.abs(b[free]).max() <= 10 * RTOL  # free cells reproduce the measurement
    assert b[~free].min() >= -10 * RTOL  # cells at the bound: over-predicted even when empty
    assert np.array_equal(info.at_bound, (~free).sum(axis=(1, 2)))
    # the recording is noisy (quiet cells at the bound in every frame) and loaded (free cells)
    assert np.all(info.at_bound > 0) and free.mean() > 0.3

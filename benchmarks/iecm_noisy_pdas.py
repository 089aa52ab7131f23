"""Noisy 16×16 streaming: a primal-dual active-set (PDAS) semismooth Newton prototype beside
psmat's Fischer-Burmeister ``bounded_newton`` (the earlier default; a measurement record).

``python benchmarks/iecm_noisy_pdas.py [--frames 60] [--size 16]``, from a source checkout (not
shipped in the wheel; psmat's own benchmarks are ``python -m psmat.bench``). The frames are those
of ``python -m psmat.bench iecm``'s noisy rows (:func:`psmat.bench.iecm_setup.scene`).

PDAS on the complementarity problem of docs/spec.md §3 with the min function, in the scaled variables
of ``solve_bounded_newton.cpp`` (a = (g - g_floor)/G, b = (F(g) - G)/G): each iteration takes the
bound set A = {a <= b}, sets dg_A = g_floor - g_A and solves J_II dg_I = -(F - G)_I - J_IA dg_A
with the dense analytic Jacobian (NumPy), then an Armijo line search on the Fischer-Burmeister
merit. Prints the Newton iterations per frame of both solvers, how many bound cells differ, and
for the first frames the accepted step lengths, the size of A and max |phi| per iteration —
the record that the warm start's first iterations are cut to steps of ~1e-3…1e-1.
"""

from __future__ import annotations

import argparse
import warnings

import numpy as np

import psmat.iecm as iecm
from psmat.bench.iecm_setup import scene

G_FLOOR = 1e-12  # S, psmat.iecm.solve's default


def _forward(g: np.ndarray, n: int) -> np.ndarray:
    return iecm.forward(g.reshape(n, n)).ravel()


def _phi(g: np.ndarray, G: np.ndarray, Gm: np.ndarray) -> np.ndarray:
    a, b = (g - G_FLOOR) / G, (Gm - G) / G
    return np.hypot(a, b) - a - b


def pdas_frame(g: np.ndarray, G: np.ndarray, n: int, max_iter: int = 60, rtol: float = 1e-10):
    """One frame from the warm start g (flat, S); (solution, iterations, [(t, |A|, max|phi|)])."""
    Gm = _forward(g, n)
    hist = []
    for it in range(max_iter):
        ph = _phi(g, G, Gm)
        if np.abs(ph).max() <= rtol:
            return g, it, hist
        merit = 0.5 * ph @ ph
        a, b = (g - G_FLOOR) / G, (Gm - G) / G
        A = a <= b
        idx = np.flatnonzero(~A)
        J = iecm.jacobian(g.reshape(n, n))
        dg = np.zeros_like(g)
        dg[A] = G_FLOOR - g[A]
        dg[idx] = np.linalg.solve(J[np.ix_(idx, idx)], -(Gm - G)[idx] - J[np.ix_(idx, np.flatnonzero(A))] @ dg[A])
        t = 1.0
        for _ in range(30):
            gt = np.maximum(g + t * dg, G_FLOOR)
            Gt = _forward(gt, n)
            pt = _phi(gt, G, Gt)
            if 0.5 * pt @ pt <= (1 - 1e-4 * t) * merit:
                break
            t *= 0.5
        g, Gm = gt, Gt
        hist.append((t, int(A.sum()), float(np.abs(ph).max())))
    return g, max_iter, hist


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--frames", type=int, default=60, help="frames of the noisy recording (default: 60)")
    p.add_argument("--size", type=int, default=16, help="array size N, an N x N mat (default: 16)")
    a = p.parse_args()
    n = a.size
    _, G = scene(n, a.frames, 0, noise_v=1e-3)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        g_ref, info = iecm.solve(G, "bounded_newton", warm_start=True, threads=1, return_info=True, progress=False)
    its, diffs = [], 0
    g = g_ref[0].ravel().copy()
    for t in range(1, a.frames):
        g, it, hist = pdas_frame(g, G[t].ravel(), n)
        its.append(it)
        diffs += int(((g <= G_FLOOR * (1 + 1e-9)) != (g_ref[t].ravel() <= G_FLOOR * (1 + 1e-9))).sum())
        if t <= 3:
            print(f"frame {t}: " + ", ".join(f"t={s:.3g} |A|={k} {r:.0e}" for s, k, r in hist))
    print(f"PDAS iterations mean {np.mean(its):.1f} max {max(its)}; bound cells differing from bounded_newton: {diffs}")
    print(f"bounded_newton iterations mean {info.iterations[1:].mean():.1f} max {info.iterations[1:].max()}")


if __name__ == "__main__":
    main()

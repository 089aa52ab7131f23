"""psmat's noisy streaming against the thesis' quick fixed point in NumPy, for
:mod:`psmat.bench.iecm`: the ratio of their frames/s and the project's goal for it (docs/spec.md §10).

The quick fixed point is eq. 2.10, ``g <- g + β (G - F(g))`` with β = 0.05 for 25 iterations,
cold from ``g0 = G`` on every frame (:func:`psmat.bench.iecm_baselines.measure_quick_fixed_point_numpy`).
The ratio compares total frames/s on the same machine and the same noisy frames: psmat on its
threads, NumPy in one process with its BLAS left free to use the cores.
"""

from __future__ import annotations

import math

__all__ = ["QUICK_BETA", "QUICK_ITERATIONS", "NUMPY_QUICK_GOALS", "speedup_over_numpy"]

QUICK_BETA = 0.05      # damping of the thesis' quick fixed point
QUICK_ITERATIONS = 25  # its iterations per frame
# docs/spec.md §10: size -> the least ratio of psmat's noisy streaming frames/s to the NumPy quick
# fixed point's, both in total on the same machine.
NUMPY_QUICK_GOALS = {32: 5.0}


def speedup_over_numpy(psmat_row: dict, numpy_row: dict) -> dict:
    """How many times the NumPy quick fixed point's frames/s psmat's noisy streaming row reaches.

    Parameters
    ----------
    psmat_row : dict
        psmat's noisy streaming row of one size (:func:`psmat.bench.iecm_setup.row`; ``fps`` in
        frames/s, all its threads together).
    numpy_row : dict
        The NumPy quick fixed point's row of the same size, on the same noisy frames.

    Returns
    -------
    dict
        ``size``; ``basis`` ("total": frames/s of each row as a whole, not per core);
        ``psmat_fps``, ``psmat_threads``, ``numpy_fps`` (frames/s); ``ratio`` (psmat / NumPy,
        NaN where either rate is missing); ``goal`` (the least ratio docs/spec.md §10 asks at this
        size, or None) and ``goal_met`` (None without a goal; False where the ratio is NaN);
        ``line``, the sentence the benchmark prints.

    Raises
    ------
    ValueError
        If the rows are of different sizes or either is not on noisy G.
    """
    size = psmat_row["size"]
    if numpy_row["size"] != size:
        raise ValueError(f"the rows must be of one size, got {size} and {numpy_row['size']}")
    if not (psmat_row["noise_v"] > 0 and numpy_row["noise_v"] > 0):
        raise ValueError("both rows must be on noisy G (noise_v > 0)")
    p, n = float(psmat_row["fps"]), float(numpy_row["fps"])
    ok = math.isfinite(p) and math.isfinite(n) and p > 0 and n > 0
    ratio = p / n if ok else float("nan")
    goal = NUMPY_QUICK_GOALS.get(size)
    goal_met = None if goal is None else bool(ok and ratio >= goal)

    def fps(x: float) -> str:
        return f"{x:.4g} fps" if math.isfinite(x) else "n/a"

    what = (f"the NumPy quick fixed point (β {QUICK_BETA:g}, {QUICK_ITERATIONS} it), total frames/s: "
            f"{fps(p)} (psmat, {psmat_row['threads']} thread(s)) against {fps(n)} (NumPy, batched, one process)")
    line = (f"{size}x{size}: psmat newton noisy streaming is {ratio:.2f}× {what}" if ok
            else f"{size}x{size}: psmat newton noisy streaming against {what}: no ratio")
    if goal is not None:
        line += f"; goal >= {goal:g}×: {'met' if goal_met else 'MISSED'}"
    return dict(size=size, basis="total", psmat_fps=p, psmat_threads=psmat_row["threads"], numpy_fps=n,
                ratio=ratio, goal=goal, goal_met=goal_met, line=line)

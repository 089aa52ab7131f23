"""SWARII (docs/spec.md §7, psmat.balance's preprocessing) against its definition written out
sample by sample, on irregular times: windows with one sample, many, none, and overlapping."""

from __future__ import annotations

import numpy as np
import pytest

from psmat.balance._preprocess import swarii


def _by_definition(t: np.ndarray, x: np.ndarray, rate_hz: float, window_s: float) -> np.ndarray:
    """At each output time τ = t0 + k/rate: the samples strictly inside (τ − w/2, τ + w/2), each
    weighted by the part of the window (clipped to [t0, t_last]) nearer to it than to the other
    samples inside; a lone sample its own value; empty windows interpolated linearly afterwards."""
    t0, t1 = float(t[0]), float(t[-1])
    grid = [t0 + k / rate_hz for k in range(int(np.floor((t1 - t0) * rate_hz + 1e-9)) + 1)]
    values: list[np.ndarray | None] = []
    for tau in grid:
        inside = [i for i in range(len(t)) if tau - window_s / 2 < t[i] < tau + window_s / 2]
        if not inside:
            values.append(None)
            continue
        lo, hi = max(t0, tau - window_s / 2), min(t1, tau + window_s / 2)
        total, weight = np.zeros(x.shape[1:]), 0.0
        for n, i in enumerate(inside):
            left = lo if n == 0 else (t[i - 1] + t[i]) / 2
            right = hi if n == len(inside) - 1 else (t[i] + t[i + 1]) / 2
            total = total + (right - left) * x[i]
            weight += right - left
        values.append(x[inside[0]] if len(inside) == 1 else total / weight)
    known = [k for k, v in enumerate(values) if v is not None]
    table = np.array([values[k] for k in known]).reshape(len(known), -1)
    filled = np.column_stack([np.interp(grid, [grid[k] for k in known], table[:, j]) for j in range(table.shape[1])])
    return filled.reshape((len(grid),) + x.shape[1:])


@pytest.mark.parametrize("rate_in, window_s, columns", [
    (100.0, 1 / 25, 2),  # the mat through the preset: ~4 samples per window
    (10.0, 1 / 25, 2),  # slower than the output: many empty windows, lone samples
    (40.0, 0.3, 0),  # overlapping windows, one-dimensional values
    (1000.0, 1 / 25, 3),  # ~40 samples per window
])
def test_swarii_is_its_definition_on_irregular_times(rate_in: float, window_s: float, columns: int) -> None:
    rng = np.random.default_rng(int(rate_in))
    n = int(4.0 * rate_in)
    t = 3.0 + np.cumsum(rng.uniform(0.1, 1.9, n) / rate_in)  # jittered clock, gaps up to ~2 periods
    t[n // 2:] += 5.0 / rate_in  # and one long gap
    x = rng.normal(scale=3.0, size=(n, columns) if columns else n)
    grid, y = swarii(t, x, 25.0, window_s)
    expected = _by_definition(t, x, 25.0, window_s)
    np.testing.assert_allclose(grid, t[0] + np.arange(len(grid)) / 25.0, rtol=0, atol=1e-12)
    assert y.shape == expected.shape
    np.testing.assert_allclose(y, expected, rtol=1e-12, atol=1e-12)

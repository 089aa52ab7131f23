"""Benchmarks of psmat's kernels against baselines run in the same process (docs/spec.md §10).

Run ``python -m psmat.bench --help``. Modules:

* :mod:`psmat.bench.iecm` — IECM frames/s and accuracy on swaying-feet recordings of
  16×16, 32×32 and 64×64 mats, streaming and cold start, beside the thesis' approach;
* :mod:`psmat.bench.baseline_numpy` — that approach in plain NumPy/SciPy
  (``scipy.optimize.least_squares`` with a numerical Jacobian, fixed point β = 0.05), also
  an independent cross-check of the forward model for the tests.
* :mod:`psmat.bench.sensor` — the sensor model's throughput and identification
  (``python -m psmat.bench sensor --seed K``);
* :mod:`psmat.bench.acquire` — acquisition through the pty twin, and a corrupted link
  against a thesis-style reader.

Importing this package is cheap: it imports neither SciPy nor the C++ core.
"""

__all__ = ["baseline_numpy", "iecm"]

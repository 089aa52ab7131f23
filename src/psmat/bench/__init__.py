"""Benchmarks of psmat's kernels against baselines run in the same process (docs/spec.md §10).

An application: one entry point, ``python -m psmat.bench BENCHMARK`` (also ``psmat bench``);
``python -m psmat.bench --help`` lists the benchmarks (:data:`psmat.bench.__main__.BENCHMARKS`).
Nothing in psmat's library imports this package. Each benchmark is one module with
``build_parser(prog)`` and ``main(argv, prog)``:

* :mod:`psmat.bench.iecm` — IECM frames/s and accuracy on swaying-feet recordings of
  16×16, 32×32 and 64×64 mats, streaming and cold start, beside the thesis' approach
  (its parts: ``iecm_setup`` frames and rows, ``iecm_baselines`` the baselines' rows,
  ``iecm_speedup`` psmat against the NumPy quick fixed point, ``iecm_report`` the table,
  ``iecm_native`` two builds side by side);
* :mod:`psmat.bench.sensor` — the sensor model's throughput and identification;
* :mod:`psmat.bench.acquire` — acquisition through the pty twin, and a corrupted link
  against a thesis-style reader;
* :mod:`psmat.bench.study` — a thesis-size simulated balance study end to end.
* :mod:`psmat.bench.import_cost` (``python -m psmat.bench import``) — the time of
  ``import psmat`` and ``psmat --help`` beside ``import numpy``, in fresh processes.
* :mod:`psmat.bench.lab` — the lab page in headless Chromium (frames drawn/s, latency,
  server CPU while recording; its browser side in ``lab_page``) beside the matplotlib view,
  driven through :mod:`psmat.bench.chromium` (a small DevTools client, also the tests').

:mod:`psmat.bench.baselines` holds the independent re-implementations the benchmarks time
beside psmat (NumPy/SciPy IECM, the NumPy sensor model, the thesis-style reader);
:mod:`psmat.bench.machine` describes the machine a run was on.

Importing this package is cheap: it imports neither SciPy nor the C++ core.
"""

__all__: list[str] = []

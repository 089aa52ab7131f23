"""The dense IECM kernels in every vector unit the build has and the CPU runs (docs/spec.md §10;
the C++ core's simd.hpp): the same noisy stream solved with the kernels capped by ``PSMAT_SIMD``
gives the same cells, each child reports the unit it used, and ``python -m psmat.bench iecm
--compare-simd`` measures the units side by side in children of this interpreter."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np

# One noisy 32x32 stream (1 mV, 12 bits: most background cells at the bound, free blocks split
# into core and fringe), solved in a child whose kernels PSMAT_SIMD caps.
_CHILD = """
import json, sys
import numpy as np
import psmat._core as core
import psmat.iecm as iecm
from psmat.bench.iecm_setup import scene
g_true, G = scene(32, 12, 3, noise_v=1e-3)
g, info = iecm.solve(G, "newton", return_info=True, threads=1)
np.save(sys.argv[1], g)
print(json.dumps({"simd": core.iecm.simd_kernels(), "iterations": [int(x) for x in info.iterations],
                  "residual": float(np.max(info.residual))}))
"""


def _env(cap: str | None) -> dict:
    env = {k: v for k, v in os.environ.items() if k != "PSMAT_SIMD"}
    if cap is not None:
        env["PSMAT_SIMD"] = cap
    return env


def _solve(cap: str | None, out: Path) -> dict:
    r = subprocess.run([sys.executable, "-c", _CHILD, str(out)], env=_env(cap), capture_output=True, text=True,
                       timeout=300)
    assert r.returncode == 0, r.stderr[-2000:]
    return json.loads(r.stdout.strip().splitlines()[-1])


def _unit_name(cap: str | None) -> str:
    r = subprocess.run([sys.executable, "-c", "import psmat._core as c; print(c.iecm.simd_kernels())"],
                       env=_env(cap), capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    return r.stdout.strip()


def test_every_vector_unit_solves_the_same_noisy_stream(tmp_path):
    widest = _solve(None, tmp_path / "widest.npy")
    capped = _solve("avx2", tmp_path / "avx2.npy")
    base = _solve("baseline", tmp_path / "baseline.npy")
    # what each child ran: the cap holds; without one, the widest unit (avx512 on a CPU with it)
    assert base["simd"] in ("baseline", "native")  # (native: a PSMAT_NATIVE build has no units)
    assert capped["simd"] in ("avx2", base["simd"])
    assert widest["simd"] in ("avx512", "avx2", "baseline", "native")
    assert widest["simd"] not in ("baseline", "native") or capped["simd"] == widest["simd"]
    # float32 preconditioners of another vector width round differently; the solutions agree far
    # below the noise (each stops at the solver's residual <= 1e-10)
    g = {k: np.load(tmp_path / f"{k}.npy") for k in ("widest", "avx2", "baseline")}
    for name, res in (("widest", widest), ("avx2", capped), ("baseline", base)):
        assert res["residual"] <= 1e-10, (name, res)
    loaded = g["baseline"] >= 1e-4  # S
    assert loaded.sum() > 100
    for k in ("widest", "avx2"):
        rel = np.abs(g[k] - g["baseline"])[loaded] / g["baseline"][loaded]
        assert rel.max() < 1e-7, (k, rel.max())
        assert np.abs(g[k] - g["baseline"]).max() < 1e-9  # S, the background cells too


def test_bench_compare_simd_measures_each_unit_in_its_own_child(tmp_path):
    cmd = [sys.executable, "-m", "psmat.bench", "iecm", "--compare-simd", "--sizes", "8", "--frames", "8",
           "--repeats", "1", "--quick"]
    r = subprocess.run(cmd, cwd=tmp_path, env=_env(None), capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr[-2000:]
    lines = r.stdout.splitlines()
    capped = next(line for line in lines if line.startswith("PSMAT_SIMD=avx2: "))
    widest = next(line for line in lines if line.startswith("widest: "))
    assert capped.split("dense kernels: ")[1] == _unit_name("avx2")
    assert widest.split("dense kernels: ")[1] == _unit_name(None)
    rows = [line for line in lines if line.startswith("| 8x8 |")]
    assert len(rows) == 2 and "noisy G" in rows[1], r.stdout
    iters = rows[1].split("|")[-3].strip().split(" / ")  # the same work in both
    assert len(iters) == 2 and iters[0] == iters[1], rows[1]
    # with --compare-native too: refused in one line
    both = subprocess.run(cmd + ["--compare-native", sys.executable, sys.executable], cwd=tmp_path, env=_env(None),
                          capture_output=True, text=True, timeout=120)
    assert both.returncode == 2 and "one comparison at a time" in both.stderr

"""``python -m psmat.bench lab`` with its smallest settings: the report's structure, never its figures."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import numpy as np
import pytest
from chromium import chromium_or_skip

from psmat.bench.lab import percentile

pytest.importorskip("starlette", reason="psmat lab needs the lab extra (starlette, uvicorn)")
pytest.importorskip("uvicorn", reason="psmat lab needs the lab extra (starlette, uvicorn)")
pytest.importorskip("psutil", reason="the benchmark reads process CPU times with psutil (the test extra)")

COLUMNS = ["display", "mat Hz", "drawn/s", "arrival ms", "p95 ms", "n", "to drawn ms", "server/view CPU %",
           "browser CPU %", "recorded", "rec. Hz"]


def _bench(*args: str, env: dict | None = None, timeout: float = 300.0) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "psmat.bench", "lab", *args], capture_output=True, text=True,
                          timeout=timeout, env=env, check=False)


def test_the_lab_benchmark_reports_both_displays_at_each_rate(tmp_path) -> None:
    chromium_or_skip()
    out = tmp_path / "lab.json"
    proc = _bench("--rates", "100,165", "--seconds", "1", "--warmup", "0.5", "--json", str(out))
    assert proc.returncode == 0, proc.stderr
    lines = proc.stdout.splitlines()
    header = next(i for i, line in enumerate(lines) if line.startswith("display "))
    assert all(c in lines[header] for c in COLUMNS)
    # one row per display and rate: the page's, then matplotlib's, at 100 then 165 Hz
    rows = [(line[:11].strip(), line[11:].split()[0]) for line in lines[header + 1:header + 5]]
    assert rows == [("lab page", "100"), ("matplotlib", "100"), ("lab page", "165"), ("matplotlib", "165")]
    data = json.loads(out.read_text())
    assert [(r["display"], r["rate_hz"]) for r in data["rows"]] == [
        ("lab page", 100.0), ("matplotlib", 100.0), ("lab page", 165.0), ("matplotlib", 165.0)]
    for r in data["rows"]:
        assert r["seconds"] >= 1.0 and r["drawn_per_s"] > 0  # it drew; how fast is not a test's business
        if r["display"] == "lab page":
            assert r["latency_samples"] > 0 and r["latency_median_ms"] <= r["latency_p95_ms"]
            assert r["recorded_frames"] > 0 and r["server_cpu_pct"] >= 0 and r["browser_cpu_pct"] >= 0
            assert set(r["server_rates"]) >= {"received_hz", "displayed_hz"}
        else:
            assert r["process_cpu_pct"] >= 0 and "latency_samples" not in r
    assert not list(tmp_path.glob("*.h5")), "the benchmark records into a temporary folder of its own"


def test_without_a_browser_it_says_so_in_one_line(tmp_path) -> None:
    env = {**os.environ, "PSMAT_CHROMIUM": str(tmp_path / "no-such-browser")}
    proc = _bench("--rates", "100", "--seconds", "1", env=env, timeout=120)
    assert proc.returncode == 1 and proc.stdout == ""
    assert proc.stderr.count("\n") == 1 and "no Chromium" in proc.stderr


@pytest.mark.parametrize("bad", ["0", "100,x", "12.5", ""])
def test_a_bad_rate_list_is_one_line(bad) -> None:
    proc = _bench("--rates", bad, timeout=120)
    assert proc.returncode == 2 and "--rates" in proc.stderr.splitlines()[-1]


def test_percentile_agrees_with_numpy() -> None:
    rng = np.random.default_rng(5)
    for n in (1, 2, 7, 100):
        xs = list(rng.normal(size=n))
        for q in (0, 5, 50, 95, 100):
            assert percentile(xs, q) == pytest.approx(np.percentile(xs, q), rel=1e-12, abs=1e-12)
    assert np.isnan(percentile([], 50))

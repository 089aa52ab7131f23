"""The balance-study benchmark end to end on a tiny simulated study (its figures are not
checked: no test asserts a time; what it runs and compares is)."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys

import pytest

from psmat.bench.study import format_report, main, parallel_fraction, run
from psmat.bench.study_scaling import fit_serial_parallel, format_scaling, parse_counts
from psmat.study import DEFAULT_PARAMS


def test_the_benchmark_runs_both_ways_and_the_rerun_reuses_every_session(tmp_path) -> None:
    r = run(volunteers=1, seconds=4.0, rate_hz=50.0, workers=1, seed=3, study_dir=str(tmp_path / "study"))
    assert r["sessions"] == 3 and r["frames"] == 3 * 200
    assert r["psmat_report"] == {"computed": 3, "reused": 0, "failed": 0}
    assert r["resume_computed"] == 0
    # the baseline ran the same per-session function over the same sessions: FP + every variant
    assert r["baseline_rows"] == 3 * (1 + len(DEFAULT_PARAMS["variants"]))
    text = format_report(r)
    assert "600 frames" in text and "multiprocessing.Pool" in text and "extrapolated" in text
    # each stage from the run's own results/timings.csv, and the serial part beside the run
    assert {"discover", "sessions", "after_sessions", "figures", "report"} <= set(r["stages"])
    assert r["stages"]["sessions"]["cpu_s"] > 0 and r["resume_stages"]["sessions"]["cpu_s"] == 0
    assert text.count("serial part (all but the session tasks)") == 2 and "after the sessions" in text
    assert text.count("parallel fraction") == 1  # the first run only: the rerun has no session work
    # the order replayed on the run's 3 session times, at 2, 4, 8 and 16 workers
    order = r["order"]
    assert order["sessions"] == 3 and [row["workers"] for row in order["rows"]] == [2, 4, 8, 16]
    for row in order["rows"]:
        # no order beats the even split, and the longest first with the times known is the best of them here
        assert row["even split (bound)"] <= row["longest first (times known)"] + 1e-12
        assert row["longest first (times known)"] <= min(row["largest file first"], row["most work first"]) + 1e-12
    # 3 sessions on 4 or more workers: each its own worker, whatever the order: the longest one's time
    ends = {row[k] for row in order["rows"][1:] for k in row if k not in ("workers", "even split (bound)")}
    assert len(ends) == 1 and ends.pop() > 0
    assert "order of the sessions, replayed" in text
    # a second benchmark run reuses the simulated study in --dir instead of simulating again
    again = run(volunteers=1, seconds=4.0, rate_hz=50.0, workers=1, seed=3, study_dir=str(tmp_path / "study"),
                baseline=False)
    assert again["simulate_s"] is None and "baseline_s" not in again


def test_quick_runs_a_tiny_study_and_writes_its_stages(tmp_path, capsys) -> None:
    out = tmp_path / "bench.json"
    assert main(["--quick", "--no-baseline", "--json", str(out)]) == 0
    r = json.loads(out.read_text(encoding="utf-8"))
    assert (r["volunteers"], r["seconds"], r["rate_hz"], r["workers"], r["sessions"]) == (1, 4.0, 50.0, 1, 3)
    assert r["psmat_report"]["computed"] == 3 and "baseline_s" not in r
    assert "serial part" in capsys.readouterr().out


def test_the_first_session_and_the_tail_by_hand(tmp_path) -> None:
    from psmat.bench.study_scaling import session_spread

    path = tmp_path / "session_timings.csv"
    head = "subject,trial,stem,result,start_s,wall_s,cpu_s,pid,worker\n"
    # pid 11 runs 1.5-3.5 then 3.5-6.0; pid 12 runs 1.2-4.2; a reused session has no times
    path.write_text(head + "V1,a,V1_a,computed,1.5,2.0,2.0,11,\nV1,b,V1_b,computed,3.5,2.5,2.5,11,\n"
                    "V2,a,V2_a,computed,1.2,3.0,3.0,12,\nV2,b,V2_b,reused,,,,,\n")
    assert session_spread(path) == pytest.approx((1.2, 6.0 - 4.2))
    # on a cluster the worker's address tells them apart (two workers may share a pid number)
    path.write_text(head + "V1,a,V1_a,computed,0.5,1.0,1.0,7,tcp://a:1\nV1,b,V1_b,computed,0.5,2.0,2.0,7,tcp://b:1\n")
    assert session_spread(path) == pytest.approx((0.5, 1.0))
    path.write_text(head + "V2,b,V2_b,reused,,,,,\n")
    assert session_spread(path) is None


def test_each_workers_first_session_and_its_second_by_hand(tmp_path) -> None:
    from psmat.bench.study_scaling import first_and_second_cpu

    path = tmp_path / "session_timings.csv"
    head = "subject,trial,stem,result,start_s,wall_s,cpu_s,pid,worker\n"
    # pid 11: 2.0 s CPU first (started 1.5), then 1.0, then 1.5; pid 12: 3.0 s then 2.5; out of order
    path.write_text(head + "V1,b,V1_b,computed,3.5,1.0,1.0,11,\nV1,a,V1_a,computed,1.5,2.0,2.0,11,\n"
                    "V2,a,V2_a,computed,1.2,3.0,3.0,12,\nV1,c,V1_c,computed,4.5,1.5,1.5,11,\n"
                    "V2,c,V2_c,computed,4.2,2.5,2.5,12,\nV2,b,V2_b,reused,,,,,\n")
    assert first_and_second_cpu(path) == pytest.approx((2.5, 1.75, 2))  # (2 + 3) / 2 and (1 + 2.5) / 2
    path.write_text(head + "V1,a,V1_a,computed,0.5,1.0,1.25,7,tcp://a:1\nV1,b,V1_b,computed,0.5,2.0,2.75,7,tcp://b:1\n")
    first, second, n = first_and_second_cpu(path)  # two workers of one session each: no second
    assert first == pytest.approx(2.0) and second is None and n == 2
    path.write_text(head + "V2,b,V2_b,reused,,,,,\n")
    assert first_and_second_cpu(path) is None


def test_the_replayed_finish_by_hand() -> None:
    from psmat.bench.study_order import finish

    # 5, 4, 3, 3, 3 s on 2 workers taking the next as each is free: A 5, B 4; B takes 3 (7), A 3 (8),
    # B 3 (10); the last ends at 10. Longest first is the best possible here ((5+4+3+3+3)/2 = 9 needs a
    # split no order of these reaches: {5, 4} and {3, 3, 3})
    assert finish([5, 4, 3, 3, 3], 2) == 10
    assert finish([3, 3, 3, 4, 5], 2) == 11  # the long ones last: 3 3 | 3 (6) 4 (7) | 5 (11)
    assert finish([5, 4, 3, 3, 3], 5) == 5 and finish([], 3) == 0


def test_the_parallel_fraction_by_hand() -> None:
    # 80 CPU s of session work and a 10 s serial part: one core would take 90 s, 80 of them parallel
    assert parallel_fraction(80.0, 10.0) == pytest.approx(80.0 / 90.0)
    assert parallel_fraction(80.0, 0.0) == pytest.approx(1.0)  # nothing serial
    assert parallel_fraction(0.0, 5.0) is None  # no session work: nothing to estimate


# --- strong scaling: --scaling N1,N2,... (psmat.bench.study_scaling) ---------------------------------

ROW = re.compile(r"^\| (pool|Dask LocalCluster) \| (\d+) \| ([\d.]+) \| ([\d.]+|—) \| ([\d.]+) \| ([\d.]+) \| "
                 r"([\d.]+) \| ([\d.]+) % \|$", re.M)


def _scaling(args: list[str], tmp_path) -> tuple[str, dict]:
    """``python -m psmat.bench study --quick ARGS --json`` in a fresh process: its stdout and JSON."""
    out = tmp_path / "scaling.json"
    proc = subprocess.run([sys.executable, "-m", "psmat.bench", "study", "--quick", *args, "--json", str(out)],
                          capture_output=True, text=True, timeout=300, check=False, cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr[-3000:]
    return proc.stdout, json.loads(out.read_text(encoding="utf-8"))


def _ratio_tol(a: float, b: float) -> float:
    """How far a / b can be from the ratio of the unrounded values, a and b printed to 0.01."""
    return 0.005 / b + a * 0.005 / b**2 + 1e-9


def _check_rows(text: str, kind: str, counts: list[int]) -> list[tuple[int, float]]:
    """The printed rows of ``kind``: their speed-up and efficiency recomputed by hand from the
    printed wall times (to the printed rounding), the serial share from the printed serial part."""
    rows = [m for m in ROW.finditer(text) if m.group(1) == kind]
    assert [int(m.group(2)) for m in rows] == counts, text
    first_n, first_t = counts[0], float(rows[0].group(3))
    for m in rows:
        n, wall, serial = int(m.group(2)), float(m.group(3)), float(m.group(7))
        speedup = first_t / wall
        tol = _ratio_tol(first_t, wall)
        assert float(m.group(5)) == pytest.approx(speedup, abs=tol + 0.005)
        assert float(m.group(6)) == pytest.approx(speedup / (n / first_n), abs=tol / (n / first_n) + 0.005)
        assert 0 <= serial <= wall + 0.01
        assert float(m.group(8)) == pytest.approx(100 * serial / wall, abs=100 * _ratio_tol(serial, wall) + 0.05)
    return [(int(m.group(2)), float(m.group(3))) for m in rows]


def test_scaling_runs_each_count_from_scratch_with_the_same_metrics(tmp_path) -> None:
    text, r = _scaling(["--scaling", "2,1"], tmp_path)  # given out of order: run smallest first
    rows = _check_rows(text, "pool", [1, 2])
    # each run said as it ended, before the table: a benchmark stopped half-way keeps its runs
    done = re.findall(r"^run done: pool, (\d+) workers?: ([\d.]+) s wall, .* 3 sessions computed; first session at "
                      r"([\d.]+) s, the workers' last sessions ended ([\d.]+) s apart$", text, re.M)
    assert [(int(n), float(t)) for n, t, _, _ in done] == rows and text.index("run done") < text.index("| run |")
    for (n, t, first, apart), run_ in zip(done, r["scaling"]["runs"]):
        assert 0 < float(first) < float(t) and (run_["first_session_s"], run_["tail_s"]) == pytest.approx(
            (float(first), float(apart)), abs=0.006)
        if n == "1":
            assert float(apart) == 0  # one worker: nothing to be apart from
    s = r["scaling"]
    assert s["counts"] == [1, 2] and r["workers"] is None and "baseline_s" not in r and "resume_s" not in r
    # every run computed every session: nothing reused from the run before it
    assert [(x["workers"], x["computed"], x["reused"], x["failed"]) for x in s["runs"]] == [(1, 3, 0, 0), (2, 3, 0, 0)]
    # the JSON's times are the printed ones, and its speed-up is the ratio of its own times
    assert [(x["workers"], round(x["wall_s"], 2)) for x in s["runs"]] == rows
    one, two = s["runs"]
    assert two["speedup"] == pytest.approx(one["wall_s"] / two["wall_s"]) and two["efficiency"] == pytest.approx(
        two["speedup"] / 2)
    # the CPU column is timings.csv's stages summed; one worker runs everything in this process, whose CPU
    # time cannot much exceed its wall time (a figure drawn here counted twice made it ~1.8x)
    assert one["cpu_s"] == pytest.approx(sum(st["cpu_s"] for st in one["stages"].values()))
    assert 0 < one["cpu_s"] <= 1.5 * one["wall_s"]
    # metrics.csv the same bytes, said so
    assert s["metrics_identical"] and one["metrics_sha256"] == two["metrics_sha256"] and s["problems"] == []
    assert "metrics.csv byte-identical across all 2 runs" in text and "problem:" not in text
    # two counts: the fit through both is exact, T(n) = S + P/n at n = 1 and 2 (by hand)
    p = 2 * (one["wall_s"] - two["wall_s"])
    assert s["pool_fit"]["parallel_s"] == pytest.approx(p) and s["pool_fit"]["serial_s"] == pytest.approx(
        one["wall_s"] - p)
    assert "pool: least-squares fit T(n) = S + P/n: S = " in text
    # the session tasks' CPU per session: the session stage's CPU over the sessions it computed
    # and a worker's first session beside its second (3 sessions on at most 2 workers: some worker
    # ran two), as the JSON has them
    part = r"([\d.]+) s \((\d+) process(?:es)?; a worker's first session ([\d.]+) s, its second ([\d.]+) s\)"
    m = re.search(rf"^the session tasks' CPU time per session \(s, in their workers\): pool 1: {part}, "
                  rf"pool 2: {part}$", text, re.M)
    assert m, text
    for run_, (shown, procs, first, second) in zip((one, two), (m.groups()[:4], m.groups()[4:])):
        assert float(shown) == pytest.approx(run_["stages"]["sessions"]["cpu_s"] / 3, abs=0.006)
        assert (float(first), float(second)) == pytest.approx((run_["first_cpu_s"], run_["second_cpu_s"]), abs=0.006)
        assert 0 < run_["first_cpu_s"] and 0 < run_["second_cpu_s"]
        # the processes that ran sessions: at most the run's workers (none replaced in so short a run)
        assert int(procs) == run_["processes"] and 1 <= run_["processes"] <= run_["workers"]
    # the load probe, before the runs: one session in 1 and then 2 processes at once, its ceiling the
    # ratio of the two medians (by hand), printed before the first run and again under the table
    load = s["load"]
    assert load["session"].endswith("V01_left-leg.h5") and [x["processes"] for x in load["runs"]] == [1, 2]
    # (whether the two ran at once depends on this machine's load: the flag is tested below by hand)
    assert all(1 <= x["distinct_processes"] <= x["processes"] for x in load["runs"])
    assert all(0 < x["wall_s"] and 0 < x["cpu_s"] for x in load["runs"])
    assert load["ceiling"]["1"] == 1.0 and load["ceiling"]["2"] == pytest.approx(
        load["runs"][0]["wall_s"] / load["runs"][1]["wall_s"])
    probe = re.findall(r"^ +(\d) at once: ([\d.]+) s wall, ([\d.]+) s CPU; ceiling on efficiency against 1: "
                       r"([\d.]+)(?:  \(not all at once: .*\))? \[(\d+) page faults, ([\d.]+) s system\]$", text, re.M)
    assert len(probe) == 4 and probe[:2] == probe[2:] and text.index("at once") < text.index("run done")
    for (n, wall, cpu, ceiling, faults, system), x in zip(probe, load["runs"]):
        assert (float(wall), float(cpu)) == pytest.approx((x["wall_s"], x["cpu_s"]), abs=0.006)
        assert float(ceiling) == pytest.approx(load["ceiling"][n], abs=0.006)
        assert int(faults) == round(x["page_faults"]) and float(system) == pytest.approx(x["system_s"], abs=0.006)
        assert 0 <= x["system_s"] <= x["cpu_s"]
    # the largest count once more, the allocator as the environment leaves it: its line, and the
    # ratio of its time to the same count's with the pool's setting (by hand)
    d = load["default_malloc"]
    assert d["processes"] == 2 and d["wall_s"] > 0 and d["page_faults"] >= 0
    m = re.search(r"^ +2 at once, the allocator as the environment leaves it \(not the pool's psmat._malloc "
                  r"setting\): ([\d.]+) s wall, ([\d.]+) s CPU, ([\d.]+) times the time with it", text, re.M)
    assert m and float(m.group(3)) == pytest.approx(d["wall_s"] / load["runs"][1]["wall_s"], abs=0.006)
    # 1 and 2 workers are not the goal's 2 and 16: the efficiency without a met/MISSED mark
    assert s["pool_goal_efficiency"] is None
    assert "pool: 2->16 goal not measured here: counts 1,2; efficiency at 2 workers against 1: " in text
    assert " met)" not in text and "MISSED" not in text


def test_the_serial_parallel_fit_by_hand() -> None:
    # T = 10 + 80/n exactly: S = 10 s, P = 80 s
    assert fit_serial_parallel([2, 4, 8, 16], [10 + 80 / n for n in (2, 4, 8, 16)]) == pytest.approx((10.0, 80.0))
    # the measured times (2, 4, 8, 16 workers): the least-squares line through (1/n, T) by hand:
    # mean 1/n = 0.234375, mean T = 92.625; Sxx = 0.1123046875, Sxy = 32.0890625 -> P = 285.73, S = 25.66
    s, p = fit_serial_parallel([2, 4, 8, 16], [169.6, 94.5, 61.6, 44.8])
    assert p == pytest.approx(32.0890625 / 0.1123046875) and s == pytest.approx(92.625 - p * 0.234375)
    # a pure serial run (no gain from workers): P = 0
    assert fit_serial_parallel([1, 3], [5.0, 5.0]) == pytest.approx((5.0, 0.0))
    with pytest.raises(ValueError, match="two different worker counts"):
        fit_serial_parallel([4, 4], [1.0, 2.0])


def test_the_counts_and_the_goal_mark() -> None:
    assert parse_counts("16, 2,8,4") == [2, 4, 8, 16]
    for bad in ("2,x", "0,2", "2,2", ""):
        with pytest.raises(ValueError, match="--scaling"):
            parse_counts(bad)
    # from 2 to 16 workers: 160 s -> 25 s is a speed-up of 6.4 over 8x the workers, exactly the 80 % goal
    s = {"counts": [2, 16], "usable_cpus": 16, "problems": [], "metrics_identical": True,
         "runs": [{"kind": "pool", "workers": 2, "wall_s": 160.0, "cpu_s": None, "speedup": 1.0, "efficiency": 1.0,
                   "serial_s": 4.0, "metrics_sha256": "0" * 64},
                  {"kind": "pool", "workers": 16, "wall_s": 25.0, "cpu_s": None, "speedup": 6.4, "efficiency": 0.8,
                   "serial_s": 4.0, "metrics_sha256": "0" * 64}],
         "pool_fit": None, "pool_goal_efficiency": 0.8}
    assert "from 2 to 16 workers >= 80% parallel efficiency: 0.80 (met)" in format_scaling(s)
    s["pool_goal_efficiency"] = 0.47
    s["usable_cpus"] = 2
    text = format_scaling(s)
    assert "0.47 (MISSED)" in text
    assert "ceiling" not in text  # no probe, no ceiling
    # a probe that found one session 1.25x slower with 16 processes at once: a ceiling of 0.8, and the
    # measured 0.47 is 0.59 of it (by hand: 0.47 / 0.8 = 0.5875)
    s["load"] = {"session": "/s/V01_left-leg.h5", "ceiling": {2: 1.0, 16: 0.8},
                 "runs": [{"processes": 2, "wall_s": 4.0, "cpu_s": 3.9, "distinct_processes": 2, "overlapped": True},
                          {"processes": 16, "wall_s": 5.0, "cpu_s": 4.9, "distinct_processes": 15,
                           "overlapped": True}]}
    text = format_scaling(s)
    assert "   2 at once: 4.00 s wall, 3.90 s CPU; ceiling on efficiency against 2: 1.00\n" in text
    # one process ran two of the 16 sessions: flagged
    assert "  16 at once: 5.00 s wall, 4.90 s CPU; ceiling on efficiency against 2: 0.80  (not all at once" in text
    assert "pool: 2->16 efficiency 0.47 against this machine's ceiling 0.80: 0.59 of what its cores under load " \
           "allow" in text
    assert "warning: 16 workers exceed the 2 CPUs this process may use: their efficiency measures " \
           "oversubscription, not scaling" in text
    # a probe of this version: each line's page faults and system time, and the largest count with the
    # allocator's defaults, 6.0 s against 5.0 s with the pool's setting: 1.20 times (by hand)
    for r, faults, system in zip(s["load"]["runs"], (420, 380), (0.01, 0.02)):
        r.update(page_faults=faults, system_s=system)
    s["load"]["default_malloc"] = {"processes": 16, "wall_s": 6.0, "cpu_s": 5.8, "page_faults": 24000.0,
                                   "system_s": 0.4, "distinct_processes": 16, "overlapped": True}
    text = format_scaling(s)
    assert "   2 at once: 4.00 s wall, 3.90 s CPU; ceiling on efficiency against 2: 1.00 [420 page faults, 0.01 s " \
           "system]\n" in text
    assert "  16 at once, the allocator as the environment leaves it (not the pool's psmat._malloc setting): 6.00 s " \
           "wall, 5.80 s CPU, 1.20 times the time with it [24000 page faults, 0.40 s system]\n" in text


def test_scaling_options_refused_in_one_line(capsys) -> None:
    for argv in (["--scaling", "2,two"], ["--dask"], ["--dask-only"], ["--scaling", "1,1"]):
        assert main(["--quick", *argv]) == 2
        err = capsys.readouterr().err
        assert len(err.strip().splitlines()) == 1, err
    for workers in ("2", "3"):  # not both, even with --workers at its default value (--quick: cheap if not refused)
        with pytest.raises(SystemExit):
            main(["--quick", "--workers", workers, "--scaling", "2,4"])
        assert "not allowed with argument" in capsys.readouterr().err


def test_scaling_on_a_local_dask_cluster_too(tmp_path) -> None:
    pytest.importorskip("distributed")
    text, r = _scaling(["--scaling", "1,2", "--dask", "--no-load-probe"], tmp_path)
    pool, dask = _check_rows(text, "pool", [1, 2]), _check_rows(text, "Dask LocalCluster", [1, 2])
    s = r["scaling"]
    assert [(x["kind"], x["workers"], x["computed"]) for x in s["runs"]] == [
        ("pool", 1, 3), ("pool", 2, 3), ("dask", 1, 3), ("dask", 2, 3)]
    # the same metrics.csv bytes from the pool and from the cluster, checked across all four runs
    assert s["metrics_identical"] and len({x["metrics_sha256"] for x in s["runs"]}) == 1
    assert "metrics.csv byte-identical across all 4 runs" in text and "problem:" not in text
    # Dask against the pool at the same count: the ratio of the printed times
    m = re.search(r"speed-up over the pool at the same count: 1: ([\d.]+), 2: ([\d.]+)", text)
    assert m, text
    for (n, tp), (_, td), shown in zip(pool, dask, m.groups()):
        assert float(shown) == pytest.approx(tp / td, abs=_ratio_tol(tp, td) + 0.005)
    assert "Dask LocalCluster: least-squares fit" in text and "Dask LocalCluster: 2->16 goal not measured" in text


def test_bench_dask_workers_start_with_the_pools_malloc_settings(monkeypatch) -> None:
    # Dask's nanny sets MALLOC_TRIM_THRESHOLD_=65536 (which made psmat's sessions ~10 % slower): the
    # bench's workers run in the real worker processes with the pool's settings instead
    # (psmat._malloc: freed memory kept), with one BLAS thread, also where an earlier cluster of
    # this process left Dask's value in os.environ (a nanny writes its environment there)
    pytest.importorskip("distributed")
    monkeypatch.setenv("MALLOC_TRIM_THRESHOLD_", "65536")
    monkeypatch.delenv("MALLOC_MMAP_THRESHOLD_", raising=False)
    import dask
    from distributed import Client

    from psmat._malloc import ENVIRONMENT
    from psmat.bench.study_scaling import local_cluster, worker_environ

    assert dask.config.get("distributed.nanny.pre-spawn-environ")["MALLOC_TRIM_THRESHOLD_"] == 65536  # Dask's default
    assert ENVIRONMENT == {"MALLOC_MMAP_THRESHOLD_": str(32 << 20), "MALLOC_TRIM_THRESHOLD_": str(1 << 30)}
    assert {k: worker_environ()[k] for k in ENVIRONMENT} == ENVIRONMENT
    with local_cluster(2) as cluster, Client(cluster) as client:
        seen = client.run(lambda: (os.getpid(), os.environ.get("MALLOC_TRIM_THRESHOLD_"),
                                   os.environ.get("MALLOC_MMAP_THRESHOLD_"), os.environ.get("OPENBLAS_NUM_THREADS")))
    assert len(seen) == 2 and len({pid for pid, _, _, _ in seen.values()} | {os.getpid()}) == 3
    assert all((trim, mmap, blas) == (str(1 << 30), str(32 << 20), "1") for _, trim, mmap, blas in seen.values())
    # outside the bench's clusters Dask's own setting is back, and this process's variables as they were
    assert dask.config.get("distributed.nanny.pre-spawn-environ")["MALLOC_TRIM_THRESHOLD_"] == 65536
    assert os.environ.get("MALLOC_TRIM_THRESHOLD_") == "65536" and "MALLOC_MMAP_THRESHOLD_" not in os.environ


def test_dask_only_runs_the_clusters_counts_alone(tmp_path) -> None:
    text, r = _scaling(["--scaling", "1", "--dask-only", "--no-load-probe"], tmp_path)
    assert [m.group(1) for m in ROW.finditer(text)] == ["Dask LocalCluster"]  # no pool's run
    assert [(x["kind"], x["workers"], x["computed"]) for x in r["scaling"]["runs"]] == [("dask", 1, 3)]
    assert "speed-up over the pool" not in text and "pool:" not in text
    assert re.search(r"^run done: Dask LocalCluster, 1 worker: [\d.]+ s wall", text, re.M)


def test_dask_skipped_in_one_line_without_distributed(tmp_path) -> None:
    # a distributed package that cannot be imported, ahead of the installed one on the path
    blocked = tmp_path / "blocked" / "distributed"
    blocked.mkdir(parents=True)
    (blocked / "__init__.py").write_text("raise ImportError('distributed blocked for this test')\n")
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(filter(None, [str(blocked.parent),
                                                                      os.environ.get("PYTHONPATH")]))}
    proc = subprocess.run([sys.executable, "-m", "psmat.bench", "study", "--quick", "--scaling", "1", "--dask"],
                          capture_output=True, text=True, timeout=300, check=False, cwd=tmp_path, env=env)
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert [m.group(1) for m in ROW.finditer(proc.stdout)] == ["pool"]  # the pool's run, no cluster's
    skipped = [line for line in proc.stdout.splitlines() if line.startswith("Dask")]
    assert skipped == ["Dask: skipped, Dask distributed is not installed (pip install 'psmat[cluster]')"]
    assert "pool: fit T(n) = S + P/n needs two worker counts at least" in proc.stdout
    # --dask-only with no Dask to run on: one line, nothing run
    proc = subprocess.run([sys.executable, "-m", "psmat.bench", "study", "--quick", "--scaling", "1", "--dask-only"],
                          capture_output=True, text=True, timeout=300, check=False, cwd=tmp_path, env=env)
    assert proc.returncode == 2 and proc.stdout == ""
    assert proc.stderr.strip().splitlines() == [
        "python -m psmat.bench study: --dask-only needs Dask distributed (pip install 'psmat[cluster]')"]


def test_a_metrics_difference_is_a_problem_line() -> None:
    from psmat.bench.study_scaling import _metrics_check

    runs = [{"kind": "pool", "workers": 1, "_metrics": b"subject,sigma\nV01,1.0\nV02,2.0\n"},
            {"kind": "pool", "workers": 2, "_metrics": b"subject,sigma\nV01,1.0\nV02,2.0\n"},
            {"kind": "dask", "workers": 2, "_metrics": b"subject,sigma\nV01,1.0\nV02,2.5\n"}]
    assert _metrics_check(runs) == ["metrics.csv of Dask LocalCluster, 2 workers differs from pool, 1 worker's "
                                    "(first at line 3)"]
    runs[2]["_metrics"] = runs[0]["_metrics"][:-8]  # a row short
    assert _metrics_check(runs)[0].endswith("(first at line 3)")

"""The study's figures as tasks of the worker pool (docs/spec.md §12): the same bytes whether one
process or two workers drew them, and a rerun after one session changed redraws only the
figures that draw it (the bars and Bland–Altman plots draw every volunteer; a trial's CoP
figure draws one session of that trial only). No assertion on how long anything takes."""

from __future__ import annotations

import csv
import shutil
from pathlib import Path

import pytest

from psmat.study import run_study
from psmat.synth import simulate_study

EVERY_VOLUNTEER = {"sigma_bars.png", "eu_bars.png", "bland_altman_ml.png", "bland_altman_ap.png"}


def _figures(results: Path) -> dict[str, tuple[bytes, int]]:
    """Every figure: (bytes, mtime ns)."""
    return {p.name: (p.read_bytes(), p.stat().st_mtime_ns) for p in sorted((results / "figures").glob("*.png"))}


def _read(path: Path) -> list[dict[str, str]]:
    with path.open(newline="", encoding="utf-8") as f:
        return list(csv.DictReader(f))


@pytest.fixture(scope="module")
def study(tmp_path_factory: pytest.TempPathFactory) -> Path:
    root = tmp_path_factory.mktemp("figtasks") / "study"
    simulate_study(root, volunteers=2, duration_s=4.0, seed=11, rate_hz=50.0)
    return root


def test_figures_drawn_by_two_workers_are_the_bytes_one_process_draws(study: Path, tmp_path: Path) -> None:
    one, two = tmp_path / "one", tmp_path / "two"
    for dst in (one, two):
        shutil.copytree(study, dst)
    run_study(one, workers=1, progress=False)
    run_study(two, workers=2, progress=False)
    a, b = _figures(one / "results"), _figures(two / "results")
    # sigma, Eu, two Bland–Altman, a CoP figure per trial
    assert set(a) == EVERY_VOLUNTEER | {f"cop_traces_{t}.png" for t in ("right-leg", "left-leg", "rotation")}
    assert {n: v[0] for n, v in a.items()} == {n: v[0] for n, v in b.items()}
    assert (one / "results" / "metrics.csv").read_bytes() == (two / "results" / "metrics.csv").read_bytes()


def test_a_changed_session_recomputes_it_and_only_the_figures_that_draw_it(study: Path, tmp_path: Path) -> None:
    root = tmp_path / "study"
    shutil.copytree(study, root)
    results = root / "results"
    run_study(root, workers=2, progress=False)
    before = _figures(results)
    # another recording of V02's rotation trial (another simulation's session and its platform file)
    other = tmp_path / "other"
    simulate_study(other, volunteers=2, duration_s=4.0, seed=12, rate_hz=50.0)
    for sub, ext in (("sessions", "h5"), ("forceplate", "csv")):
        shutil.copyfile(other / sub / f"V02_rotation.{ext}", root / sub / f"V02_rotation.{ext}")

    report = run_study(root, workers=2, progress=False)
    assert (report.computed, report.reused) == (1, 5)
    per = {r["stem"]: r["result"] for r in _read(results / "session_timings.csv")}
    assert per == {**{s: "reused" for s in per}, "V02_rotation": "computed"}
    after = _figures(results)
    redrawn = {n for n in after if after[n] != before[n]}
    # the tables across volunteers changed: every figure of them is drawn again
    assert EVERY_VOLUNTEER <= redrawn
    # the single-leg trials' sessions did not change: their CoP figures are neither drawn nor written
    assert redrawn <= EVERY_VOLUNTEER | {"cop_traces_rotation.png"}
    for name in ("cop_traces_right-leg.png", "cop_traces_left-leg.png"):
        assert after[name] == before[name]
    stages = {r["stage"]: r for r in _read(results / "timings.csv")}
    assert int(stages["figures"]["computed"]) + int(stages["figures"]["reused"]) == len(after)
    assert int(stages["figures"]["reused"]) >= 2

    # and the run after that finds every output up to date (results/.outputs.json agrees)
    again = run_study(root, workers=2, progress=False)
    assert (again.computed, again.reused) == (0, 6) and not again.problems
    assert _figures(results) == after
    stages = {r["stage"]: r for r in _read(results / "timings.csv")}
    assert (stages["figures"]["computed"], stages["figures"]["reused"]) == ("0", str(len(after)))


def test_a_figure_changed_on_disk_is_drawn_again_with_its_bytes(study: Path, tmp_path: Path) -> None:
    root = tmp_path / "study"
    shutil.copytree(study, root)
    results = root / "results"
    run_study(root, workers=1, progress=False)
    before = _figures(results)
    (results / "figures" / "eu_bars.png").write_bytes(b"not a figure")
    report = run_study(root, workers=1, progress=False)
    assert any("eu_bars.png changed after it was written" in p for p in report.problems)
    after = _figures(results)
    assert after["eu_bars.png"][0] == before["eu_bars.png"][0]
    # the others hold the bytes their keys record: not drawn nor written again
    assert {n: v for n, v in after.items() if n != "eu_bars.png"} == \
        {n: v for n, v in before.items() if n != "eu_bars.png"}

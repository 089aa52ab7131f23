"""What a study's worker process loads before its first task (psmat.study._warm), and the order the
figures are handed to the workers (psmat.study._figure_tasks.most_work_first). No assertion on how
long anything takes."""

from __future__ import annotations

import subprocess
import sys
import textwrap

from psmat.study._figure_tasks import FigureTask, most_work_first


def test_warm_loads_matplotlibs_figure_and_agg_canvas_in_a_fresh_process() -> None:
    # in a process of its own: this one has imported matplotlib long ago
    code = textwrap.dedent("""
        import os, sys
        from psmat.study._warm import warm
        wanted = ("matplotlib.figure", "matplotlib.backends.backend_agg", "psmat.study._task", "psmat.study._run")
        before = [m in sys.modules for m in wanted]
        pid = warm()
        print(before, [m in sys.modules for m in wanted], pid == os.getpid())
    """)
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120, check=True)
    # the package's import brings the tasks' modules; warm adds what the figures need
    assert out.stdout.split("\n")[0] == "[False, False, True, True] [True, True, True, True] True"


def _task(name: str, kind: str) -> FigureTask:
    return FigureTask(name, f"/nowhere/{name}.png", kind, (), name)


def test_the_figures_that_take_longest_are_handed_out_first() -> None:
    report_order = [_task("sigma_bars", "sigma_bars"), _task("eu_bars", "eu_bars"),
                    _task("cop_traces_right-leg", "cop_traces"), _task("cop_traces_rotation", "cop_traces"),
                    _task("bland_altman_ml", "bland_altman"), _task("bland_altman_ap", "bland_altman")]
    names = [t.name for t in most_work_first(report_order)]
    # Bland-Altman (27 panels) before the σ and Eu bars, the CoP figures last; ties keep their order
    assert names == ["bland_altman_ml", "bland_altman_ap", "sigma_bars", "eu_bars", "cop_traces_right-leg",
                     "cop_traces_rotation"]
    assert [t.name for t in most_work_first([])] == []

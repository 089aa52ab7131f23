"""The figures of a balance study keep every text readable: inside the figure, each panel's
tick labels, axis labels and title clear of every other panel's, the figure title above the
panels and the key below them. Measured by matplotlib itself on the figures as saved."""

from __future__ import annotations

import math

import numpy as np
import pytest

from psmat.study import COLUMNS, write_results

NAN = math.nan
SUBJECTS = ("V01", "V02", "V03", "V04")


def _row(subject: str, trial: str, variant: str, **values: float) -> dict:
    row = {c: NAN for c in COLUMNS}
    row.update(subject=subject, trial=trial, variant=variant, condition="", status="ok", **values)
    return row


def _rows() -> list[dict]:
    """Two trials; SCHC-8x8 differs from FP by 1e-7 cm (its Bland–Altman panels need an offset
    text, "1e-7", above them); PROP-C-8x8 (a long name) only in "rotation" (an empty panel)."""
    rows = []
    for trial, scale in (("right-leg", 1.0), ("rotation", 30.0)):
        for i, s in enumerate(SUBJECTS):
            fp_ml, fp_ap = scale * (1.0 + 0.3 * i), scale * (2.0 + 0.2 * i)
            values = {"FP": (fp_ml, fp_ap), "PROP": (0.7 * fp_ml, 1.1 * fp_ap),
                      "SCHC-8x8": (fp_ml + 1e-7 * i, fp_ap - 1e-7 * i)}
            if trial == "rotation":
                values["PROP-C-8x8"] = (0.4 * fp_ml + 0.01 * i * i, 0.5 * fp_ap)
            for variant, (ml, ap) in values.items():
                eu = 0.0 if variant == "FP" else 0.01 * (i + 1) * scale
                rows.append(_row(s, trial, variant, sd_ml_cm=ml, sd_ap_cm=ap, eu_cm=eu, eu_ml_cm=0.6 * eu,
                                 eu_ap_cm=0.8 * eu))
    return rows


def _traces() -> dict:
    t = 5.0 + 0.01 * np.arange(1000)
    fp = np.c_[10.0 + np.sin(t), 20.0 + 0.7 * np.cos(0.6 * t)]
    return {(s, trial): {"t_s": t, "FP": fp, "PROP": 0.7 * fp + 1.0, "SCHC-8x8": fp + 1e-3 * np.sin(9.0 * t)[:, None]}
            for trial in ("right-leg", "rotation") for s in SUBJECTS}


def _narrow_rows() -> list[dict]:
    """One trial, one variant against FP, no label: a figure narrower than its title and key."""
    return [_row(s, "quiet", variant, sd_ml_cm=0.2 + 0.1 * i * k, sd_ap_cm=0.3 + 0.05 * i * k, eu_cm=0.1 * i * (k - 1))
            for i, s in enumerate(SUBJECTS[:3]) for k, variant in ((1, "FP"), (2, "PROP"))]


def _written(tmp_path, rows: list[dict], traces: dict, label: str | None) -> dict:
    """{file name: the matplotlib Figure as written} of a study's results (each figure known by the
    task drawing it: they are drawn the longest first, not in the report's order)."""
    from matplotlib.figure import Figure

    from psmat.study import _results

    figures, drawing = {}, []
    save, draw = Figure.savefig, _results.draw_figure

    def keep(fig, fname, *args, **kwargs):
        save(fig, fname, *args, **kwargs)
        figures[drawing[-1]] = fig

    def named(task):
        drawing.append(task.name)
        return draw(task)

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(Figure, "savefig", keep)
        mp.setattr(_results, "draw_figure", named)
        paths = write_results(tmp_path, rows, traces, label=label)
    names = [name for name in paths if name not in ("summary", "pairwise", "report")]
    assert sorted(names) == sorted(figures) and len(drawing) == len(names)
    return {name: figures[name] for name in names}


@pytest.fixture(scope="module")
def saved(tmp_path_factory) -> dict:
    return _written(tmp_path_factory.mktemp("results"), _rows(), _traces(), "simulation")


@pytest.fixture(scope="module")
def narrow(tmp_path_factory) -> dict:
    return _written(tmp_path_factory.mktemp("narrow"), _narrow_rows(), {}, None)


def _sub_cm_rows() -> list[dict]:
    """Spreads under 1 cm, as a standing trial has: the A-P axis ticks at 0.00, 0.25, 0.50, 0.75 only
    once the panels have their final size (at the figure's first size they read 0.0, 0.5)."""
    return [_row(s, trial, variant, sd_ml_cm=(0.25 + 0.03 * i) * k, sd_ap_cm=(0.55 + 0.05 * i) * k,
                 eu_cm=0.1 * i * (k - 0.9))
            for trial in ("right-leg", "left-leg", "rotation") for i, s in enumerate(SUBJECTS)
            for k, variant in ((1.0, "FP"), (0.8, "PROP"), (1.1, "SCHC"), (0.6, "PROP-C"))]


@pytest.fixture(scope="module")
def sub_cm(tmp_path_factory) -> dict:
    return _written(tmp_path_factory.mktemp("sub_cm"), _sub_cm_rows(), {}, "simulation")


def _overlap(a, b, tol: float) -> bool:
    return a.x0 < b.x1 - tol and b.x0 < a.x1 - tol and a.y0 < b.y1 - tol and b.y0 < a.y1 - tol


def test_every_figure_of_the_studies_is_checked(saved, narrow) -> None:
    assert set(saved) == {"sigma_bars", "eu_bars", "cop_traces_right-leg", "cop_traces_rotation",
                          "bland_altman_ml", "bland_altman_ap"}
    assert set(narrow) == {"sigma_bars", "eu_bars", "bland_altman_ml", "bland_altman_ap"}  # no traces


@pytest.mark.parametrize("study, name", [(study, name) for study in ("saved", "narrow", "sub_cm") for name in
                                         ("sigma_bars", "eu_bars", "cop_traces_rotation", "bland_altman_ml",
                                          "bland_altman_ap") if study == "saved" or "cop" not in name])
def test_texts_inside_the_figure_and_clear_of_each_other(request, study: str, name: str) -> None:
    fig = request.getfixturevalue(study)[name]
    renderer = fig.canvas.get_renderer()
    page = fig.bbox
    tol = 1.0  # pixels
    panels = [ax for ax in fig.axes if ax.axison]
    boxes = [ax.get_tightbbox(renderer) for ax in panels]  # a panel with its ticks, labels, title
    for ax, box in zip(panels, boxes):
        assert page.x0 - tol <= box.x0 and box.x1 <= page.x1 + tol, (name, ax.get_title())
        assert page.y0 - tol <= box.y0 and box.y1 <= page.y1 + tol, (name, ax.get_title())
        assert ax.bbox.width > 0.5 * fig.dpi and ax.bbox.height > 0.5 * fig.dpi, (name, ax.get_title())
    for i in range(len(boxes)):
        for j in range(i + 1, len(boxes)):
            assert not _overlap(boxes[i], boxes[j], tol), (name, panels[i].get_title(), panels[j].get_title())
    title = next(t for t in fig.texts if t.get_text() == fig.get_suptitle()).get_window_extent(renderer)
    key = fig.legends[0].get_window_extent(renderer)
    assert title and page.y1 + tol >= title.y1 and title.y0 >= max(b.y1 for b in boxes) - tol, name
    assert key.y0 >= page.y0 - tol and key.y1 <= min(b.y0 for b in boxes) + tol, name
    assert page.x0 - tol <= min(title.x0, key.x0) and max(title.x1, key.x1) <= page.x1 + tol, name


@pytest.mark.parametrize("name", ["bland_altman_ml", "bland_altman_ap"])
def test_an_offset_text_sits_above_its_panel_clear_of_the_title(saved, name: str) -> None:
    # SCHC-8x8 − FP spans 3e-7 cm: its y axis shows "1e-7" above the panel
    fig = saved[name]
    renderer = fig.canvas.get_renderer()
    ax = next(a for a in fig.axes if a.get_title() == "SCHC-8x8, right-leg")
    offset = ax.yaxis.offsetText
    assert offset.get_text(), "expected an offset text on a 3e-7 cm span"
    above = offset.get_window_extent(renderer)
    assert above.y0 >= ax.bbox.y1 - 1.0
    assert not _overlap(ax.title.get_window_extent(renderer), above, 1.0)


def test_a_trial_without_a_variant_leaves_its_panel_empty(saved) -> None:
    fig = saved["bland_altman_ap"]
    off = [ax for ax in fig.axes if not ax.axison]
    assert len(off) == 1 and not off[0].lines  # PROP-C-8x8 in right-leg

"""Figures of a balance study (thesis Figs. 3.2-3.7): bars of σ and Eu per variant, CoP
traces against the platform, Bland–Altman of σ; matplotlib's object API (Agg), PNG, the panels
placed by :func:`~psmat.study._figure_layout.arrange` (no layout engine: it drew every figure
twice).

Every function takes an optional ``label`` (e.g. ``"simulation"``) shown in the title. Each figure
carries a key that spells out the variants it shows (:func:`psmat.balance.legend_label`).
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any, BinaryIO

import numpy as np

from ..balance import legend_label
from ._figure_layout import arrange
from ._summary import REFERENCE, SIGMAS, StudyRows

__all__ = ["TRACE_VARIANTS", "load_canvas", "sigma_bars", "eu_bars", "median_session", "ranking_variant",
           "trace_variants", "cop_traces", "draw_cop_traces", "bland_altman_plot"]

#: Variants drawn against FP in the trace figures when present (thesis Figs. 3.6, 3.7).
TRACE_VARIANTS = ("PROP", "SCHC", "SCHC-8x8")
AXES = {"sd_ml_cm": ("M-L", r"$\sigma_{ML}$"), "sd_ap_cm": ("A-P", r"$\sigma_{AP}$")}
LONG_AXES = {"M-L": "the medial-lateral direction (M-L)", "A-P": "the anterior-posterior direction (A-P)"}
DPI = 100
#: Tick spacings the small panels may use (times a power of ten): matplotlib's automatic ones.
TICK_STEPS = (1, 2, 2.5, 5, 10)


def load_canvas() -> tuple[Any, Any]:
    """matplotlib's ``Figure`` and Agg canvas, imported (about 0.3 s the first time in a process on the
    2-core machine, which a worker process can spend before its first figure: :mod:`psmat.study`
    (``_warm.py``))."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    return Figure, FigureCanvasAgg


def _figure(nrows: int, ncols: int, size: tuple[float, float]) -> Any:
    # Object-oriented matplotlib: no pyplot state, rendered by Agg when saved; no layout engine
    # (its extra draw on save was most of a figure's time): :func:`_finish` places the panels.
    Figure, FigureCanvasAgg = load_canvas()
    fig = Figure(figsize=size, dpi=DPI)
    FigureCanvasAgg(fig)
    return fig, fig.subplots(nrows, ncols, squeeze=False)


def _title(text: str, label: str | None) -> str:
    return f"{text} ({label})" if label else text


def _finish(fig: Any, ax: Any, title: str, key: Any, path: str | os.PathLike[str] | BinaryIO) -> Any:
    """Title ``fig``, place its panels, title and ``key`` (:func:`arrange`) and save it to ``path``."""
    suptitle = fig.suptitle(title)
    # twice: the tick locators pick their ticks for the panel size the first pass sets, and the
    # second measures those labels (wider ones, "0.75" where "0.5" was, would reach out of the figure)
    for _ in range(2):
        arrange(fig, ax, suptitle, key)
    return _save(fig, path)


def _save(fig: Any, path: str | os.PathLike[str] | BinaryIO) -> Any:
    """Save ``fig`` as PNG to ``path`` (whole or not at all), or into a binary file object
    (the same bytes: :mod:`psmat.study` (``_figure_tasks.py``) draws in workers this way)."""
    from .._atomic import replacing

    if not isinstance(path, (str, os.PathLike)):
        fig.savefig(path, format="png", dpi=DPI, metadata={"Software": None})
        return path
    path = Path(path)
    with replacing(path) as tmp:  # whole or not at all
        fig.savefig(tmp, dpi=DPI, metadata={"Software": None})
    return path


def _colours(variants: Sequence[str]) -> dict[str, Any]:
    """One colour per variant, FP black, the others from the tab10 cycle in order."""
    from matplotlib import colormaps

    cycle = colormaps["tab10"].colors
    others = [v for v in variants if v != REFERENCE]
    return {REFERENCE: "black", **{v: cycle[i % len(cycle)] for i, v in enumerate(others)}}


def _key(fig: Any, variants: Sequence[str], colours: Mapping[str, Any] | None = None) -> Any:
    """Below the panels, each variant with what it stands for ("SCHC: IECM + sensor model, ..."), as
    a coloured patch when ``colours`` is given; IECM, the crosstalk removal, spelled out once."""
    from matplotlib.patches import Patch

    labels = [legend_label(v) for v in variants]
    if any("IECM" in label for label in labels):
        labels.append("IECM: Inverse of Equivalent Conductance Method, the crosstalk removal")
    handles = [Patch(facecolor=colours[v]) if colours else Patch(visible=False) for v in variants]
    handles += [Patch(visible=False)] * (len(labels) - len(handles))
    return fig.legend(handles, labels, loc="lower center", ncols=2, fontsize="small", frameon=False, borderaxespad=0,
                      **({} if colours else {"handlelength": 0, "handletextpad": 0}))


def _order(summary: Sequence[Mapping[str, Any]], key: str) -> list[str]:
    return list(dict.fromkeys(str(r[key]) for r in summary))


def _bars(ax: Any, rows: Sequence[Mapping[str, Any]], mean: str, sd: str, colours: Mapping[str, Any]) -> None:
    names = [str(r["variant"]) for r in rows]
    x = np.arange(len(names))
    heights = [float(r[mean]) for r in rows]
    errors = [0.0 if not math.isfinite(float(r[sd])) else float(r[sd]) for r in rows]
    ax.bar(x, heights, yerr=errors, capsize=3, color=[colours[n] for n in names])
    ax.set_xticks(x, names, rotation=45, ha="right")


def sigma_bars(summary: Sequence[Mapping[str, Any]], path: str | os.PathLike[str] | BinaryIO,
               label: str | None = None) -> Path:
    """Mean σ_ML and σ_AP per variant and trial, FP included (Figs. 3.2, 3.4).

    Parameters
    ----------
    summary : rows of :func:`psmat.study.summary_rows`
    path : path-like or binary file
        PNG to write (a file object: the PNG's bytes written into it).
    label : str, optional
        Shown in the title (e.g. ``"simulation"``).

    Returns
    -------
    pathlib.Path
        ``path``. Error bars: SD across volunteers (cm).
    """
    trials, colours = _order(summary, "trial"), _colours(_order(summary, "variant"))
    fig, ax = _figure(2, len(trials), (3.6 * len(trials), 6.5))
    for j, trial in enumerate(trials):
        rows = [r for r in summary if r["trial"] == trial]
        for i, (metric, key) in enumerate((("sd_ml_cm", "sd_ml"), ("sd_ap_cm", "sd_ap"))):
            _bars(ax[i, j], rows, f"{key}_mean_cm", f"{key}_sd_cm", colours)
            ax[i, j].set_ylabel(f"{AXES[metric][1]} (cm)")
            ax[i, j].set_title(f"{trial}, {AXES[metric][0]}", y=1.0)
    key = _key(fig, _order(summary, "variant"), colours)
    return _finish(fig, ax, _title("Standard deviation σ of the centre of pressure per variant, mean ± SD across "
                                   "volunteers\nalong the medial-lateral (M-L) and anterior-posterior (A-P) directions",
                                   label), key, path)


def eu_bars(summary: Sequence[Mapping[str, Any]], path: str | os.PathLike[str] | BinaryIO,
            label: str | None = None) -> Path:
    """Mean Eu (eq. 3.1) against FP per variant and trial (Figs. 3.3, 3.5); error bars SD (cm)."""
    trials, colours = _order(summary, "trial"), _colours(_order(summary, "variant"))
    fig, ax = _figure(1, len(trials), (3.6 * len(trials), 3.6))
    for j, trial in enumerate(trials):
        rows = [r for r in summary if r["trial"] == trial and r["variant"] != REFERENCE]
        _bars(ax[0, j], rows, "eu_mean_cm", "eu_sd_cm", colours)
        ax[0, j].set_ylabel("Eu (cm)")
        ax[0, j].set_title(trial, y=1.0)
    key = _key(fig, [v for v in _order(summary, "variant") if v != REFERENCE], colours)
    return _finish(fig, ax, _title("Trajectory distance Eu (eq. 3.1) to the force platform (FP), mean ± SD across "
                                   "volunteers", label), key, path)


def trace_variants(study: StudyRows) -> tuple[str, ...]:
    """The variants drawn against FP: those of :data:`TRACE_VARIANTS` in the study, else its
    first two compared variants."""
    chosen = tuple(v for v in TRACE_VARIANTS if v in study.variants)
    return chosen or study.compared[:2]


def ranking_variant(study: StudyRows) -> str | None:
    """The variant whose Eu picks the session drawn: SCHC when drawn, else the first drawn."""
    drawn = trace_variants(study)
    return ("SCHC" if "SCHC" in drawn else drawn[0]) if drawn else None


def median_session(study: StudyRows, trial: str, traces: Mapping[tuple[str, str], Mapping[str, Any]]
                   ) -> str | None:
    """The subject of ``trial`` with the median Eu of the ranking variant (SCHC when drawn, else
    the first drawn), among the sessions ok for it and for FP that have traces of it.

    With an even count, the lower of the two middle ones; ties by subject id. None without one.
    """
    rank = ranking_variant(study)
    if rank is None:
        return None
    subjects = [s for s in study.ok_subjects(trial, rank, REFERENCE)
                if rank in traces.get((s, trial), {}) and REFERENCE in traces.get((s, trial), {})]
    eu = study.values(trial, rank, "eu_cm", subjects)
    ranked = sorted((e, s) for e, s in zip(eu, subjects) if math.isfinite(e))
    return ranked[(len(ranked) - 1) // 2][1] if ranked else None


def cop_traces(study: StudyRows, traces: Mapping[tuple[str, str], Mapping[str, Any]], trial: str,
               path: str | os.PathLike[str], label: str | None = None) -> Path | None:
    """M-L and A-P CoP against time of the median session of ``trial`` (Figs. 3.6, 3.7):
    FP and :func:`trace_variants`, each mean-removed (cm). None (nothing written) without a session."""
    subject = median_session(study, trial, traces)
    if subject is None:
        return None
    return draw_cop_traces(traces[(subject, trial)], subject, trial, trace_variants(study), ranking_variant(study),
                           study.variants, path, label)


def draw_cop_traces(tr: Mapping[str, Any], subject: str, trial: str, drawn: Sequence[str], rank: str | None,
                    variants: Sequence[str], path: str | os.PathLike[str] | BinaryIO, label: str | None = None) -> Any:
    """The figure of :func:`cop_traces` from the one session it draws: ``tr`` its traces
    (``t_s`` s, ``FP`` and the variants (N, 2) cm), ``drawn`` the variants drawn against FP,
    ``rank`` the variant whose Eu chose the session, ``variants`` the study's (for the colours)."""
    drawn = tuple(drawn)
    t = np.asarray(tr["t_s"], np.float64)
    t = t - t[0]
    colours = _colours(variants)
    fig, ax = _figure(2, 1, (10.0, 6.0))
    for name in (REFERENCE,) + drawn:
        if name not in tr:
            continue
        c = np.asarray(tr[name], np.float64)
        c = c - np.nanmean(c, axis=0)
        for k in range(2):
            ax[k, 0].plot(t, c[:, k], lw=1.4 if name == REFERENCE else 0.9, color=colours[name],
                          zorder=3 if name == REFERENCE else 2)
    for k, axis in enumerate(("medial-lateral (M-L)", "anterior-posterior (A-P)")):
        ax[k, 0].set_ylabel(f"{axis} CoP,\nmean removed (cm)")
    key = _key(fig, [n for n in (REFERENCE,) + drawn if n in tr], colours)
    ax[1, 0].set_xlabel("time (s)")
    return _finish(fig, ax, _title(f"Centre of pressure (CoP) against the force platform: {subject}, {trial}\n(the "
                                   f"session of median trajectory distance Eu of {rank})", label), key, path)


def bland_altman_plot(study: StudyRows, summary: Sequence[Mapping[str, Any]], metric: str,
                      path: str | os.PathLike[str] | BinaryIO, label: str | None = None) -> Path:
    """Bland–Altman of σ along one axis: σ_variant − σ_FP against their mean, one panel per
    trial (rows) and compared variant (columns), with the bias and 95 % limits of ``summary``.

    Parameters
    ----------
    metric : {"sd_ml_cm", "sd_ap_cm"}
    """
    if metric not in SIGMAS:
        raise ValueError(f"Bland–Altman of {metric!r}: only {' or '.join(SIGMAS)}")
    from matplotlib.ticker import MaxNLocator

    key = metric[:-3]
    trials, variants = study.trials, study.compared
    fig, ax = _figure(len(trials), max(len(variants), 1), (2.8 * max(len(variants), 1) + 0.6, 2.5 * len(trials) + 0.6))
    rows_of: dict[tuple[str, str], Mapping[str, Any]] = {}
    for r in summary:
        rows_of.setdefault((r["trial"], r["variant"]), r)
    shown = [[(trial, variant) in rows_of for variant in variants] for trial in trials]
    for i, trial in enumerate(trials):
        for j, variant in enumerate(variants):
            a = ax[i, j]
            row = rows_of.get((trial, variant))
            if row is None:  # no rows of this variant in this trial
                a.set_axis_off()
                continue
            _, v, fp = study.paired(trial, variant, metric)
            a.plot(0.5 * (v + fp), v - fp, "o", ms=4)
            for col, style in (("bias", "-"), ("loa_low", "--"), ("loa_high", "--")):
                y = float(row[f"ba_{key}_{col}_cm"])
                if math.isfinite(y):
                    a.axhline(y, color="grey", ls=style, lw=0.8)
            a.axhline(0.0, color="black", lw=0.5)
            a.set_title(f"{variant}, {trial}", fontsize="medium", y=1.0)
            # every panel of a row has the same y quantity, of a column the same x: each said once, on the
            # row's first panel and the column's lowest; four intervals on each axis of these small panels
            if not any(shown[k][j] for k in range(i + 1, len(trials))):
                a.set_xlabel(f"mean of {AXES[metric][1]} (cm)")
            if not any(shown[i][:j]):
                a.set_ylabel(f"{AXES[metric][1]} − FP (cm)")
            a.xaxis.set_major_locator(MaxNLocator(4, steps=TICK_STEPS))
            a.yaxis.set_major_locator(MaxNLocator(4, steps=TICK_STEPS))
    key = _key(fig, variants)
    return _finish(fig, ax, _title(f"Bland–Altman of σ, the standard deviation of the centre of pressure\nalong "
                                   f"{LONG_AXES[AXES[metric][0]]}, against the force platform (FP): bias, 95 % limits",
                                   label), key, path)

"""A report as one self-contained HTML page: inline CSS, figures as ``data:`` PNGs, no script, no link."""

from __future__ import annotations

import html
import json
import math
from collections.abc import Iterable, Sequence
from typing import Any

from ..balance import descriptor_unit
from ._analysis import SessionAnalysis
from ._figures import cop_png, overlay_png, pressure_images_png
from ._units import metric_unit

__all__ = ["page", "session_section"]

_CSS = """
body{font-family:sans-serif;margin:1.5em auto;max-width:62em;color:#222;line-height:1.35}
h1{font-size:1.5em}h2{font-size:1.25em;border-bottom:1px solid #999;margin-top:2em}h3{font-size:1.05em}
table{border-collapse:collapse;margin:.4em 0 1em;font-size:.88em}
td,th{border:1px solid #bbb;padding:.15em .5em;text-align:left;vertical-align:top}
td.n{text-align:right;font-variant-numeric:tabular-nums}th{background:#eee}
.sim{background:#fff3c4;border:1px solid #d8b600;padding:.4em .6em}.note{color:#555;font-size:.9em}
img{max-width:100%;height:auto}pre{font-size:.78em;white-space:pre-wrap;background:#f6f6f6;padding:.5em}
details{margin:.4em 0 1em}
"""


def _e(text: Any) -> str:
    return html.escape(str(text), quote=True)


def _num(v: Any) -> str:
    if isinstance(v, (int, float)) and not isinstance(v, bool):
        x = float(v)
        if not math.isfinite(x):
            return "—"
        return f"{x:.4g}"
    return _e(v)


def _table(header: Sequence[str], rows: Iterable[Sequence[Any]]) -> str:
    head = "".join(f"<th>{_e(h)}</th>" for h in header)
    body = []
    for row in rows:
        cells = "".join(f'<td class="n">{_num(c)}</td>' if isinstance(c, (int, float)) and not isinstance(c, bool)
                        else f"<td>{_e(c)}</td>" for c in row)
        body.append(f"<tr>{cells}</tr>")
    return f"<table><thead><tr>{head}</tr></thead><tbody>{''.join(body)}</tbody></table>"


def _img(png_b64: str, alt: str) -> str:
    return f'<img alt="{_e(alt)}" src="data:image/png;base64,{png_b64}">'


def _note(text: str) -> str:
    return f'<p class="note">{_e(text)}</p>' if text else ""


def _metric_rows(*dicts: dict[str, float]) -> list[list[Any]]:
    return [[k, metric_unit(k), *(d.get(k, float("nan")) for d in dicts)] for k in dicts[0]]


def _regions(a: SessionAnalysis) -> str:
    out = [f"<h3>Regions: {_e(a.regions_kind)}</h3>"]
    if a.regions is None:
        return "".join(out) + _note(a.regions_note)
    r = a.regions
    out.append(_note(f"A cell is loaded above {r.threshold_kpa:g} kPa (the threshold of the masks and of the contact "
                     f"area); PTI = ∫ peak pressure dt and FTI = ∫ force dt over {r.integrated_s:.2f} s of frames "
                     "present; force = Σ pressure × cell area."))
    rows = []
    for name, reg in r.regions.items():
        present = ~r.missing
        rows.append([name, reg.n_cells, float(reg.force_n[present].mean()) if present.any() else float("nan"),
                     float(reg.peak_kpa[present].max()) if present.any() else float("nan"),
                     float(reg.contact_area_cm2[present].mean()) if present.any() else float("nan"),
                     reg.pti_kpa_s, reg.fti_n_s])
    out.append(_table(["region", "cells", "mean force (N)", "peak pressure (kPa)", "mean contact area (cm²)",
                       "PTI (kPa·s)", "FTI (N·s)"], rows))
    return "".join(out)


def _conditions(a: SessionAnalysis) -> str:
    out = ["<h3>Conditions</h3>", _note(a.conditions_note)]
    if a.conditions:
        out.append(_table(["condition", "role", "start (s)", "duration (s)", "frames", "ISPGR", "note"],
                          [[r.label, r.role or "—", r.start_s, r.duration_s, r.frames, r.ispgr, r.note]
                           for r in a.conditions]))
        keys = next((list(r.metrics) for r in a.conditions if r.metrics), [])
        if keys:
            out.append(_table(["metric per condition", "unit", *(r.label for r in a.conditions)],
                              [[k, metric_unit(k), *(r.metrics.get(k, float("nan")) for r in a.conditions)]
                               for k in keys]))
    if a.romberg:
        out.append(_note(a.romberg_note))
        out.append(_table(["quotient", "unit", "value"], [[k, "1", v] for k, v in a.romberg.items()]))
    elif a.conditions:
        out.append(_note(a.romberg_note))
    return "".join(out)


def _platform(a: SessionAnalysis) -> str:
    out = ["<h3>Force platform</h3>"]
    pf = a.platform
    out.append(_note(a.platform_note))
    if pf is None:
        return "".join(out)
    out.append(_table(["", "value", "unit"], [
        ["file", pf.path.name, ""], ["platform rate", pf.rate_hz, "Hz"],
        ["lag (platform time − mat time)", pf.lag_s, "s"], ["correlation at the lag", pf.r, "1"],
        ["overlap", pf.overlap_s, "s"], ["Eu (eq. 3.1)", pf.eu_cm, "cm"], ["Eu M-L (eq. 3.2)", pf.eu_ml_cm, "cm"],
        ["Eu A-P (eq. 3.2)", pf.eu_ap_cm, "cm"]]))
    out.append(_note("Eu at the mat's frame times, the platform interpolated there, both mean-removed, before "
                     "the preprocessing (as the thesis defines it); the metrics below after it, each on its own "
                     "samples within the overlap."))
    out.append(_table(["metric", "unit", "mat", "platform"], _metric_rows(pf.mat, pf.fp)))
    out.append(_img(overlay_png(pf.t_s, pf.mat_cm, pf.fp_cm), "mat and platform CoP overlaid"))
    return "".join(out)


def session_section(a: SessionAnalysis, index: int) -> str:
    """One session's part of the page."""
    rec = a.record
    out = [f'<section id="session-{index}"><h2>{_e(a.label)}</h2>']
    if a.simulated:
        out.append('<p class="sim">simulation: the session\'s metadata say a simulator wrote it '
                   "(no person stood on a mat).</p>")
    out.append("<h3>What was recorded</h3>")
    out.append(_table(["", "value"], a.recorded))
    out.append(f"<p>ISPGR (Scoppa et al. 2013; checked here: at least {a.ispgr_min_duration_s:g} s, at least "
               f"{a.ispgr_min_rate_hz:g} Hz): <b>{_e(a.ispgr)}</b> "
               f"({a.duration_s:.2f} s at {a.rate_hz:.2f} Hz).</p>")
    out.append("<h3>Pressure</h3>")
    out.append(_note(f"Over the {int(rec.usable.sum())} usable frames; {rec.source}."))
    out.append(_img(pressure_images_png(a.mean_kpa, a.peak_kpa, rec.geometry), "mean and peak pressure (kPa)"))
    out.append("<h3>Centre of pressure</h3>")
    out.append(_img(cop_png(rec.t_s, a.cop_cm, a.starts_s), "CoP stabilogram and time series (cm)"))
    out.append("<h3>Sway metrics</h3>")
    out.append(_table(["metric", "unit", "value"], _metric_rows(a.sway)))
    out.append("<h3>Posturography descriptors (Quijoux et al. 2021)</h3>")
    if a.descriptors:
        out.append(f"<details open><summary>{len(a.descriptors)} descriptors</summary>")
        out.append(_table(["descriptor", "unit", "value"],
                          [[k, descriptor_unit(k), v] for k, v in a.descriptors.items()]))
        out.append("</details>")
    else:
        out.append(_note(a.descriptors_note))
    out.append(_regions(a))
    out.append(_conditions(a))
    out.append(_platform(a))
    out.append("<h3>Processing parameters</h3>")
    out.append(_table(["parameter", "value"], [[k, json.dumps(v, default=str, ensure_ascii=False)
                                                  if not isinstance(v, str) else v]
                                               for k, v in sorted(rec.params.items())]))
    out.append("</section>")
    return "".join(out)


def page(title: str, subject: str | None, sections: list[str], footer: list[tuple[str, str]]) -> str:
    """The whole HTML document."""
    head = (f'<!DOCTYPE html><html lang="en"><head><meta charset="utf-8"><title>{_e(title)}</title>'
            f'<meta name="viewport" content="width=device-width, initial-scale=1"><style>{_CSS}</style></head><body>')
    top = f"<h1>{_e(title)}</h1>" + (f"<p>Subject: {_e(subject)}</p>" if subject else "")
    end = "<h2>About this report</h2>" + _table(["", "value"], footer)
    return head + top + "".join(sections) + end + "</body></html>\n"

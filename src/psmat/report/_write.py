""":func:`write_report`: sessions in, one self-contained HTML file out (and a PDF on request)."""

from __future__ import annotations

import datetime as _dt
import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from .._atomic import write_text_atomic
from .._version import __version__
from ._analysis import analyse, preprocessing_line
from ._html import page, session_section
from ._item import ReportItem, merged_params
from ._pdf import write_pdf

__all__ = ["write_report", "render_report", "ReportResult"]


class ReportResult(os.PathLike):  # type: ignore[type-arg]
    """The HTML file written (a path-like) and what became of the PDF (:func:`write_report`)."""

    def __init__(self, html: Path, pdf: Path | None, pdf_note: str) -> None:
        self.html, self.pdf, self.pdf_note = html, pdf, pdf_note

    def __fspath__(self) -> str:
        return os.fspath(self.html)

    def __repr__(self) -> str:
        return f"ReportResult({str(self.html)!r}, pdf={None if self.pdf is None else str(self.pdf)!r})"


def _item(x: ReportItem | str | os.PathLike[str]) -> ReportItem:
    return x if isinstance(x, ReportItem) else ReportItem(session=x)


def write_report(out_html: str | os.PathLike[str], items: Sequence[ReportItem | str | os.PathLike[str]], *,
                 title: str | None = None, subject: str | None = None, params: dict[str, Any] | None = None,
                 pdf: bool | str | os.PathLike[str] | None = None) -> ReportResult:
    """Write a report of one or more sessions as one self-contained HTML file.

    Per session: what was recorded (device, profile, duration, rate, frames missing, whether a
    simulator wrote it), mean and peak pressure images (kPa), the CoP (stabilogram and time series,
    cm), the sway metrics and the 72 descriptors with their units after one preprocessing
    (``params["preset"]``), the ISPGR flag, the regions (feet, or seat for a seated trial: force,
    peak, contact area, PTI, FTI, threshold stated), the conditions the markers cut the session into
    with their metrics and the Romberg quotients when an eyes-open and an eyes-closed condition
    exist, and with a platform file its alignment, Eu and the overlay; then the processing
    parameters, the psmat version and the date. Figures are base64 PNGs inside the page; nothing
    is fetched from elsewhere. The file is written atomically.

    Parameters
    ----------
    out_html : path
        The HTML file (its folder must exist; an existing file is replaced).
    items : sequence of ReportItem or path
        The sessions, in the page's order (a bare path is a session without platform).
    title : str, optional
        The page's title; default "psmat report" and the first session's name.
    subject : str, optional
        A line under the title (who was measured).
    params : dict, optional
        Overrides of :data:`DEFAULT_PARAMS` (preset, regions' threshold, IECM method, calibration,
        alignment, ISPGR limits).
    pdf : bool or path, optional
        True: also print ``out_html`` with ``.pdf`` for ``.html``; a path: print there. With
        Chromium, else WeasyPrint; neither: the HTML is written and ``pdf_note`` says why there is
        no PDF.

    Returns
    -------
    ReportResult
        Path-like to the HTML; ``.pdf`` (None without one) and ``.pdf_note``.

    Raises
    ------
    ValueError
        No session, a bad parameter, a session or platform file the report cannot use (one line,
        naming the file).
    """
    out = Path(out_html)
    write_text_atomic(out, render_report(items, title=title, subject=subject, params=params))
    if not pdf:
        return ReportResult(out, None, "")
    target = out.with_suffix(".pdf") if pdf is True else Path(pdf)
    try:
        done, engine = write_pdf(out, target)
    except RuntimeError as exc:  # PdfUnavailable too
        return ReportResult(out, None, " ".join(str(exc).split()))
    return ReportResult(out, done, f"PDF by {engine}")


def render_report(items: Sequence[ReportItem | str | os.PathLike[str]], *, title: str | None = None,
                  subject: str | None = None, params: dict[str, Any] | None = None) -> str:
    """The HTML page :func:`write_report` writes, as text (nothing written).

    Parameters and errors as for :func:`write_report` (no ``out_html``, no ``pdf``).
    """
    entries = [_item(x) for x in items]
    if not entries:
        raise ValueError("no session to report on")
    p = merged_params(params)
    sections = []
    for k, item in enumerate(entries):
        try:
            a = analyse(item, p)
        except ValueError as exc:
            msg = str(exc)
            name = Path(item.session).name
            raise ValueError(msg if name in msg else f"{name}: {msg}") from None
        sections.append(session_section(a, k + 1))
    now = _dt.datetime.now(_dt.timezone.utc).replace(microsecond=0).isoformat()
    footer = [("psmat version", __version__), ("written (UTC)", now),
              ("preprocessing", preprocessing_line(p["preset"])),
              ("descriptors", f"psmat.balance.descriptors, preset {p['preset']}"),
              ("report parameters", ", ".join(f"{k}={v}" for k, v in p.items()))]
    name = title or f"psmat report: {entries[0].label or Path(entries[0].session).name}"
    return page(name, subject, sections, footer)

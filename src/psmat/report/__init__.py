"""A report of recorded sessions as one self-contained HTML page (and a PDF on request).

* :func:`write_report` — sessions (:class:`ReportItem`: a session file, optionally a force-platform
  CSV and a label) → one HTML file: what was recorded, pressure images (kPa), the CoP (cm), sway
  metrics and the 72 descriptors with units, the ISPGR flag, regions, conditions and Romberg
  quotients from the session's markers, the platform comparison (alignment, Eu), the processing
  parameters, the psmat version and the date (:class:`ReportResult`); :func:`render_report` the
  same page as text, :func:`check_page` whether a text holds only what such a page can (no
  script, no link: for a page made where it is not trusted, a Dask worker);
* :data:`DEFAULT_PARAMS` — its options (the units of the descriptors are
  :func:`psmat.balance.descriptor_unit`, the ISPGR check :func:`psmat.balance.ispgr`);
* :func:`write_pdf` — an HTML file printed to PDF by headless Chromium or WeasyPrint
  (:class:`PdfUnavailable` when neither is here).

It reads sessions only through the processing layers (:mod:`psmat.process`, :mod:`psmat.balance`,
:mod:`psmat.regions`, :mod:`psmat.io`) and never a study. ``psmat report`` is its command.
Each lives in a private module of this package; the names below are the package's API.
"""

from ._check import check_page
from ._item import DEFAULT_PARAMS, ReportItem
from ._pdf import PdfUnavailable, write_pdf
from ._write import ReportResult, render_report, write_report

__all__ = ["write_report", "render_report", "check_page", "ReportItem", "ReportResult", "DEFAULT_PARAMS",
           "write_pdf", "PdfUnavailable"]

"""A report's HTML printed to PDF: headless Chromium (``--print-to-pdf``) when one is installed, else
WeasyPrint when it is importable, else one line saying that neither was found.

The browser is found by :func:`psmat._browser.find_chromium` (``$PSMAT_CHROMIUM``, then the usual
names on PATH), the lookup the headless driver of :mod:`psmat.bench.chromium` uses. The PDF is
written atomically.
"""

from __future__ import annotations

import os
import subprocess
import tempfile
from pathlib import Path

from .._atomic import replacing
from .._browser import CANDIDATES, find_chromium

__all__ = ["write_pdf", "PdfUnavailable"]

#: how long the browser may take to print (s): a hang guard, not a performance claim
_TIMEOUT_S = 120.0


class PdfUnavailable(RuntimeError):
    """No way to print a PDF here; the message is one line saying what was looked for."""


def _chromium(exe: str, html_path: Path, pdf_tmp: Path) -> None:
    with tempfile.TemporaryDirectory(prefix="psmat-report-") as profile:
        argv = [exe, "--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage",
                f"--user-data-dir={profile}", "--no-first-run", "--no-pdf-header-footer",
                f"--print-to-pdf={pdf_tmp}", html_path.resolve().as_uri()]
        done = subprocess.run(argv, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                              timeout=_TIMEOUT_S, check=False, start_new_session=True)
    if not pdf_tmp.is_file() or pdf_tmp.stat().st_size == 0:
        tail = " | ".join(done.stdout.decode(errors="replace").strip().splitlines()[-3:])
        raise RuntimeError(f"{exe} wrote no PDF (exit status {done.returncode}): {tail}")


def write_pdf(html_path: str | os.PathLike[str], pdf_path: str | os.PathLike[str]) -> tuple[Path, str]:
    """Print the HTML file at ``html_path`` to ``pdf_path``; the path and the engine used.

    Raises
    ------
    PdfUnavailable
        Neither Chromium nor WeasyPrint is here.
    RuntimeError
        The engine failed (one line).
    """
    src, out = Path(html_path), Path(pdf_path)
    exe = find_chromium()
    if exe is not None:
        with replacing(out) as tmp:
            _chromium(exe, src, Path(tmp))
        return out, f"Chromium ({exe})"
    try:
        import weasyprint  # type: ignore[import-not-found]
    except ImportError:
        raise PdfUnavailable(f"no PDF: neither Chromium ($PSMAT_CHROMIUM, {', '.join(CANDIDATES)} on PATH) nor "
                             "WeasyPrint (pip install weasyprint) was found") from None
    with replacing(out) as tmp:
        weasyprint.HTML(filename=str(src)).write_pdf(str(tmp))
    return out, "WeasyPrint"

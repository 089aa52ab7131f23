"""Where the Chromium executable is: one lookup for the headless browser driver
(:mod:`psmat.bench.chromium`) and the report's PDF printer (:mod:`psmat.report`)."""

from __future__ import annotations

import os
import shutil

__all__ = ["CANDIDATES", "find_chromium"]

#: executables tried, in order, by :func:`find_chromium` (after ``$PSMAT_CHROMIUM``)
CANDIDATES = ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable", "chrome")


def find_chromium() -> str | None:
    """The Chromium executable: ``$PSMAT_CHROMIUM`` when set, else the first of :data:`CANDIDATES` on PATH.

    Returns
    -------
    str or None
        Its path; None when there is none.
    """
    env = os.environ.get("PSMAT_CHROMIUM")
    if env:
        return shutil.which(env) or (env if os.access(env, os.X_OK) else None)
    return next((found for found in map(shutil.which, CANDIDATES) if found), None)

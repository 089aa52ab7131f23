"""Files of a simulated study's ``truth/`` folder written the same way every time (docs/spec.md §6).

Same arguments and seed → same bytes: indented JSON with NumPy values as plain numbers, and
``.npz`` archives whose member dates are fixed.
"""

from __future__ import annotations

import io as _io
import json
import os
import zipfile
from typing import Any

import numpy as np

__all__ = ["truth_json", "save_npz_stable"]


def truth_json(obj: Any) -> str:
    """Indented JSON (numpy scalars and arrays as numbers and lists), ending in a newline."""

    def default(o: Any) -> Any:
        if isinstance(o, np.ndarray):
            return o.tolist()
        if isinstance(o, (np.floating, np.integer, np.bool_)):
            return o.item()
        raise TypeError(f"not JSON serialisable: {type(o).__name__}")

    return json.dumps(obj, indent=2, default=default, allow_nan=False) + "\n"


def save_npz_stable(path: str | os.PathLike[str], arrays: dict[str, Any]) -> None:
    """``numpy.savez_compressed`` with fixed member dates, so the same arrays give the same bytes."""
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as z:
        for name, a in arrays.items():
            buf = _io.BytesIO()
            np.lib.format.write_array(buf, np.asarray(a), allow_pickle=False)
            info = zipfile.ZipInfo(f"{name}.npy", date_time=(1980, 1, 1, 0, 0, 0))
            info.compress_type = zipfile.ZIP_DEFLATED
            z.writestr(info, buf.getvalue())

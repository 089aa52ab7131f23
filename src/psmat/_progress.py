"""The progress bar psmat draws: tqdm's notebook widget where ipywidgets can draw it, tqdm's plain
text bar everywhere else.

``tqdm.auto`` on its own warns on import (``TqdmWarning: IProgress not found``) in a Jupyter kernel
without ipywidgets; picking the plain bar there avoids the cause of that warning.
"""

from __future__ import annotations

from importlib.util import find_spec

if find_spec("ipywidgets") is not None:
    from tqdm.auto import tqdm
else:
    from tqdm.std import tqdm

__all__ = ["tqdm"]

"""Live display of a mat: raw image, crosstalk-free pressure and the CoP trace.

* :class:`LiveView` - processing and matplotlib artists for one :class:`psmat.acquire.Device`
  (or anything with ``read()``, ``latest()`` and ``stats``); :meth:`LiveView.update` is the
  per-redraw step and runs headless (Agg) as well as in a window.
* :func:`run_view` - the draw loop used by ``psmat view``: a window (or a headless run with
  a screenshot), closing, Ctrl-C and a vanished port handled.
* :func:`mat_image`, :func:`mat_extent_cm` - a frame drawn in its mat's coordinates (cm), for
  any profile geometry (axes along rows or columns, mirrored, shifted origin).
"""

from ._mat_image import mat_extent_cm, mat_image
from .view import LiveView, ViewResult, run_view

__all__ = ["LiveView", "ViewResult", "run_view", "mat_image", "mat_extent_cm"]

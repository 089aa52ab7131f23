"""Balance (thesis chapter 3, SPEC §7): centre of pressure and the thesis' metrics.

:func:`cop` is the centre of pressure of pressure images; :func:`eu` the thesis' distance
between two CoP traces (eq. 3.1); :func:`sway` the posturography metrics of a trace;
:func:`align` the time alignment of the mat with a force platform.
"""

from .align import Alignment, align
from .cop import cell_centres_cm, cop
from .metrics import eu
from .sway import Sway, sway

__all__ = ["cop", "cell_centres_cm", "eu", "sway", "Sway", "align", "Alignment"]

"""Balance (thesis chapter 3, docs/spec.md §7): centre of pressure and the thesis' metrics.

:func:`cop` is the centre of pressure of pressure images; :func:`eu` the thesis' distance
between two CoP traces (eq. 3.1); :func:`sway` the posturography metrics of a trace;
:func:`align` the time alignment of the mat with a force platform; :func:`scale_factor`
the SCHC factor of eq. 3.3; :func:`equilibrate` a per-cell gain map learned from a standing
trial (beyond the thesis: the SCHC-EQ variant).
"""

from .align import Alignment, align
from .cop import cell_centres_cm, cop
from .equilibrate import Equilibration, equilibrate
from .metrics import eu
from .scale import mean_force_n, scale_factor
from .sway import Sway, sway

__all__ = ["cop", "cell_centres_cm", "eu", "sway", "Sway", "align", "Alignment", "scale_factor", "mean_force_n",
           "equilibrate", "Equilibration"]

"""The thesis' experiments on IECM, reproduced in simulation (thesis §2.3, Appendix C), and
the balance study's measurements beyond the thesis.

One module per study; each function is seeded, takes a size argument so it can run small,
and returns a result object with the arrays, a ``.table()`` text (Markdown) and a
``.plot()`` figure (matplotlib, imported only when plotting):

* :func:`table_2_4` — Table 2.4 / Fig. 2.12: voltage noise → conductance uncertainty
  through the DAQ (:mod:`.measurement_noise`).
* :func:`uncertainty_random` — Fig. 2.11/2.13: eq. 2.11 vs Monte Carlo for a random 16×16
  array (:mod:`.random_array`).
* :func:`uncertainty_maps` — Fig. 2.15/2.16: the same for simulated standing and
  semi-tandem stances (:mod:`.stance_maps`).
* :func:`resistor_board_6x6` — §2.3.3, Fig. 2.19/2.20: a 6×6 resistor board read by the
  16×16 DAQ, experimental SD over frames vs eq. 2.11 (:mod:`.resistor_board`).
* :func:`qzpm_tables` / :func:`figure_c4` — Appendix C, Tables C.1/C.2, Fig. C.4:
  IECM adapted to the QZPM readout vs the closed-form QZPM (:mod:`.qzpm_acceptance`;
  needs :mod:`psmat.qzpm`).

Beyond the thesis, in simulation, three measurements run as commands
(``python -m psmat.experiments --help`` lists them; each prints its table):

* ``python -m psmat.experiments equilibration`` — SCHC-EQ (a per-cell equilibration,
  :func:`psmat.balance.equilibrate`) against SCHC.
* ``python -m psmat.experiments dynamic_correction`` — SCHC-DYN (a linear correction fitted
  on other volunteers, :mod:`psmat.study` (``_dynamic.py``)) against SCHC, and the models compared.
* ``python -m psmat.experiments pressure_calibration`` — the kPa of twin mats of unknown
  sensitivity and cell gains against the truth, before and after the ``psmat calibrate``
  pressure steps (:mod:`.pressure_calibration`).

Figures: :func:`save_figure` writes PNGs to ``$PSMAT_FIGURES`` or ``./psmat_figures``.
The notebooks in ``notebooks/`` run each study; ``docs/thesis_results.md`` compares the
numbers with the thesis'.
"""

from ._common import figures_dir, save_figure
from .measurement_noise import THESIS_TABLE_2_4, Table24Result, table_2_4
from .qzpm_acceptance import THESIS_TABLE_C1, THESIS_TABLE_C2, QzpmCase, QzpmTables, figure_c4, qzpm_case, qzpm_tables
from .random_array import RandomArrayUncertainty, uncertainty_random
from .resistor_board import BoardResult, board_resistors, resistor_board_6x6
from .stance_maps import STANCES, StanceUncertainty, stance_conductance, stance_pressure, uncertainty_maps

__all__ = [
    "table_2_4", "Table24Result", "THESIS_TABLE_2_4",
    "uncertainty_random", "RandomArrayUncertainty",
    "uncertainty_maps", "StanceUncertainty", "stance_pressure", "stance_conductance", "STANCES",
    "resistor_board_6x6", "BoardResult", "board_resistors",
    "qzpm_tables", "qzpm_case", "figure_c4", "QzpmTables", "QzpmCase", "THESIS_TABLE_C1", "THESIS_TABLE_C2",
    "figures_dir", "save_figure",
]

"""Scoring posture models (thesis §4.4, Table 4.4) and the linear baseline beside the CNN.

Numpy and matplotlib only (no PyTorch): the learning (:mod:`psmat.posture.learn`) scores with these.
Private modules:

* ``_metrics`` — MSE and R² per output (eqs. 4.2, 4.3), the rows of Table 4.4 and their CSV;
* ``_thesis_table`` — the thesis' Table 4.4, transcribed once;
* ``_baseline`` — ridge regression on a PCA of the window-mean image (beyond the thesis);
* ``_calibration`` — a new subject's calibration phase, the windows scored after it, the
  offset-calibrated and invariant ridge variants (beyond the thesis);
* ``_figures``, ``_heldout_figure`` — predicted against measured angles (Figs. 4.13–4.16), R² bars.
"""

from ._baseline import COMPONENTS, PENALTIES, RidgePCA, fit_ridge_pca, ridge_pca_rows, window_mean_images
from ._calibration import HeldoutWindows, apply_offsets, heldout_windows, offsets_from_calibration, ridge_variants
from ._figures import plot_predictions
from ._heldout_figure import plot_r2_bars
from ._metrics import OUTPUTS, TABLE44_COLUMNS, mse_per_output, r2_per_output, table44_row, write_table44
from ._thesis_table import TABLE_4_4, Table44Row

__all__ = [
    # metrics and Table 4.4
    "OUTPUTS", "mse_per_output", "r2_per_output", "table44_row", "TABLE44_COLUMNS", "write_table44",
    "Table44Row", "TABLE_4_4",
    # the linear baseline
    "COMPONENTS", "PENALTIES", "RidgePCA", "window_mean_images", "fit_ridge_pca", "ridge_pca_rows",
    # held-out subjects' calibration
    "HeldoutWindows", "heldout_windows", "offsets_from_calibration", "apply_offsets", "ridge_variants",
    # figures
    "plot_predictions", "plot_r2_bars",
]

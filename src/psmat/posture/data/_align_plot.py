"""Figure of a mat-to-IMU alignment (thesis Fig. 4.11: the summed mat signal and the summed
angles over time); matplotlib's object API, imported when a figure is drawn."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

from ._align import MatImuAlignment

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = ["plot_mat_imu_alignment"]


def plot_mat_imu_alignment(result: MatImuAlignment, *, path: str | Path | None = None, title: str = "") -> Figure:
    """The two standardised series of :func:`~psmat.posture.data.align_mat_imu` on the IMU's clock.

    The mat's series is drawn at its aligned times (mat time + ``lag_s``); the summed angles are
    multiplied by the relation's sign (labelled so) so that the two curves overlay.

    Parameters
    ----------
    result : MatImuAlignment
        The alignment.
    path : str or Path, optional
        PNG to write.
    title : str
        Figure title; by default the lag and r.

    Returns
    -------
    matplotlib.figure.Figure
    """
    from matplotlib.figure import Figure

    if not isinstance(result, MatImuAlignment):
        raise TypeError(f"result must be a MatImuAlignment (from align_mat_imu), got {type(result).__name__}")
    fig = Figure(figsize=(8, 3.5), constrained_layout=True)
    ax = fig.subplots()
    ax.plot(result.t_s, result.mat, lw=1.0, label="summed mat conductance")
    ax.plot(result.t_s, result.sign * result.imu, lw=1.0,
            label="summed angles" if result.sign > 0 else "− summed angles (negative relation)")
    ax.set_xlabel("time on the IMU clock (s)")
    ax.set_ylabel("standardised, (x − mean) / SD")
    ax.legend(loc="upper right", fontsize="small")
    how = "manual" if result.manual else "cross-correlation"
    ax.set_title(title or f"mat + {result.lag_s:.2f} s = IMU time ({how}), r = {result.r:.2f}")
    if path is not None:
        fig.savefig(Path(path), dpi=100)
    return fig

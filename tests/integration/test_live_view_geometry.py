""":class:`psmat.live.LiveView` on a mat whose profile runs its axes otherwise (mirrored, along the
rows, origin shifted): the CoP is in the profile's coordinates and its marker sits on the loaded cell.

One cell loaded: the counts a real chain reads (the crosstalk of the array, :func:`psmat.iecm.forward`,
through the measurement chain's 12-bit ADC, :meth:`psmat.Circuit.counts`), processed by the view's
chain (IECM, sensor model). The CoP of one loaded cell is that cell's centre, computed by hand.
"""

from __future__ import annotations

import time

import matplotlib

matplotlib.use("Agg")

import numpy as np  # noqa: E402
import pytest  # noqa: E402

from psmat import iecm  # noqa: E402
from psmat.acquire import FrameBatch  # noqa: E402
from psmat.circuit import Circuit  # noqa: E402
from psmat.live import LiveView  # noqa: E402
from psmat.profile import Geometry, load_profile  # noqa: E402

G_REST_S = 1e-7  # an unloaded cell (S)


class _Frames:
    """The same counts frame ``n`` times, 10 ms apart, in one batch (deterministic, no pty)."""

    def __init__(self, counts: np.ndarray, n: int = 5) -> None:
        self.shape = counts.shape
        self.port = "frames"
        self.description = {"rate": 100}
        self._counts, self._n = counts, n
        self.stats = type("S", (), {"frames": 0, "invalid": 0, "dropped_wire": 0, "dropped_buffer": 0})()

    def read(self, n: int | None = None, timeout_s: float | None = None) -> FrameBatch:
        f = np.repeat(self._counts[None], self._n, axis=0)
        seq = np.arange(self._n)
        self.stats.frames += self._n
        return FrameBatch(f, np.full(self._n, time.time()), np.ones(self._n, bool), seq, seq * 10_000)


# (x, y, the loaded cell (row, column), its centre (x, y) in cm by hand) on a 5 x 7 mat, 3 cm pitch,
# cell (0, 0) at (10, -4) cm
CASES = [
    # x falls with the column: x = 10 - 3 p, y = -4 + 3 i
    ("-columns", "+rows", (1, 5), (10.0 - 15.0, -4.0 + 3.0)),
    # x along the rows, y falls with the column: x = 10 + 3 i, y = -4 - 3 p
    ("+rows", "-columns", (3, 2), (10.0 + 9.0, -4.0 - 6.0)),
]


@pytest.mark.parametrize("x,y,cell,centre_cm", CASES)
def test_the_cop_of_one_loaded_cell_is_its_centre_and_the_marker_is_on_it(x, y, cell, centre_cm) -> None:
    geometry = Geometry((5, 7), 3.0, (10.0, -4.0), x, y)
    g = np.full((5, 7), G_REST_S)
    g[cell] = 2e-3  # a loaded cell (about 500 ohm)
    circuit = Circuit()
    counts = circuit.counts(iecm.forward(g))
    view = LiveView(_Frames(counts), geometry=geometry, circuit=circuit, g_rest=G_REST_S)
    try:
        assert view.update()
        assert view.geometry == geometry and view.pitch_cm == 3.0
        cop = view.cop_cm[-1]
        assert cop == pytest.approx(centre_cm, abs=0.05)  # quantisation leaves a trace on the other cells
        # the pressure image: its brightest pixel is the one under the CoP marker
        mx, my = (float(v[0]) for v in view.cop_marker.get_data())
        img = np.asarray(view.im_p.get_array())
        left, right, bottom, top = view.im_p.get_extent()
        assert left < right and bottom < top
        col = int((mx - left) / (right - left) * img.shape[1])
        row = int((my - bottom) / (top - bottom) * img.shape[0])
        assert (row, col) == np.unravel_index(np.argmax(img), img.shape)
        assert img[row, col] > 0 and view.pressure_kpa[cell] == img[row, col]
        # and the raw image the same way
        raw = np.asarray(view.im_raw.get_array())
        assert (row, col) == np.unravel_index(np.argmax(raw), raw.shape)
        assert view.ax_p.get_xlabel() == "M-L x (cm)" and view.ax_p.get_ylabel() == "A-P y (cm)"
    finally:
        view.close()


def test_a_profile_gives_the_view_its_pitch_and_circuit() -> None:
    prof = load_profile("psm8")  # 8 x 8 cells of 4 cm
    g = np.full((8, 8), G_REST_S)
    g[2, 6] = 2e-3
    counts = prof.circuit().counts(iecm.forward(g))
    view = LiveView(_Frames(counts), profile=prof, g_rest=G_REST_S)
    try:
        assert view.pitch_cm == 4.0 and view.geometry == prof.geometry
        assert view.im_raw.get_extent() == pytest.approx((-2.0, 30.0, -2.0, 30.0))  # centres 0 ... 28 cm
        assert view.update()
        assert view.cop_cm[-1] == pytest.approx((6 * 4.0, 2 * 4.0), abs=0.05)  # cell (2, 6) at (24, 8) cm
    finally:
        view.close()
    with pytest.raises(ValueError, match="not a mat"):
        LiveView(_Frames(counts), profile=load_profile("imu"))

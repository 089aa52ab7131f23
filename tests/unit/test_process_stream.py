"""One processing chain: :class:`psmat.process.Processor` pushed in chunks,
:func:`psmat.process.process_counts` and the live view give the same numbers.

Frames are 64 Hz so that every frame time k/64 s and every period between frames is an exact
binary fraction: the view's periods (differences of frame times) then equal ``1/RATE`` bit for
bit, and the chain is deterministic (IECM on one worker), so G, g and pressure compare exactly.
A CoP is a ratio of two sums over the R*C cells, and numpy sums a frame in an order that can
depend on how many frames are in the call; a sum of n non-negative terms carries a relative
rounding error of at most (n - 1) u in any order (u = eps/2, Higham, Accuracy and Stability,
eq. 4.4), so the same CoP computed in two batchings differs by at most about n eps (relative).
"""

from __future__ import annotations

from types import SimpleNamespace

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402

from psmat import Circuit, iecm  # noqa: E402
from psmat import process  # noqa: E402
from psmat.frames import FrameBatch  # noqa: E402
from psmat.live import LiveView  # noqa: E402
from psmat.sensor import MPICreep  # noqa: E402
from psmat.twin import MatPhysics, quiet_standing  # noqa: E402
from psmat.units import PSI_KPA  # noqa: E402

RATE = 64.0  # frames/s
DT = 1.0 / RATE
G_REST = 1e-7  # S: the twin's unloaded leakage (MatPhysics default), the view's default
INVALID, SHORT_FRAME = 40, 70  # a frame that failed its check on the wire, a frame with a short reading
COP_RTOL = 16 * 16 * np.finfo(np.float64).eps  # the same CoP summed in another order (module docstring)


@pytest.fixture(scope="module")
def recording() -> tuple[np.ndarray, np.ndarray]:
    """Twin counts (128, 16, 16) of a standing person, with two open cells, one invalid and one short frame."""
    scene = quiet_standing(2.0, RATE, seed=1)
    counts = MatPhysics((16, 16), dt=DT, seed=2).counts(scene.pressure_psi).astype(np.uint16)
    full_scale = Circuit().full_scale
    counts[:, 0, 0] = full_scale  # open: beyond what the ADC resolves (docs/spec.md §2)
    counts[::3, 15, 15] = full_scale
    counts[SHORT_FRAME, 3, 3] = 0  # short: count 0 on the low side
    valid = np.ones(len(counts), bool)
    valid[INVALID] = False
    return counts, valid


class _Frames:
    """A frame source for :class:`LiveView`: counts in batches of ``per_read``, frame k numbered k, no device clock."""

    def __init__(self, counts: np.ndarray, valid: np.ndarray, per_read: int) -> None:
        self.shape = counts.shape[1:]
        self.port = "frames"
        self.description = {"rate": RATE}
        self.stats = SimpleNamespace(frames=0, invalid=0, dropped_wire=0, dropped_buffer=0)
        self._counts, self._valid, self._per, self._k = counts, valid, per_read, 0

    def read(self, n: int | None = None, timeout_s: float | None = None) -> FrameBatch:
        k = self._k
        f, v = self._counts[k:k + self._per], self._valid[k:k + self._per]
        self._k += len(f)
        self.stats.frames += int(v.sum())
        self.stats.invalid += int((~v).sum())
        seq = np.arange(k, k + len(f), dtype=np.int64)
        return FrameBatch(f, np.zeros(len(f)), v, seq, np.full(len(f), -1, np.int64))


def _run_view(counts: np.ndarray, valid: np.ndarray, iecm_on: bool) -> LiveView:
    """A live view fed every frame (a budget large enough that none is skipped)."""
    view = LiveView(_Frames(counts, valid, per_read=16), iecm=iecm_on, rate_hz=RATE, g_rest=G_REST,
                    budget_s=10.0, history_s=1e3)
    try:
        for _ in range(-(-len(counts) // 16)):
            view.update()
    finally:
        view.close()
        plt.close(view.fig)
    return view


def test_the_view_shows_the_numbers_of_process_counts(recording) -> None:
    counts, valid = recording
    out = process.process_counts(counts, DT, valid=valid, g_rest=G_REST, threads=1)
    assert not out.usable[INVALID] and not out.usable[SHORT_FRAME] and out.usable.sum() == len(counts) - 2
    view = _run_view(counts, valid, iecm_on=True)
    assert view.processed == len(counts) - 2 and view.unusable == 2 and view.skipped == 0
    np.testing.assert_array_equal(view.cop_t, np.flatnonzero(out.usable) / RATE)
    np.testing.assert_allclose(view.cop_cm, out.cop_cm[out.usable], rtol=COP_RTOL, atol=0)
    np.testing.assert_array_equal(view.G, out.G[-1])
    np.testing.assert_array_equal(view.pressure_kpa, out.pressure_kpa[-1])


def test_an_open_reading_is_the_open_floor_in_every_product() -> None:
    """A hand-made frame: uniform load, one open cell. The raw CoP is worked out by hand."""
    circuit = Circuit()
    frames = np.full((3, 4, 5), 1500, np.uint16)
    frames[:, 2, 4] = circuit.full_scale  # open
    out = process.process_counts(frames, DT, circuit=circuit, threads=1)
    floor = process.open_floor(circuit)
    G_ok = float(circuit.conductance(1500))
    assert np.all(out.usable) and np.all(out.G[:, 2, 4] == floor)
    assert np.all(np.isfinite(out.g)) and np.all(np.isfinite(out.pressure_kpa))
    # centroid of 19 cells of G_ok and one of the floor at (x, y) = (8, 4) cm on a 2 cm pitch:
    # sum over all 20 cells of G_ok x is G_ok * 4 rows * (0+2+4+6+8) cm, less (G_ok - floor) at the open cell
    total = 20 * G_ok - (G_ok - floor)
    x = (G_ok * 4 * 20.0 - (G_ok - floor) * 8.0) / total
    y = (G_ok * 5 * 12.0 - (G_ok - floor) * 4.0) / total
    np.testing.assert_allclose(out.cop_raw_cm, np.tile([x, y], (3, 1)), rtol=1e-12)
    view = _run_view(frames, np.ones(3, bool), iecm_on=False)
    np.testing.assert_array_equal(view.G, out.G[-1])
    np.testing.assert_array_equal(view.cop_cm, out.cop_raw_cm)


def _g_of(counts: np.ndarray, usable: np.ndarray) -> np.ndarray:
    """IECM of the usable frames, open readings at the open floor (the chain's first two steps)."""
    circuit = Circuit()
    G, flags = circuit.conductance(counts[usable], return_flags=True)
    G = np.where(flags == Circuit.OPEN, process.open_floor(circuit), G)
    return iecm.solve(G, threads=1, rtol=process.IECM_RTOL)


def test_a_missing_frame_steps_the_sensor_model_over_its_time(recording) -> None:
    """Creep goes on while a frame is lost: the frame after a gap is stepped with 2 periods (eq. 2.23)."""
    counts, valid = recording
    out = process.process_counts(counts, DT, valid=valid, g_rest=G_REST, threads=1)
    u = np.maximum(_g_of(counts, out.usable) - G_REST, 0.0)
    sensor, state = MPICreep.thesis(), MPICreep.thesis().rest_state((16, 16))
    # u holds the usable frames 0..39 | 41 (after the gap) | 42..69 | 71 (after the gap) | 72..127
    steps = [(0, 40, DT), (40, 41, 2 * DT), (41, 69, DT), (69, 70, 2 * DT), (70, 126, DT)]
    expected = np.concatenate([sensor.inverse(u[a:b], dt, state) for a, b, dt in steps]) * PSI_KPA
    np.testing.assert_array_equal(out.pressure_kpa[out.usable], expected)
    assert np.all(np.isnan(out.pressure_kpa[[INVALID, SHORT_FRAME]]))
    # the gap matters in this recording: one period instead of two gives other pressures
    replay = sensor.rest_state((16, 16))
    sensor.inverse(u[:40], DT, replay)
    assert not np.array_equal(sensor.inverse(u[40:41], DT, replay) * PSI_KPA, expected[40:41])


def test_chunked_pushes_give_the_numbers_of_one_push(recording) -> None:
    counts, valid = recording
    whole = process.process_counts(counts, DT, valid=valid, g_rest=G_REST, threads=1)
    # chunk ends fall on the invalid frame (40 is the last of 0..40) and just before the short one
    edges = [0, 1, 8, 41, 70, 71, 100, len(counts)]
    with process.Processor((16, 16), g_rest=G_REST) as proc:
        parts = [proc.push(counts[a:b], DT, valid=valid[a:b]) for a, b in zip(edges[:-1], edges[1:])]
    for name in ("G", "g", "pressure_kpa", "usable"):
        np.testing.assert_array_equal(np.concatenate([getattr(p, name) for p in parts]), getattr(whole, name),
                                      err_msg=name)
    for name in ("cop_cm", "cop_raw_cm"):
        np.testing.assert_allclose(np.concatenate([getattr(p, name) for p in parts]), getattr(whole, name),
                                   rtol=COP_RTOL, atol=0, err_msg=name)
    assert sum(p.params["frames_missing"] for p in parts) == whole.params["frames_missing"] == 2


def test_per_frame_periods_are_honoured(recording) -> None:
    counts, _ = recording
    counts = counts[:24]
    periods = np.where(np.arange(24) % 2 == 0, DT, 4 * DT)  # 1/64 s and 1/16 s alternately
    with process.Processor((16, 16), g_rest=G_REST) as proc:
        out = proc.push(counts, periods)
    u = np.maximum(_g_of(counts, np.ones(24, bool)) - G_REST, 0.0)
    sensor = MPICreep.thesis()
    state = sensor.rest_state((16, 16))
    expected = np.concatenate([sensor.inverse(u[k:k + 1], float(periods[k]), state) for k in range(24)]) * PSI_KPA
    np.testing.assert_array_equal(out.pressure_kpa, expected)
    with process.Processor((16, 16), g_rest=G_REST) as proc:
        assert not np.array_equal(proc.push(counts, DT).pressure_kpa, expected)


@pytest.mark.parametrize("shape, dt, valid, match", [
    ((2, 8, 16), DT, None, r"counts must be \(T, 16, 16\)"),
    ((3, 16, 16), [DT, DT], None, r"dt must be one frame period or one per frame \(3,\)"),
    ((3, 16, 16), -DT, None, "dt must be"),
    ((3, 16, 16), [DT, 0.0, DT], None, "dt must be"),
    ((3, 16, 16), DT, [True, False], r"valid must be \(3,\)"),
])
def test_bad_input_is_one_clear_error(shape, dt, valid, match) -> None:
    counts = np.full(shape, 1500, np.uint16)
    with process.Processor((16, 16)) as proc, pytest.raises(ValueError, match=match):
        proc.push(counts, dt, valid=valid)


def test_parallel_pushes_solve_every_frame(recording) -> None:
    """threads > 1: each push is a parallel batch, the first frame warm-started from the push before.
    Every frame is then the bounded solution of docs/spec.md §3: the forward model meets G to the solver's
    tolerance (process.IECM_RTOL) on the free cells, and over-predicts G on the cells held at g_floor."""
    counts = recording[0][:40]
    with process.Processor((16, 16), g_rest=G_REST, threads=2) as proc:
        parts = [proc.push(counts[a:b], DT) for a, b in ((0, 17), (17, 40))]
    assert all(p.solve_info.threads == 2 and p.solve_info.all_converged for p in parts)
    G = np.concatenate([p.G for p in parts])
    g = np.concatenate([p.g for p in parts])
    F = iecm.forward(g)
    held = g <= 1e-12 * (1 + 1e-9)  # at iecm.solve's default g_floor
    assert np.max(np.abs(F - G)[~held] / G[~held]) <= process.IECM_RTOL
    assert np.all(F[held] >= G[held])

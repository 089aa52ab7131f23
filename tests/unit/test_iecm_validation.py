"""Bad input gets a clear error, never a silent garbage answer."""

from __future__ import annotations

import numpy as np
import pytest

import psmat

GOOD = np.full((4, 4), 1e-3)


@pytest.mark.parametrize("fn", [psmat.iecm.forward, psmat.iecm.solve])
@pytest.mark.parametrize(
    "bad, exc, msg",
    [
        (np.where(np.eye(4, dtype=bool), np.nan, 1e-3), ValueError, "non-finite"),
        (np.where(np.eye(4, dtype=bool), np.inf, 1e-3), ValueError, "non-finite"),
        (np.where(np.eye(4, dtype=bool), -1e-3, 1e-3), ValueError, "negative"),
        (np.full(16, 1e-3), ValueError, "shape"),
        (np.full((2, 2, 2, 2), 1e-3), ValueError, "shape"),
        (np.full((1, 5), 1e-3), ValueError, "at least 2"),
        (np.full((4, 4), 1e-3 + 1e-4j), TypeError, "real numeric"),
        (np.full((4, 4), "1e-3"), TypeError, "real numeric"),
        (np.full((4, 4), None, dtype=object), TypeError, "real numeric"),
    ],
)
def test_bad_input(fn, bad, exc, msg):
    with pytest.raises(exc, match=msg):
        fn(bad)


def test_zero_measured_conductance_is_rejected():
    G = GOOD.copy()
    G[1, 2] = 0.0
    with pytest.raises(ValueError, match=r"zero or negative.*cell \(1, 2\)"):
        psmat.iecm.solve(G)


def test_error_names_frame_and_cell():
    G = np.full((3, 4, 4), 1e-3)
    G[2, 1, 3] = np.nan
    with pytest.raises(ValueError, match=r"frame 2, cell \(1, 3\)"):
        psmat.iecm.solve(G)


@pytest.mark.parametrize(
    "kwargs",
    [{"method": "magic"}, {"rtol": -1.0}, {"rtol": np.nan}, {"max_iter": 0}, {"beta": 0.0},
     {"g_floor": -1.0}, {"threads": 0}],
)
def test_bad_options(kwargs):
    with pytest.raises(ValueError):
        psmat.iecm.solve(np.stack([GOOD, GOOD]), **kwargs)


def test_g0_shape_mismatch():
    with pytest.raises(ValueError, match="g0"):
        psmat.iecm.solve(GOOD, g0=np.full((4, 5), 1e-3))


def test_integer_input_is_accepted_as_conductance():
    g = np.ones((3, 3), dtype=np.int64)  # 1 S everywhere
    np.testing.assert_allclose(psmat.iecm.forward(g), psmat.iecm.forward(g.astype(float)))


_RAW_COUNTS = [np.full((4, 4), 1000, dtype=np.uint16), np.full((3, 4, 4), 1000, dtype=np.int64),
               [[1000, 1200], [900, 4000]]]


@pytest.mark.parametrize("counts", _RAW_COUNTS)
def test_solve_refuses_raw_counts(counts):
    # ADC counts passed by mistake were solved as conductances: g ~ 1205 S, "converged"
    with pytest.raises(TypeError, match=r"integer.*psmat\.Circuit\(\)\.conductance\(counts\)") as err:
        psmat.iecm.solve(counts)
    assert "\n" not in str(err.value)


@pytest.mark.parametrize("counts", _RAW_COUNTS)
def test_stream_refuses_raw_counts(counts):
    # the streaming form takes the same measured G as solve: integers are counts, not S
    frame = np.asarray(counts)[-1] if np.ndim(counts) == 3 else counts
    with psmat.iecm.Stream(np.shape(frame)) as s:
        with pytest.raises(TypeError, match=r"integer.*psmat\.Circuit\(\)\.conductance\(counts\)"):
            s.push(frame)

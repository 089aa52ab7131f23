"""Frames that g_floor decides are reported, not passed off as solutions.

g_floor is the positivity bound of docs/spec.md §3 (1e-12 S by default), far below anything a mat
measures. A frame whose every cell ends on it holds no signal above the floor, and a g_floor
at or above a measured G forces that cell to the bound whatever the data say (a cell never
conducts more than the equivalent conductance measured across it, g <= G). Either way the
answer is the floor's, not the data's: a warning and a status, not "converged".
"""

from __future__ import annotations

import numpy as np
import pytest

import psmat


def _loaded(shape=(4, 4)) -> np.ndarray:
    g = np.full(shape, 1e-6)  # 1 MOhm background
    g[1:3, 1:3] = 5e-3  # a 200 Ohm load
    return g


@pytest.mark.parametrize("method", psmat.iecm.METHODS)
def test_a_frame_below_what_the_floor_itself_predicts_is_all_at_floor(method):
    g_floor = 1e-12
    # every cell at g_floor gives F(floor); half of it is unreachable by any g >= g_floor,
    # the bounded problem's answer is g = g_floor everywhere
    G = 0.5 * psmat.iecm.forward(np.full((4, 4), g_floor))
    with pytest.warns(RuntimeWarning, match="all_at_floor.*every cell ended at g_floor"):
        g, info = psmat.iecm.solve(G, method=method, g_floor=g_floor, return_info=True)
    np.testing.assert_allclose(g, g_floor, rtol=1e-9)
    assert info.status == "all_at_floor" and not info.converged and not info.all_converged


def test_only_the_empty_frame_of_a_batch_is_flagged():
    g = np.stack([_loaded(), _loaded()])
    G = psmat.iecm.forward(g)
    G[1] = 0.5 * psmat.iecm.forward(np.full((4, 4), 1e-12))  # nothing on the mat, noise below the floor's G
    with pytest.warns(RuntimeWarning, match=r"1 of 2 frame\(s\) did not converge.*all_at_floor"):
        sol, info = psmat.iecm.solve(G, threads=2, return_info=True)
    assert info.status.tolist() == ["converged", "all_at_floor"]
    assert info.converged.tolist() == [True, False]
    np.testing.assert_allclose(sol[0], g[0], rtol=1e-7)


@pytest.mark.parametrize("method", psmat.iecm.METHODS)
def test_a_floor_above_some_measured_G_is_reported(method):
    G = psmat.iecm.forward(_loaded())
    g_floor = 1e-4  # above the background's G (~1e-5 S with the crosstalk), below the load's
    assert G.min() < g_floor < G.max()
    with pytest.warns(RuntimeWarning, match="floor_above_data.*g_floor = 0.0001 S"):
        g, info = psmat.iecm.solve(G, method=method, g_floor=g_floor, return_info=True)
    assert info.status == "floor_above_data" and not info.converged
    assert np.all(g >= g_floor)


def test_a_floor_above_all_the_data_is_reported_as_such():
    G = psmat.iecm.forward(_loaded())
    with pytest.warns(RuntimeWarning, match="floor_above_data"):
        g, info = psmat.iecm.solve(G, g_floor=1.0, return_info=True)  # 1 S: above every G
    np.testing.assert_allclose(g, 1.0)  # every cell at the floor: the cause is the floor
    assert info.status == "floor_above_data"


def test_the_default_floor_leaves_noisy_frames_alone(rng):
    # quiet cells at the bound and the load free: a solution, without a warning (pytest: error)
    G = psmat.iecm.forward(_loaded((6, 6)))
    Gn = G * (1 + 0.02 * rng.standard_normal(G.shape))
    sol, info = psmat.iecm.solve(Gn, return_info=True)
    assert info.status == "bounded" and info.converged and 0 < info.at_bound < Gn.size


def test_the_stream_reports_the_same_floor_statuses_as_solve():
    # frames in a live stream get solve's statuses: an empty mat and a floor-decided frame are
    # not "converged" there either (no warning per frame: the status is the report)
    loaded = psmat.iecm.forward(_loaded())
    empty = 0.5 * psmat.iecm.forward(np.full((4, 4), 1e-12))
    with psmat.iecm.Stream((4, 4)) as s:
        statuses = [str(info.status) for _, _, info in s.process([loaded, empty, loaded])]
    assert statuses == ["converged", "all_at_floor", "converged"]
    with psmat.iecm.Stream((4, 4), g_floor=1e-4) as s:
        s.push(loaded)
        (_, g, info), = list(s.drain())
    assert str(info.status) == "floor_above_data" and not info.converged and np.all(g >= 1e-4)

"""psmat.balance.scale_factor (thesis eq. 3.3): f from the body weight, by hand and by round trip."""

from __future__ import annotations

import numpy as np
import pytest

from psmat.balance import scale_factor
from psmat.balance._scale import RTOL
from psmat.sensor import MPICreep

PSI_N_PER_CM2 = 6894.757e-4  # 1 psi on 1 cm² is 0.6894757 N


def _block(T=400, level_psi=10.0):
    p = np.zeros((T, 16, 16))
    p[:, 5:9, 6:11] = level_psi  # 20 cells
    return p


def test_a_mat_more_conductive_than_the_model_by_hand() -> None:
    # 20 cells at 10 psi on 4 cm² carry 20 · 10 · 4 · 0.6894757 N = 551.58 N; a mat 2.5x more
    # conductive than the nominal model needs f = 1 / 2.5 = 0.4 to carry that weight
    sensor = MPICreep.thesis()
    g_mat = sensor.direct(_block(), 0.01) * 2.5
    weight = 20 * 10.0 * 4.0 * PSI_N_PER_CM2
    assert RTOL == 1e-6  # the search's documented tolerance on f, which the hand values below are held to
    assert scale_factor(g_mat, 0.01, weight) == pytest.approx(0.4, rel=RTOL)
    # a tighter tolerance reaches the hand value as closely
    assert scale_factor(g_mat, 0.01, weight, rtol=1e-12) == pytest.approx(0.4, rel=1e-11)


def test_a_moving_load_with_creep_and_missing_frames() -> None:
    # load moving between two blocks, sensor creeping; the pressures are known, so is the mean force
    T, dt = 1500, 0.02
    t = np.arange(T) * dt
    p = np.zeros((T, 8, 8))
    share = 0.5 + 0.4 * np.sin(2 * np.pi * 0.3 * t)
    p[:, 1:3, 1:4] = (20.0 * share)[:, None, None]
    p[:, 5:7, 4:7] = (20.0 * (1 - share))[:, None, None]
    sensor = MPICreep.thesis()
    g = sensor.direct(p, dt) / 0.65
    g[100:110] = np.nan  # frames lost on the wire
    keep = np.ones(T, bool)
    keep[100:110] = False
    weight = float((p.sum(axis=(1, 2)) * 4.0 * PSI_N_PER_CM2)[keep].mean())
    # the inverse steps the creep over the lost frames with the pressure held (psmat.process's
    # policy) while the true pressure moved during them: allow the creep's share of an error
    assert scale_factor(g, dt, weight, cell_area_cm2=4.0) == pytest.approx(0.65, rel=2e-3)
    g[100:110] = sensor.direct(p, dt)[100:110] / 0.65
    assert scale_factor(g, dt, weight) == pytest.approx(0.65, rel=RTOL)


def test_cell_area_enters_linearly_in_the_weight() -> None:
    sensor = MPICreep.thesis()
    g = sensor.direct(_block(level_psi=6.0), 0.01) / 0.5
    weight_1cm2 = 20 * 6.0 * 1.0 * PSI_N_PER_CM2
    assert scale_factor(g, 0.01, weight_1cm2, cell_area_cm2=1.0) == pytest.approx(0.5, rel=RTOL)
    assert scale_factor(g, 0.01, 4 * weight_1cm2, cell_area_cm2=4.0) == pytest.approx(0.5, rel=RTOL)


def test_an_unreachable_weight_is_one_clear_error() -> None:
    # the inverse model saturates at p_max = 32 psi: 20 cells carry at most 20·32·4·0.689 = 1765 N
    g = MPICreep.thesis().direct(_block(), 0.01)
    with pytest.raises(ValueError, match="cannot be reached"):
        scale_factor(g, 0.01, 2000.0)


@pytest.mark.parametrize("g, match", [
    (np.zeros((10, 4, 4)), "zero everywhere"),
    (np.full((10, 4, 4), np.nan), "no complete frame"),
    (np.ones((4, 4)), "shape"),
    (-np.ones((3, 4, 4)), "negative"),
])
def test_bad_input(g, match) -> None:
    with pytest.raises(ValueError, match=match):
        scale_factor(g, 0.01, 700.0)


@pytest.mark.parametrize("conductive, bracket", [(0.01, (1e-3, 1e3)), (0.01, (20.0, 500.0)), (40.0, (1e-3, 1e3))])
def test_far_from_the_secant_start_and_a_bracket_without_it(conductive: float, bracket) -> None:
    # the root is searched from f = 1 and 0.5 in log-log; a mat 100x less (or 40x more) conductive
    # than the model needs f = 100 (0.025), also when the bracket excludes both starting points
    sensor = MPICreep.thesis()
    g_mat = sensor.direct(_block(), 0.01) * conductive
    weight = 20 * 10.0 * 4.0 * PSI_N_PER_CM2
    assert scale_factor(g_mat, 0.01, weight, bracket=bracket) == pytest.approx(1 / conductive, rel=RTOL)

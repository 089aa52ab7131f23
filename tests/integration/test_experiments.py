"""psmat.experiments: the thesis' uncertainty studies (§2.3, Table 2.4, Fig. 2.13/2.15/2.16, §2.3.3)
at small size. Expectations come from the thesis and the physics, not from the code under test.
(Tables C.1/C.2 are in test_experiments_qzpm.py.)"""

from __future__ import annotations

import numpy as np
import pytest

from psmat import experiments as ex

# Thesis Table 2.4, typed from the thesis (R Ω, σ_v V, σ_g S).
THESIS_T24 = [(100.0, 1.0e-3, 7.7e-5), (1e3, 0.9e-3, 1.3e-6), (10e3, 1.1e-3, 2.4e-7),
              (100e3, 1.1e-3, 1.6e-7), (220e3, 1.1e-3, 1.6e-7)]


# ----------------------------------------------------------------------------- Table 2.4
def test_table_2_4_within_15_percent_of_the_thesis():
    res = ex.table_2_4("thesis", n_frames=4000, seed=3)
    R, sv, sg = (np.array(c) for c in zip(*THESIS_T24))
    np.testing.assert_array_equal(res.resistance, R)
    np.testing.assert_allclose(res.thesis_sigma_g, sg)
    np.testing.assert_allclose(res.sigma_v, sv)
    # first-order chain and the quantised, noisy recording (SD over 4000 frames: ±1.6 %)
    np.testing.assert_allclose(res.sigma_g, sg, rtol=0.15)
    np.testing.assert_allclose(res.sigma_g_sim, sg, rtol=0.15)
    # Fig. 2.12: relative σ rises from ~0.1 % at 1 kΩ to a few % at 220 kΩ
    assert res.relative[-1] > 10 * res.relative[1]
    text = res.table()
    assert "7.7e-05" in text and "1.6e-07" in text


def test_table_2_4_scalar_sigma_v_and_other_resistances():
    res = ex.table_2_4(1e-3, resistances=(100.0, 470.0, 1e3), n_frames=50)
    assert np.isnan(res.thesis_sigma_g[1]) and not np.isnan(res.thesis_sigma_g[0])
    # σ_g ∝ σ_v: 0.9 mV → 1 mV scales the 1 kΩ row by 1/0.9
    th = ex.table_2_4("thesis", n_frames=2)
    assert res.sigma_g[2] == pytest.approx(th.sigma_g[1] / 0.9, rel=1e-12)
    with pytest.raises(ValueError):
        ex.table_2_4("thesis", resistances=(470.0,))


# ----------------------------------------------------------------------------- Fig. 2.13
def test_fig_2_13_propagation_vs_monte_carlo():
    # 2000 draws: the SD estimates scatter by ~1/sqrt(4000) = 1.6 % per cell
    res = ex.uncertainty_random(shape=(8, 8), draws=2000, seed=1)
    hi, lo = res.g >= 1e-3, res.g < 3e-5
    assert hi.sum() >= 10 and lo.sum() >= 5
    r_hi = res.ratio[hi]
    # agreement for high conductances (thesis: "overlapping points")
    assert abs(np.median(r_hi) - 1) < 0.05
    assert np.mean(np.abs(r_hi - 1) < 0.10) >= 0.9 and np.all(np.abs(r_hi - 1) < 0.15), r_hi
    # eq. 2.11 overestimates for low conductances (a linearisation where σ/g is large)
    assert np.median(res.ratio[lo]) > 1.1 and np.mean(res.ratio[lo] > 1) >= 0.8
    # relative uncertainty grows as g falls
    assert np.median(res.rel_mc[lo]) > 10 * np.median(res.rel_mc[hi])
    assert res.g.min() >= 1e-5 and res.g.max() <= 1e-2
    assert "median ratio" in res.table()


# ----------------------------------------------------------------------------- Fig. 2.15 / 2.16
def test_semi_tandem_geometry():
    p = ex.stance_pressure("semi_tandem")
    y = np.arange(16)[:, None] * 2.0
    left, right = p[:, :8], p[:, 8:]
    dy = (y * right).sum() / right.sum() - (y * left).sum() / left.sum()
    assert 9.0 < dy < 14.0  # half a 24 cm foot ahead (ends cut by the 32 cm mat)
    st = ex.stance_pressure("standing")
    np.testing.assert_allclose(st, st[:, ::-1], atol=1e-9)  # mirror-symmetric feet
    assert st.sum() * 4.0 * 6894.757e-4 == pytest.approx(700.0, rel=0.01)  # psi·cm² → N
    with pytest.raises(ValueError):
        ex.stance_pressure("tandem")


@pytest.mark.parametrize("stance", ["standing", "semi_tandem"])
def test_stance_uncertainty_maps(stance):
    res = ex.uncertainty_maps(stance, draws=300, seed=0)
    hi, bg = res.g >= 1e-3, res.g < 1e-5
    assert hi.sum() >= 8
    # loaded cells: propagation agrees with the simulation (300 draws: ±4 % per cell)
    assert abs(np.median(res.ratio[hi]) - 1) < 0.06 and np.all(np.abs(res.ratio[hi] - 1) < 0.25)
    # thesis: "for conductances above a value about 1e-4 the uncertainty is less than 10 %"
    assert 5e-5 < res.threshold_10pct() < 5e-4
    # and eq. 2.11 overestimates in the very low conductance range
    assert np.median(res.ratio[bg]) > 1.2
    assert stance in res.table()


# ----------------------------------------------------------------------------- §2.3.3 board
@pytest.mark.parametrize("config", ["corners", "random"])
def test_resistor_board(config):
    res = ex.resistor_board_6x6(n_frames=300, seed=0, config=config)
    assert res.g_frames.shape == (300, 6, 6)
    if config == "corners":
        assert np.all(res.resistance[[0, 0, 5], [0, 5, 0]] == 100.0)
        assert np.all(res.resistance[res.resistance != 100.0] >= 1e3)
    loaded = res.loaded()  # 100 Ω and 1 kΩ resistors, the cells the thesis plots
    assert loaded.sum() >= 3
    # corners / loaded cells recovered from the median G (σ/g ~1 %, 300 frames)
    assert np.all(res.recovery_error[loaded] < 0.02), res.recovery_error[loaded]
    # experimental SD over the frames vs eq. 2.11: within a factor ~1.5
    r = res.ratio[loaded]
    assert np.all((r > 1 / 1.5) & (r < 1.5)), r
    assert np.all(res.rel_exp[res.resistance == 100.0] < 0.1)


def test_board_reads_open_lines_outside_the_board():
    # the 6x6 block in a 16x16 DAQ: the G of the board's pairs do not depend on the open lines
    res_small = ex.resistor_board_6x6(n_frames=30, seed=2, daq_shape=(6, 6))
    res_big = ex.resistor_board_6x6(n_frames=30, seed=2, daq_shape=(16, 16))
    m = res_big.loaded()
    np.testing.assert_allclose(res_small.g_median[m], res_big.g_median[m], rtol=0.03)
    np.testing.assert_allclose(res_big.g_median[m], res_big.g_true[m], rtol=0.03)

"""The thesis' variants (Tables 3.2/3.4) as recipes on the chain's G and g: checked on a
simulated trial whose pressure is known (simulation, no crosstalk in the cells' own model)."""

from __future__ import annotations

import numpy as np
import pytest

from psmat import iecm, twin
from psmat.balance import cop, mean_force_n
from psmat.balance import VARIANTS, variant_traces
from psmat.sensor import MPICreep
from psmat.units import PSI_PA


@pytest.fixture(scope="module")
def trial():
    scene = twin.quiet_standing(3.0, 50.0, seed=2)  # psi on the 16x16, 2 cm mat
    p = np.minimum(scene.pressure_psi, 32.0)
    sensor = MPICreep.thesis()
    g = sensor.direct(p, 0.02) / 0.5  # a mat twice as conductive as the nominal model
    G = iecm.forward(g + 1e-7)  # the unloaded cells leak 10 MOhm, as the twin's, or the network falls apart
    weight = float(np.mean(p.sum(axis=(1, 2))) * PSI_PA * 4e-4)  # N: what the cells carry
    return p, g, G, weight, sensor


def test_each_variant_is_its_recipe(trial) -> None:
    p, g, G, weight, sensor = trial
    v = variant_traces(G, g, 0.02, weight_n=weight, sensor=sensor, names=("PROP", "PROP-C", "CHC", "SCHC"))
    np.testing.assert_array_equal(v["PROP"].cop_cm[0], cop(g))
    np.testing.assert_array_equal(v["PROP-C"].cop_cm[0], cop(G))
    np.testing.assert_array_equal(v["CHC"].cop_cm[0], cop(sensor.inverse(g, 0.02)))
    # SCHC undoes the mat's extra conductance exactly: f = 1/2 and the CoP of the true pressure
    assert v["SCHC"].factor[0] == pytest.approx(0.5, rel=1e-8)
    np.testing.assert_allclose(v["SCHC"].cop_cm[0], cop(p), atol=1e-9)
    assert v["PROP"].factor is None


def test_the_8x8_variants_keep_four_choices_near_the_truth(trial) -> None:
    p, g, G, weight, sensor = trial
    v = variant_traces(G, g, 0.02, weight_n=weight, sensor=sensor, names=("PROP-8x8", "SCHC-8x8"))
    for name in ("PROP-8x8", "SCHC-8x8"):
        assert v[name].cop_cm.shape == (4,) + p.shape[:1] + (2,)
    # choice (r0, c0) of PROP-8x8 is the CoP of g[r0::2, c0::2] placed on the full mat
    np.testing.assert_allclose(v["PROP-8x8"].cop_cm[3], cop(g[:, 1::2, 1::2], 4.0) + [2.0, 2.0])
    # each coarse cell stands for 16 cm²; the four choices partition the cells, so at f = 1/2 their
    # forces average to the weight exactly, and a choice that carries less than the weight at
    # f = 1/2 needs a larger f (the left side of eq. 3.3 grows with f), one that carries more a smaller one
    forces = np.array([mean_force_n(g[:, r::2, c::2], 0.02, 0.5, sensor, 16.0) for r in (0, 1) for c in (0, 1)])
    assert forces.mean() == pytest.approx(weight, rel=1e-9)
    f = v["SCHC-8x8"].factor
    assert np.all(np.sign(f - 0.5) == -np.sign(forces - weight))
    # and the four choices' mean CoP stays within a fraction of the 2 cm pitch of the truth
    np.testing.assert_allclose(v["SCHC-8x8"].cop_cm.mean(axis=0), cop(p), atol=0.5)


def test_missing_frames_stay_missing(trial) -> None:
    p, g, G, weight, sensor = trial
    g2, G2 = g.copy(), G.copy()
    g2[5:8] = np.nan
    G2[5:8] = np.nan
    v = variant_traces(G2, g2, 0.02, weight_n=weight, sensor=sensor)
    assert set(v) == set(VARIANTS)
    for t in v.values():
        assert np.all(np.isnan(t.cop_cm[:, 5:8])) and np.all(np.isfinite(t.cop_cm[:, 8:]))


def test_bad_requests(trial) -> None:
    p, g, G, weight, sensor = trial
    with pytest.raises(ValueError, match="unknown variant"):
        variant_traces(G, g, 0.02, weight_n=weight, names=("PROP", "FANCY"))
    with pytest.raises(ValueError, match="body weight"):
        variant_traces(G, g, 0.02, weight_n=None, names=("SCHC",))

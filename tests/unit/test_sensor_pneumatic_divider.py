"""The material DAQ's divider is the measurement chain of ``psmat.Circuit`` (one implementation).

The DAQ's divider (thesis §2.4.1) is the mat's circuit (docs/spec.md §2) with no multiplexer, an
ideal ADC and ``V_ref`` normalised to 1, with the sensor either below the node (``"low"``,
like the mat) or above it (``"high"``). Expectations come from the divider written out here.
"""

from __future__ import annotations

import numpy as np
import pytest

from psmat.circuit import OK, OPEN, SHORT, Circuit
from psmat.sensor.pneumatic import DAQ_BITS, DAQ_R_O, divider_conductance, divider_counts

FS = 2**DAQ_BITS - 1


@pytest.mark.parametrize("side", ["low", "high"])
def test_daq_divider_is_the_circuit_with_no_mux_and_an_ideal_adc(side):
    c = Circuit(r_o=DAQ_R_O, r_mux=0.0, r_adc=np.inf, v_ref=1.0, bits=DAQ_BITS, sensor_side=side)
    x = np.arange(FS + 1) / FS
    g, flags = divider_conductance(x, sensor_side=side)
    g_c, flags_c = c.conductance_from_voltage(x, return_flags=True)
    np.testing.assert_array_equal(flags, flags_c)
    np.testing.assert_array_equal(g[flags != OPEN], g_c[flags != OPEN])
    np.testing.assert_array_equal(g[flags == OPEN], 0.0)
    G = np.concatenate([[0.0], np.logspace(-7, 0, 500)])
    np.testing.assert_array_equal(divider_counts(G, sensor_side=side), c.counts(G))


@pytest.mark.parametrize("side", ["low", "high"])
def test_daq_divider_against_the_written_out_divider(side):
    x = np.array([0.0, 0.01, 0.25, 0.5, 0.9, 1.0])
    g, flags = divider_conductance(x, r_o=1000.0, sensor_side=side, open_value=-1.0)
    inner = x[1:-1]
    # low: x = R_s/(R_o + R_s) -> g = (1 - x)/(R_o x); high: x = R_o/(R_o + R_s) -> g = x/(R_o (1 - x))
    expected = (1 - inner) / (1000.0 * inner) if side == "low" else inner / (1000.0 * (1 - inner))
    np.testing.assert_allclose(g[1:-1], expected, rtol=1e-12)
    np.testing.assert_array_equal(flags[1:-1], OK)
    ends = [SHORT, OPEN] if side == "low" else [OPEN, SHORT]
    np.testing.assert_array_equal(flags[[0, -1]], ends)
    assert g[ends.index(OPEN) * 5] == -1.0 and np.isnan(g[ends.index(SHORT) * 5])

"""One validation module: the checks of circuit, noise, the DAQ divider, the pressure
protocols and the protocol encoders come from psmat._checks, so the same bad input gets the same
answer everywhere (they used to have private validators with their own rules and messages)."""

from __future__ import annotations

import numpy as np
import pytest

from psmat import Circuit, noise
from psmat.sensor import protocols
from psmat.sensor.pneumatic import divider_counts


@pytest.mark.parametrize("bad, msg", [
    (np.array([1e-3, -1e-3]), r"must be >= 0 \(S\); negative value -0\.001 at index \(1,\)"),
    (np.array([1e-3, np.nan]), r"must be finite; non-finite value nan at index \(1,\)"),
])
def test_conductance_checks_agree(bad, msg):
    # Circuit, the noise model and the DAQ divider reject the same G with the same message
    for fn in (Circuit().voltage, noise.table_sigma_G, noise.voltage_sigma_G, noise.relative_sigma, divider_counts):
        with pytest.raises(ValueError, match=msg):
            fn(bad)


@pytest.mark.parametrize("make", [
    lambda: protocols.fast_cyclic(5.0, cycles=2.0),
    lambda: protocols.fast_cyclic(5.0, cycles=True),
    lambda: protocols.descending_hysteresis(repetitions=1.0),
])
def test_protocol_counts_are_integers(make):
    # a count given as a float or a bool is refused, as everywhere else (psmat._checks.positive_int)
    with pytest.raises(ValueError, match="must be an integer >= 1"):
        make()

"""A material-DAQ session whose lines reached the host several at a time (one serial chunk, one
arrival time: a busy host, a USB adapter's latency timer) loads, at the times the lines were
sent. Before, two lines of one arrival time made ``load_daq_session`` refuse the whole session
("time ... does not increase")."""

from __future__ import annotations

import numpy as np

from psmat.io import SessionWriter
from psmat.sensor import load_daq_session
from psmat.protocol import DAQ_MAX_COUNT
from psmat.sensor.pneumatic import DAQ_R_O


def test_lines_read_three_at_a_time_load_at_the_times_they_were_sent(tmp_path) -> None:
    rng = np.random.default_rng(1)
    n = 12
    counts = rng.integers(1, DAQ_MAX_COUNT, size=(n, 10)).astype(np.uint16)
    sent = 100.0 + 0.5 * np.arange(n)  # a line every 0.5 s
    host = np.repeat(sent[2::3] + 0.02, 3)  # read three at a time, 20 ms after the third was sent
    valid = np.ones(n, bool)
    valid[4] = False  # a line that failed on the wire: its slot stays empty
    path = tmp_path / "daq.h5"
    with SessionWriter(path, (10,), {"device": "daq"}, kind="daq") as w:
        for a in range(0, n, 3):
            w.append(counts[a:a + 3], host[a:a + 3], valid[a:a + 3])
    run = load_daq_session(path)
    # relative to the first line: 0, 0.5, 1.0, 1.5, (2.0 lost), 2.5, ... 5.5 s
    np.testing.assert_allclose(run.t, (sent - sent[0])[valid], atol=1e-6)  # ms with 3 decimals
    x = counts[valid] / DAQ_MAX_COUNT  # the divider by hand, row for row
    np.testing.assert_allclose(run.g, (1 - x) / (DAQ_R_O * x), rtol=1e-12)

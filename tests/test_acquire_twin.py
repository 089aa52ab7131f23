"""End to end through the pseudo-terminal (issue 4, item 9): the firmware core on the twin,
the serial link, psmat.acquire, the session file."""

from __future__ import annotations

import time

import numpy as np
import pytest

from psmat.acquire import DeviceDisconnected, open_device
from psmat.io import SessionWriter, load_session
from psmat.twin import Faults, SerialTwin


@pytest.mark.slow
@pytest.mark.parametrize("protocol", ["v2", "v1"])
def test_165_hz_for_10_s_without_losing_a_frame(protocol, tmp_path):
    seconds, rate = 10.5, 165
    path = tmp_path / "run.h5"
    with SerialTwin("psm", rate, protocol, scene="quiet") as twin, open_device(twin.port, "psm", protocol) as dev, \
            SessionWriter(path, (16, 16), device=dict(dev.description or {})) as writer:
        dev.record_to(writer)
        dev.start()
        t0 = time.monotonic()
        got = 0
        while time.monotonic() - t0 < seconds:
            got += len(dev.read(timeout=0.2))
        dev.stop()
        dev.stop_recording()
        st = dev.stats
    s = load_session(path)
    assert s.n_frames >= rate * 10 and s.valid.all()
    assert st.invalid == 0 and st.dropped_wire == 0 and st.dropped_buffer == 0 and st.skipped_bytes == 0
    if protocol == "v2":
        # the device's own sequence numbers prove that nothing was lost in between
        assert np.all(np.diff(s.seq) == 1)
        # and its clock that frames were paced at the rate
        assert np.median(np.diff(s.device_time_us)) == pytest.approx(1e6 / rate, rel=0.02)
    # every frame the twin sent after the first one recorded arrived (count by the twin)
    assert s.n_frames <= twin.stats.frames_sent


def test_a_vanishing_port_is_reported_not_hung_on():
    with SerialTwin("psm", 100, "v2", scene="quiet", faults=Faults(disconnect_after_s=0.5)) as twin:
        with open_device(twin.port, "psm", "v2") as dev:
            dev.start()
            t0 = time.monotonic()
            with pytest.raises(DeviceDisconnected):
                while time.monotonic() - t0 < 5:
                    dev.read(timeout=0.2)
            assert time.monotonic() - t0 < 3  # hang guard
            assert not dev.connected


def test_the_imu_and_material_daq_twins_through_the_same_api():
    # spine IMUs: five sensors' Euler angles (degrees), v2 framing
    with SerialTwin("imu", 20, "v2") as twin, open_device(twin.port, "imu", "v2") as dev:
        assert dev.description.get("device") == "imu"
        batch = dev.read(n=10, timeout=3)
    assert len(batch) >= 10 and batch.frames.shape[1:] == (5, 3) and batch.valid.all()
    assert np.all(np.diff(batch.seq) == 1)
    # heading 90 deg, pitch bending most at the lowest sensor (the twin's spine model)
    assert np.allclose(batch.frames[:, :, 0], 90.0)
    # material DAQ: text lines of 10 counts, started by 's'
    with SerialTwin("daq", 20) as twin, open_device(twin.port, "daq") as dev:
        batch = dev.read(n=5, timeout=3)
    assert len(batch) >= 5 and batch.frames.shape[1:] == (10,) and batch.valid.all()
    assert batch.frames.max() <= 1023


def test_psmat_boxes_are_recognised_by_their_usb_identity():
    from psmat.acquire import find_devices
    from psmat.acquire.discover import is_psmat_port

    assert is_psmat_port(0x1209, 0x0001)  # the firmware's descriptors (firmware/stm32/common/usb_desc.c)
    assert is_psmat_port(0x0483, 0x5740, manufacturer="psmat")
    assert not is_psmat_port(0x0403, 0x6001, product="FT232R USB UART", manufacturer="FTDI")
    assert not is_psmat_port(None, None)
    # a pseudo-terminal twin is not a USB box: the demo falls back to starting its own
    assert all(not f.port.startswith("/dev/pts/") for f in find_devices())

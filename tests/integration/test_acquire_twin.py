"""End to end through the pseudo-terminal (docs/spec.md §5): the firmware core on the twin,
the serial link, psmat.acquire, the session file."""

from __future__ import annotations

import time
from contextlib import closing

import numpy as np
import pytest

from psmat.acquire import DeviceDisconnected, open_device
from psmat.io import SessionWriter, load_session
from psmat.protocol import v1_frame_size, v2_frame_size
from psmat.twin import Faults, ImuSource, SerialTwin
from hang_guard import HANG_GUARD_S, read_until_gone, returns


@pytest.mark.parametrize("protocol", ["v2", "v1"])
def test_a_165_hz_recording_holds_every_frame_sent(protocol, tmp_path):
    # a short run; the rate over 10 min is `python -m psmat.bench acquire`'s to measure
    n, rate = 200, 165
    path = tmp_path / "run.h5"
    with SerialTwin("psm", rate, protocol, scene="quiet") as twin, \
            closing(open_device(twin.port, "psm", protocol)) as dev, \
            SessionWriter(path, (16, 16), device=dict(dev.description)) as writer:
        # the twin streams from power-up: the host may open the port mid-packet; those bytes
        # are judged before the IDENTIFY reply that open() waited for
        skipped_at_open = dev.stats.skipped_bytes
        dev.record_to(writer)
        dev.start()                                          # recorded from the first frame buffered
        parts = []
        deadline = time.monotonic() + HANG_GUARD_S
        while sum(map(len, parts)) < n and time.monotonic() < deadline:
            parts.append(dev.read(n - sum(map(len, parts)), timeout_s=0.5))
        dev.stop()
        dev.stop_recording()
        st = dev.stats
    frames = np.concatenate([b.frames for b in parts])
    seq = np.concatenate([b.seq for b in parts])
    s = load_session(path)
    assert len(frames) == n and s.n_frames >= n and s.valid.all()
    np.testing.assert_array_equal(s.frames[:n], frames)     # what was read is what was recorded
    assert st.invalid == 0 and st.dropped_wire == 0 and st.dropped_buffer == 0
    size = v2_frame_size((16, 16)) if protocol == "v2" else v1_frame_size((16, 16))
    assert skipped_at_open < size and st.skipped_bytes == skipped_at_open
    if protocol == "v2":
        # the device's own sequence numbers: every one from the first recorded on arrived
        np.testing.assert_array_equal(s.seq, seq[0] + np.arange(s.n_frames))
    # no more frames recorded than the twin sent (count by the twin)
    assert s.n_frames <= twin.stats.frames_sent


def test_a_vanishing_port_is_reported_not_hung_on():
    # the fault counts from the twin's start: 2 s leave a loaded machine time to open the port first
    with SerialTwin("psm", 100, "v2", scene="quiet", faults=Faults(disconnect_after_s=2.0)) as twin:
        with open_device(twin.port, "psm", "v2") as dev:
            dev.start()
            with pytest.raises(DeviceDisconnected):
                returns(lambda: read_until_gone(dev), "reads until the vanished port is reported")
            assert not dev.connected


def test_the_imu_and_material_daq_twins_through_the_same_api():
    # spine IMUs: five sensors' Euler angles (degrees), v2 framing
    with SerialTwin("imu", 20, "v2") as twin, open_device(twin.port, "imu", "v2") as dev:
        assert dev.description.get("device") == "imu"
        batch = dev.read(n=10, timeout_s=HANG_GUARD_S)
    assert len(batch) >= 10 and batch.frames.shape[1:] == (5, 3) and batch.valid.all()
    assert np.all(np.diff(batch.seq) == 1)
    # consecutive samples of the seated twin's IMUs (psmat.twin.seated), float32 as sent
    served = ImuSource(20.0, 0).angles_deg
    first = np.flatnonzero(np.all(served == batch.frames[0], axis=(1, 2)))
    assert first.size == 1
    np.testing.assert_array_equal(batch.frames, served[first[0] + batch.seq - batch.seq[0]])
    # material DAQ: text lines of 10 counts, started by 's'
    with SerialTwin("daq", 20) as twin, open_device(twin.port, "daq") as dev:
        batch = dev.read(n=5, timeout_s=HANG_GUARD_S)
    assert len(batch) >= 5 and batch.frames.shape[1:] == (10,) and batch.valid.all()
    assert batch.frames.max() <= 1023


def test_psmat_boxes_are_recognised_by_their_usb_identity():
    from serial.tools.list_ports_linux import SysFS

    from psmat.acquire import find_devices
    from psmat.acquire import is_psmat_port

    assert is_psmat_port(0x1209, 0x0001)  # the firmware's descriptors (firmware/stm32/common/usb_desc.c)
    assert is_psmat_port(0x0483, 0x5740, manufacturer="psmat")
    assert not is_psmat_port(0x0403, 0x6001, product="FT232R USB UART", manufacturer="FTDI")
    assert not is_psmat_port(None, None)
    # a pseudo-terminal twin is not a USB box: the demo falls back to starting its own
    with SerialTwin("psm", 10, "v2") as twin:
        info = SysFS(twin.port)                       # what pyserial knows of the twin's port
        assert (info.vid, info.pid, info.product, info.manufacturer) == (None, None, None, None)
        assert not is_psmat_port(info.vid, info.pid, info.product, info.manufacturer)
        assert twin.port not in [f.port for f in find_devices()]

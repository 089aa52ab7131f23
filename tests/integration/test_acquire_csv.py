"""Acquiring a do-it-yourself csv mat (docs/protocol.md "csv"): loop://, the csv twin on a pty, wire order."""

from __future__ import annotations

import numpy as np
import pytest

from psmat.acquire import AcquireError, Device, open_device
from psmat.circuit import Circuit
from psmat.protocol import Opcode, encode_csv, encode_v2
from psmat.twin import MatPhysics, PsmSource, SerialTwin, make_scene
from hang_guard import HANG_GUARD_S

ROW_ORDER = (2, 0, 3, 1)        # the k-th row sent is logical row ROW_ORDER[k]
COL_ORDER = (4, 3, 2, 1, 0)


def _logical(i: int) -> np.ndarray:
    return (np.arange(20).reshape(4, 5) + 100 * i).astype(np.uint16)


def _wire(frame: np.ndarray) -> np.ndarray:
    """What a mat wired in ROW_ORDER / COL_ORDER sends: wire[k, m] = logical[ROW_ORDER[k], COL_ORDER[m]]."""
    return frame[np.ix_(ROW_ORDER, COL_ORDER)]


def test_a_csv_mat_takes_no_commands_and_says_what_it_does_not_report() -> None:
    with open_device("loop://", "psm", protocol="csv", shape=(4, 5), bits=10) as dev:
        assert dev.protocol == "csv" and not dev.commands and dev.baudrate == 115_200
        d = dev.description
        assert (d["proto"], d["rows"], d["cols"], d["bits"]) == ("csv", 4, 5, 10)
        assert set(d["unknown"]) == {"fw", "rate", "serial", "r_o", "v_ref"} and "csv" in d["note"]
        for call in (lambda: dev.set_rate(10), lambda: dev.send_command(Opcode.IDENTIFY),
                     lambda: dev.set_protocol(2), lambda: dev.cal_hold(0, 0)):
            with pytest.raises(AcquireError, match="csv mat takes no commands"):
                call()
        assert dev.serial.in_waiting == 0          # start() wrote nothing on the wire
        assert "csv" in repr(dev)


@pytest.mark.parametrize("bad", [dict(kind="imu"), dict(bits=0), dict(bits=17), dict(protocol="v3")])
def test_bad_csv_arguments_are_one_line(bad: dict) -> None:
    args = dict(port="loop://", kind="psm", protocol="csv", shape=(4, 5)) | bad
    with pytest.raises(ValueError):
        Device(**args)


def test_csv_frames_bits_and_bad_lines_through_loop() -> None:
    with open_device("loop://", "psm", protocol="csv", shape=(4, 5), bits=10) as dev:
        dev.serial.write(b"r0c0;r0c1 a header\r\n" + encode_csv(_logical(1)) + b"1,2,3\n"
                         + encode_csv(_logical(9)) + encode_csv(_logical(2), "block"))
        b = dev.read(4, timeout_s=HANG_GUARD_S)
    # _logical(9) holds 919 ... 900 + 19: within 10 bits; "1,2,3" has 3 numbers: invalid
    assert b.valid.tolist() == [True, False, True, True]
    np.testing.assert_array_equal(b.frames[[0, 2, 3]], [_logical(1), _logical(9), _logical(2)])
    assert (b.seq == -1).all() and (b.device_time_us == -1).all()


@pytest.mark.parametrize("protocol", ["csv", "v2"])
def test_wire_order_is_undone_on_every_frame(protocol: str) -> None:
    with open_device("loop://", "psm", protocol=protocol, shape=(4, 5), identify=False, bits=12,
                     row_order=list(ROW_ORDER), col_order=list(COL_ORDER)) as dev:
        for i in range(3):
            wire = _wire(_logical(i))
            dev.serial.write(encode_csv(wire) if protocol == "csv" else encode_v2(wire, i, 1000 * i))
        b = dev.read(3, timeout_s=HANG_GUARD_S)
    assert b.valid.all()
    np.testing.assert_array_equal(b.frames, [_logical(i) for i in range(3)])


def test_rows_only_and_identity_orders() -> None:
    with open_device("loop://", "psm", protocol="csv", shape=(4, 5), row_order=ROW_ORDER) as dev:
        dev.serial.write(encode_csv(_logical(3)[list(ROW_ORDER)]))
        b = dev.read(1, timeout_s=HANG_GUARD_S)
    np.testing.assert_array_equal(b.frames[0], _logical(3))
    ident = Device("loop://", "psm", "csv", (4, 5), row_order=range(4), col_order=[0, 1, 2, 3, 4])
    assert ident.row_order is None and ident.col_order is None       # identity: nothing to reorder
    for bad in ([0, 1, 2], [0, 1, 2, 2], [0, 1, 2, 3.0]):
        with pytest.raises(ValueError, match="row_order"):
            Device("loop://", "psm", "csv", (4, 5), row_order=bad)


class _Known:
    """A source of known frames with the physics (and so the bits) of a 10-bit, 5 V board."""

    def __init__(self, frames: np.ndarray) -> None:
        self.frames = frames
        self.physics = MatPhysics(shape=frames.shape[1:], circuit=Circuit(bits=10, v_ref=5.0))
        self.k = 0

    def next(self) -> np.ndarray:
        f = self.frames[self.k % len(self.frames)]
        self.k += 1
        return f


@pytest.mark.parametrize("layout", ["line", "block"])
def test_the_csv_twin_on_a_pty_streams_its_source(layout: str) -> None:
    frames = np.random.default_rng(3).integers(0, 1024, (1000, 6, 7)).astype(np.uint16)
    twin = SerialTwin("psm", 100, "csv", source=_Known(frames), shape=(6, 7), csv_layout=layout)
    assert twin.bits == 10 and twin.firmware is None
    with twin, open_device(twin.port, "psm", protocol="csv", shape=(6, 7), bits=10) as dev:
        b = dev.read(30, timeout_s=HANG_GUARD_S)
        dev.serial.write(encode_v2(frames[0], 0, 0))   # commands, anything: the twin ignores it
        b2 = dev.read(5, timeout_s=HANG_GUARD_S)
    got = b.frames[b.valid]
    assert len(got) == 30                               # a line or block cut by the open is no row
    first = int(np.flatnonzero((frames == got[0]).all(axis=(1, 2)))[0])
    np.testing.assert_array_equal(got, frames[first:first + len(got)])
    assert len(b2) == 5 and b2.valid.all()


def test_a_source_with_a_10_bit_circuit_gives_10_bit_counts() -> None:
    scene = make_scene("quiet", 1.0, 50.0, (8, 8))
    src = PsmSource(scene, MatPhysics(shape=(8, 8), dt=0.02, circuit=Circuit(bits=10, v_ref=5.0)))
    twin = SerialTwin("psm", 50, "csv", source=src, shape=(8, 8))
    assert twin.bits == 10
    with twin, open_device(twin.port, "psm", protocol="csv", shape=(8, 8), bits=10) as dev:
        b = dev.read(20, timeout_s=HANG_GUARD_S)
    assert b.valid[1:].all() and int(b.frames.max()) <= 1023
    twin12 = SerialTwin("psm", 50, "csv", source=PsmSource(scene, MatPhysics(shape=(8, 8), dt=0.02)), shape=(8, 8))
    assert twin12.bits == 12
    twin12.stop()

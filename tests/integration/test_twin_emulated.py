"""The twin serving the PSM firmware image in the emulator (psmat.twin.EmulatedTwin) on a real
pseudo-terminal, read by psmat.acquire as a mat would be (docs/spec.md §5 "Firmware executed").

Expected values come from outside the code under test: the serial is the XOR of the three UID
words in 8 hex digits (firmware/stm32/common/uid.c), and the frames carry the counts of the
source frames the test hands the twin, in order (one source frame per scan)."""

from __future__ import annotations

import os
import select
import time

import numpy as np
from pathlib import Path

import pytest

pytest.importorskip("unicorn")
pytest.importorskip("elftools")

from psmat import protocol  # noqa: E402
from psmat.acquire import open_device  # noqa: E402
from psmat.emulator import BuildUnavailable, build_images  # noqa: E402
from psmat.twin import EmulatedTwin, PsmSource  # noqa: E402
from psmat.twin.pty_link import pty_available  # noqa: E402

#: the repository's firmware sources (the images are built from them, whether psmat is installed or not)
FIRMWARE = Path(__file__).resolve().parents[2] / "firmware"

UID = (0x0BADF00D, 0x13572468, 0xCAFEBABE)
SERIAL = f"{0x0BADF00D ^ 0x13572468 ^ 0xCAFEBABE:08X}"


@pytest.fixture(scope="module")
def psm_elf(tmp_path_factory):
    try:
        return build_images(tmp_path_factory.mktemp("fw"), link="uart", source=FIRMWARE)["psm"]
    except BuildUnavailable as exc:
        pytest.skip(str(exc))


class Counting:
    """Frame k: every cell holds (k * 37 + cell index) mod 4096, on a 16x16 mat."""

    def __init__(self) -> None:
        self.k = 0

    def next(self) -> np.ndarray:
        frame = (self.k * 37 + np.arange(256).reshape(16, 16)) % 4096
        self.k += 1
        return frame.astype(np.uint16)


@pytest.mark.skipif(not pty_available(), reason="no pseudo-terminals on this system")
def test_open_device_reads_the_images_frames_and_serial(psm_elf):
    with EmulatedTwin(psm_elf, uid=UID, source=PsmSource.named("quiet", 100.0, (16, 16), seed=1)) as twin:
        assert twin.transport == "pty"
        with open_device(twin.port, "psm", protocol="v2") as dev:
            assert dev.description["serial"] == SERIAL
            assert dev.description["rows"] == 16 and dev.description["cols"] == 16
            dev.start()
            got, deadline = [], time.monotonic() + 60
            while sum(len(b.frames) for b in got) < 3 and time.monotonic() < deadline:
                got.append(dev.read(timeout_s=0.5))
            dev.stop()
    frames = np.concatenate([b.frames for b in got if len(b.frames)])
    valid = np.concatenate([b.valid for b in got if len(b.frames)])
    assert len(frames) >= 3 and valid.all()
    assert frames.shape[1:] == (16, 16) and frames.max() < 4096
    assert not twin.stats.errors


@pytest.mark.skipif(not pty_available(), reason="no pseudo-terminals on this system")
def test_each_scan_reads_the_sources_next_frame(psm_elf):
    source = Counting()
    twin = EmulatedTwin(psm_elf, uid=UID, source=source)
    try:
        twin.start()
        decoder, frames, deadline = protocol.V2Decoder(), [], time.monotonic() + 60
        fd = os.open(twin.port, os.O_RDONLY | os.O_NOCTTY)
        try:
            while len(frames) < 3 and time.monotonic() < deadline:
                if select.select([fd], [], [], 0.5)[0]:
                    frames += [f for f in decoder.feed(os.read(fd, 4096)) if f.kind == "psm"]
        finally:
            os.close(fd)
    finally:
        twin.stop()
    assert len(frames) >= 3
    for f in frames[:3]:
        assert f.valid
        expected = (f.seq * 37 + np.arange(256).reshape(16, 16)) % 4096  # scan seq read source frame seq
        np.testing.assert_array_equal(f.data, expected)
    assert np.diff([f.seq for f in frames[:3]]).tolist() == [1, 1]
    assert twin.scans >= 3 and twin.rate_hz == pytest.approx(100.0)


def test_a_source_larger_than_the_images_multiplexers_is_refused(psm_elf):
    with pytest.raises(ValueError, match="at most 16x16"):
        EmulatedTwin(psm_elf, source=PsmSource.named("quiet", 100.0, (32, 32)))

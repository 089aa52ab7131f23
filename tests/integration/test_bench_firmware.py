"""``python -m psmat.bench firmware``: the PSM image's work per frame in the emulator, table CRC
beside the bitwise baseline, with the smallest settings (one frame per image). No timing assertions:
the figures checked are instruction counts, byte counts and the link's arithmetic, against hand
calculation (a 16x16 v2 frame is 16 + 2·256 + 2 = 530 bytes, docs/protocol.md; 10 bits per byte at
1 Mbit/s)."""

from __future__ import annotations

import re

from pathlib import Path

import pytest

pytest.importorskip("unicorn")
pytest.importorskip("elftools")

from psmat.bench import firmware as bench  # noqa: E402
from psmat.emulator import BuildUnavailable  # noqa: E402

CELLS = 16 * 16
FRAME_BYTES = 16 + 2 * CELLS + 2  # header, 12-bit counts in 2 bytes each, CRC-16: 530
LINK_HZ = 1e6 / (FRAME_BYTES * 10)


@pytest.fixture(scope="module")
def images(tmp_path_factory):
    try:
        return bench.build_pair(tmp_path_factory.mktemp("fw"), source=Path(__file__).resolve().parents[2] / "firmware")
    except BuildUnavailable as exc:
        pytest.skip(str(exc))


@pytest.fixture(scope="module")
def figures(images):
    return {name: bench.measure_image(elf, frames=1) for name, elf in images.items()}


def test_eoc_loop_found_in_hand_assembled_thumb():
    # 0x100: ldr r2,[r3]; 0x102: lsls r2,r2,#30; 0x104: bpl 0x100 (d5fc), then a forward beq (d000)
    code = bytes.fromhex("1a68" "9207" "fcd5" "00d0")
    assert bench.eoc_loop(code, 0x100) == (0x100, 0x104)
    with pytest.raises(ValueError, match="one backward"):
        bench.eoc_loop(bytes.fromhex("00d0"), 0x100)


def test_link_limit_is_baud_over_ten_bits_per_byte():
    assert bench.v2_frame_bytes() == FRAME_BYTES
    assert bench.link_limit_hz(1e6, FRAME_BYTES) == pytest.approx(LINK_HZ)


def test_both_images_send_valid_frames_of_the_mat(figures):
    assert [*figures] == [name for name, _ in bench.IMAGES]
    for f in figures.values():
        assert f.frames == 1 and len(f.per_frame) == 1
        assert f.frames_valid == f.frames_sent >= 1  # every frame decoded, CRC good, the mat's counts
        assert f.frame_bytes == FRAME_BYTES
        assert f.baud == pytest.approx(1e6)
        assert f.sysclk_hz == pytest.approx(48e6)


def test_counts_relate_as_they_must(figures):
    table, bitwise = (figures[name] for name, _ in bench.IMAGES)
    for f in (table, bitwise):
        parts = f.crc + f.wait_delay + f.wait_eoc
        assert 0 < parts < f.instructions
        # every cell's conversion waits (delay_us(1) before it, EOC after): at least one loop pass each
        assert f.wait_delay >= CELLS and f.wait_eoc >= CELLS
        # the scan's 256 conversions are each > 2 µs apart (1 µs settling + 2.17 µs conversion)
        assert f.scan_us > (CELLS - 1) * 3.0
        assert f.settle_us >= 1.0  # the firmware's promise (firmware/README.md)
    # bitwise: 8 conditional shifts per byte; the CRC covers bytes [2, 528) of the frame (docs/protocol.md)
    assert bitwise.crc >= 8 * 2 * CELLS
    assert table.crc >= 2 * CELLS  # at least one instruction per byte
    assert table.crc < bitwise.crc
    assert table.instructions < bitwise.instructions
    # the CRC is the only difference between the images: the rest is the same work
    assert table.instructions - table.crc == pytest.approx(bitwise.instructions - bitwise.crc, rel=0.01)


def test_report_lines(figures):
    lines = bench.report(figures)
    text = "\n".join(lines)
    table, bitwise = (figures[name] for name, _ in bench.IMAGES)
    assert f"{bitwise.crc:,.0f} -> {table.crc:,.0f}" in text
    link = re.search(r"= ([\d.]+) frames/s", text)
    assert link and float(link.group(1)) == pytest.approx(LINK_HZ, abs=0.05)  # 188.7
    assert "165 Hz" in text and "cycle per instruction" in text


def test_main_prints_header_table_and_limits(images, capsys):
    assert bench.main(["--frames", "1"]) == 0
    out = capsys.readouterr().out
    head, *rest = out.splitlines()
    assert head.startswith("firmware benchmark - ") and re.search(r"\d{4}-\d\d-\d\d", head)
    assert "188.7 frames/s" in out
    assert sum(line.startswith("  in pm_crc16_update") for line in rest) == 1

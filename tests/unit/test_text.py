"""The text of files that people, spreadsheets and other makers' software wrote (``psmat._text``):
the expected strings are the ones written, encoded here by Python's own codecs."""

from __future__ import annotations

import codecs

import pytest

from psmat._text import NotTextError, decode_text, read_text

TEXT = "Zeit [µs];Gerät;yeux fermés\r\n0,5;1;2\r\n"


@pytest.mark.parametrize("encoding", ["utf-8", "utf-8-sig", "cp1252", "utf-16", "utf-16-le", "utf-16-be", "utf-32"])
def test_every_encoding_a_spreadsheet_saves_reads_back(encoding: str) -> None:
    data = TEXT.encode(encoding)
    if encoding in ("utf-16-le", "utf-16-be"):  # the mark is what tells UTF-16 from the others
        data = (codecs.BOM_UTF16_LE if encoding.endswith("le") else codecs.BOM_UTF16_BE) + data
    assert decode_text(data) == TEXT


def test_bytes_windows_1252_leaves_undefined_read_as_latin_1() -> None:
    assert decode_text(b"a\x81b\xe9") == "a\x81b\xe9"


@pytest.mark.parametrize("data, byte, offset", [
    (b"t,x\n0,\x001\n", 0x00, 6),
    (codecs.BOM_UTF8 + "é,\x02".encode(), 0x02, 3 + 3),  # the mark and the two bytes of é come first
    (b"\xff\xfe\x00\x01binary", 0xff, 0),  # a UTF-16 mark, but no text in UTF-16: the first byte not UTF-8
    (b"\x89PNG\r\n\x1a\n\x00\x00\x00\rIHDR", 0x89, 0),
])
def test_bytes_that_are_no_text_say_which_byte(data: bytes, byte: int, offset: int) -> None:
    with pytest.raises(NotTextError) as e:
        decode_text(data)
    assert (e.value.byte, e.value.offset) == (byte, offset) and data[offset] == byte
    assert str(e.value) == f"is not text (byte 0x{byte:02x} at offset {offset})"


def test_read_text_reads_the_file(tmp_path) -> None:
    p = tmp_path / "f.csv"
    p.write_bytes(TEXT.encode("utf-16"))
    assert read_text(p) == TEXT
    with pytest.raises(FileNotFoundError):
        read_text(tmp_path / "missing.csv")

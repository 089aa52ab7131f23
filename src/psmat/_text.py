"""The text of a file that a person, a spreadsheet or another maker's software wrote.

Such files are not always UTF-8: Excel's "CSV (comma delimited)" on a western Windows saves
Windows-1252, its "Unicode text" UTF-16 with a byte-order mark, its "CSV UTF-8" UTF-8 with one.
Their numbers are ASCII in all of these, so the encoding decides only how names and labels read
(``Müller``, ``yeux fermés``, ``µs``); a reader that insists on UTF-8 refuses a whole file for
one accented letter in a comment. A file with control bytes (NUL and the like) is no text in any
of these encodings: one clear error. Imports nothing but the standard library.
"""

from __future__ import annotations

import codecs
import os
import re
from pathlib import Path

__all__ = ["NotTextError", "decode_text", "read_text"]

# control characters no text file holds (tab, line feed, vertical tab, form feed and carriage
# return are text)
_CONTROL = re.compile(r"[\x00-\x08\x0e-\x1f\x7f]")


class NotTextError(ValueError):
    """Bytes that are no text: ``str()`` is ``"is not text (byte 0x00 at offset 12)"``.

    Attributes
    ----------
    byte : int
        The first byte that is not text (for bytes that are not UTF-8 either: the first that is
        not UTF-8).
    offset : int
        Its offset in the file (bytes).
    """

    def __init__(self, byte: int, offset: int) -> None:
        super().__init__(f"is not text (byte 0x{byte:02x} at offset {offset})")
        self.byte, self.offset = byte, offset


def _utf16_text(data: bytes) -> str | None:
    """``data`` as UTF-16 or UTF-32 when it begins with their byte-order mark and reads as text in
    which most characters are ASCII (as every table of numbers): else None."""
    for bom, enc in ((codecs.BOM_UTF32_LE, "utf-32"), (codecs.BOM_UTF32_BE, "utf-32"),
                     (codecs.BOM_UTF16_LE, "utf-16"), (codecs.BOM_UTF16_BE, "utf-16")):
        if data.startswith(bom):  # (UTF-32-LE's mark begins with UTF-16-LE's: it is tried first)
            try:
                text = data.decode(enc)
            except UnicodeDecodeError:
                return None
            ascii_share = sum(c < "\x80" for c in text) / max(len(text), 1)
            return text if ascii_share >= 0.5 and not _CONTROL.search(text) else None
    return None


def decode_text(data: bytes) -> str:
    """``data`` decoded: UTF-16 or UTF-32 by their byte-order mark, else UTF-8 (a byte-order mark
    dropped), else Windows-1252, else Latin-1.

    Parameters
    ----------
    data : bytes
        The file's contents.

    Returns
    -------
    str
        The text, without a byte-order mark; line ends as in the file.

    Raises
    ------
    NotTextError
        ``data`` holds control bytes (NUL and the like) in every one of these encodings.
    """
    text = _utf16_text(data)
    if text is not None:
        return text
    try:
        text = data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        bad = (data[exc.start], exc.start)
        try:
            text = data.decode("cp1252")
        except UnicodeDecodeError:  # the five bytes Windows-1252 leaves undefined
            text = data.decode("latin-1")
        if _CONTROL.search(text):
            raise NotTextError(*bad) from None
        return text
    m = _CONTROL.search(text)
    if m:
        k = len(text[:m.start()].encode("utf-8")) + (3 if data.startswith(codecs.BOM_UTF8) else 0)
        raise NotTextError(data[k], k)
    return text


def read_text(path: str | os.PathLike[str]) -> str:
    """The text of the file at ``path``, decoded by :func:`decode_text`.

    Raises
    ------
    OSError
        The file cannot be read (FileNotFoundError when there is none).
    NotTextError
        The file is not text.
    """
    return decode_text(Path(path).read_bytes())

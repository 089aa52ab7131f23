"""The force-platform table reader's two paths (psmat.io._forceplate): a plain table read by NumPy at once
(``_plain_table``) must give exactly what the field-by-field reader (``_table``, any layout) gives, and
leave every other layout to it."""

from __future__ import annotations

import lzma
from pathlib import Path

import numpy as np
import pytest

from psmat.io import bds_files
from psmat.io._forceplate import _HEAD_LINES, _plain_table, _table

RNG = np.random.default_rng(7)


def _body(n: int, sep: str = ",", dec: str = ".") -> str:
    """``n`` rows: time (s) and three numbers, written with ``sep`` and the decimal mark ``dec``."""
    return "".join(sep.join(f"{v:.6f}".replace(".", dec) for v in (k * 0.01, *RNG.normal(size=3))) + "\n"
                   for k in range(n))


def _notes(n: int) -> str:
    return "".join(f"note {k}: a platform's preamble line\n" for k in range(n))


#: layouts NumPy reads at once
PLAIN = {
    "header": "time,x,y,Fz\n" + _body(200),
    "no header": _body(50),
    "units row": "time;x;y;Fz\ns;cm;cm;N\n" + _body(40, ";", ","),
    "a preamble and a rate": "Sampling rate: 100 Hz\nsample\tFz\tCOPx\tCOPy\n" + _body(40, "\t"),
    "tabs, a decimal comma": "time\tx\ty\tFz\n" + _body(40, "\t", ","),
    "runs of spaces": "time x y Fz\n" + _body(40, "   "),
    "quoted names": '"time","x","y","Fz"\n' + _body(30),
    "CRLF and a byte-order mark": ("\ufefftime,x,y,Fz\n" + _body(30)).replace("\n", "\r\n"),
    "one row": "time,x,y,Fz\n0,1,2,3\n",
    "nan and infinities": "time,x,y,Fz\n" + _body(5) + "nan,inf,-inf,1e400\n",
    "a numeric preamble line": "Subject 3\n42\ntime,x,y,Fz\n" + _body(5),
    "preamble up to the head's end": _notes(_HEAD_LINES - 4) + "time,x,y,Fz\n" + _body(50),
}

#: layouts only the field-by-field reader takes (a valid table, or an error it words)
OTHER = {
    "clock times": "time,x,y,Fz\n" + "".join(f"12:00:{k:02d}.5,1,2,3\n" for k in range(30)),
    "an empty field": "time,x,y,Fz\n" + _body(10) + "0.5,,1,2\n" + _body(5),
    "trailing commas": "time,x,y,Fz,\n" + _body(30).replace("\n", ",\n"),
    "trailing tabs": "time\tx\ty\tFz\n" + _body(30, "\t").replace("\n", "\t\n"),
    "a name over two lines": '"time\nin s","x","y","Fz"\n' + _body(30),
    "a number float() reads and NumPy does not": "time,x,y,Fz\n1_0,1,2,3\n" + _body(5),
    "a long preamble": _notes(_HEAD_LINES + 5) + "time,x,y,Fz\n" + _body(50),
    "a short row": "time,x,y,Fz\n" + _body(10) + "0.5,1,2\n",
    "a word among the numbers": _body(10) + "1,2,x,4\n" + _body(5),
    "no data row": "time,x,y,Fz\n",
}


def _lines(text: str) -> list[str]:
    """The lines the reader keeps (as psmat.io._forceplate._read_table: no blank or # lines)."""
    return [ln for ln in text.splitlines() if ln.strip() and not ln.lstrip().startswith("#")]


def _delimiter(lines: list[str]) -> str | None:
    probe = lines[-1]
    return "\t" if "\t" in probe else ";" if ";" in probe else "," if "," in probe else None


def _same(a: tuple, b: tuple) -> None:
    assert a[0] == b[0] and a[2] == b[2] and a[3] == b[3]
    assert a[1].dtype == b[1].dtype == np.float64 and a[1].shape == b[1].shape
    assert a[1].tobytes() == b[1].tobytes()  # bit for bit, NaN included


@pytest.mark.parametrize("name", list(PLAIN))
def test_a_plain_table_is_read_at_once_and_exactly_as_field_by_field(name: str) -> None:
    lines = _lines(PLAIN[name].lstrip("\ufeff"))
    d = _delimiter(lines)
    plain = _plain_table(lines, d)
    assert plain is not None, name
    _same(plain, _table(Path(name), lines, d))


@pytest.mark.parametrize("name", list(OTHER))
def test_every_other_layout_is_left_to_the_field_by_field_reader(name: str) -> None:
    lines = _lines(OTHER[name])
    d = _delimiter(lines)
    assert _plain_table(lines, d) is None
    if name in ("a short row", "a word among the numbers", "no data row"):
        with pytest.raises(ValueError):
            _table(Path(name), lines, d)
    else:
        assert _table(Path(name), lines, d)[1].shape[0] > 0


def test_the_real_bds_trials_are_plain_and_read_the_same() -> None:
    for path in bds_files()[:6]:
        with lzma.open(path, "rt") as fh:
            lines = _lines(fh.read())
        plain = _plain_table(lines, "\t")
        assert plain is not None and plain[1].shape == (len(lines) - 1, 9), path.name
        _same(plain, _table(path, lines, "\t"))

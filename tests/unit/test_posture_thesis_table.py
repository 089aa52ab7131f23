"""psmat.posture.evaluate.TABLE_4_4: Table 4.4 as transcribed equals the thesis' table, row by row.

The thesis' rows are in ``tests/data/thesis_excerpts.txt`` (verbatim, block ``Table 4.4 (§4.4)``).
"""

from __future__ import annotations

import pytest

from psmat.posture.evaluate import OUTPUTS, TABLE_4_4
from thesis_excerpts import thesis_excerpt


def _numbers(line: str) -> list[float]:
    return [float(x) for x in line.split("\t") if x.strip() and x.strip().lstrip("-").replace(".", "", 1).isdigit()]


def test_table_4_4_matches_the_thesis_text() -> None:
    caption, _, header, *rows = thesis_excerpt("Table 4.4 (§4.4)")
    assert caption.startswith("Table 4.4: MSE and R2")
    assert header.split() == ["Subset", *OUTPUTS]
    assert len(rows) == len(TABLE_4_4) == 4
    group = ""
    for line, row in zip(rows, TABLE_4_4):
        group = line.split("\t")[0] or group  # "KSI" or "LSO", given on the first row of its pair
        assert {"KSI": "ksi-leaky", "LSO": "lso"}[group] == row.split, line
        assert row.subset.capitalize() in line.split("\t")
        assert _numbers(line) == [row.mse, *row.r2], row
    assert [r.split for r in TABLE_4_4] == ["ksi-leaky", "ksi-leaky", "lso", "lso"]
    assert TABLE_4_4[3].r2[OUTPUTS.index("Sensor4")] == pytest.approx(-2.446)

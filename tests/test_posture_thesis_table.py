"""psmat.posture.thesis_table: Table 4.4 as transcribed equals the thesis' text, line by line."""

from __future__ import annotations

import pytest

from conftest import shared_path
from psmat.posture.thesis_table import OUTPUTS, TABLE_4_4


def test_table_4_4_matches_the_thesis_text() -> None:
    lines = shared_path("seed", "thesis.txt").read_text(encoding="utf-8").splitlines()
    assert lines[2071 - 1].startswith("Table 4.4: MSE and R2")
    assert lines[2074 - 1].split() == ["Subset", *OUTPUTS]
    for row in TABLE_4_4:
        numbers = [float(x) for x in lines[row.line - 1].split("\t") if x.strip()
                   and x.strip().lstrip("-").replace(".", "", 1).isdigit()]
        assert numbers == [row.mse, *row.r2], row
        assert row.subset.capitalize() in lines[row.line - 1]
    assert [r.split for r in TABLE_4_4] == ["ksi-leaky", "ksi-leaky", "lso", "lso"]
    assert TABLE_4_4[3].r2[OUTPUTS.index("Sensor4")] == pytest.approx(-2.446)

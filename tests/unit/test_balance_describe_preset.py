""":func:`psmat.balance.describe_preset`: the one sentence on the preprocessing, shared by the report
and the study, says the preset's numbers (Quijoux et al. 2021: SWARII to 25 Hz, window 1/25 s,
4th-order Butterworth at 10 Hz, zero phase)."""

from __future__ import annotations

import pytest

from psmat.balance import describe_preset
from psmat.balance._preprocess import CUTOFF_HZ, ORDER, RATE_HZ, WINDOW_S
from psmat.report._analysis import preprocessing_line
from psmat.study._row_metrics import preprocessing_sentence


def test_the_sentence_names_the_preset_constants() -> None:
    assert (RATE_HZ, WINDOW_S, CUTOFF_HZ, ORDER) == (25.0, 1 / 25, 10.0, 4)  # the paper's numbers
    text = describe_preset("quijoux2021")
    for words in ("quijoux2021", "SWARII", "25 Hz", "window 1/25 s", "4th-order Butterworth", "10 Hz",
                  "forward and backward"):
        assert words in text, words
    assert "no resampling, no filter" in describe_preset(None)


def test_the_report_and_the_study_say_it_in_the_same_words() -> None:
    for preset in ("quijoux2021", None):
        assert describe_preset(preset) in preprocessing_line(preset)
        assert describe_preset(preset) in preprocessing_sentence(preset)


def test_an_unknown_preset_is_one_line() -> None:
    with pytest.raises(ValueError, match="preset must be one of quijoux2021 or None, got 'x'"):
        describe_preset("x")

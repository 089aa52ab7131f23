"""The results of a balance study (summary.csv, pairwise.csv, figures, report.md) on rows made
by hand, every expectation computed by hand below (thesis §3.3, Tables 3.5-3.8)."""

from __future__ import annotations

import csv
import io
import math
import re

import numpy as np
import pytest

from psmat.study import thesis_tables as thesis
from psmat.study import write_results
from psmat.study import index_rows, pairwise_rows, summary_rows
from psmat.study import COLUMNS

from thesis_excerpts import thesis_excerpt

NAN = math.nan
PNG = b"\x89PNG\r\n\x1a\n"

# right-leg: V01-V04 ok; V05's session has no platform file (its mat rows carry sway numbers
# that must not enter anything). rotation: V01-V04, SCHC failed for V04. left-leg: no FP at all.
RIGHT = {  # variant: (sd_ml, sd_ap, eu) for V01..V04
    "FP": ([1.0, 2.0, 3.0, 4.0], [2.0, 3.0, 4.0, 5.0], [0.0, 0.0, 0.0, 0.0]),
    "PROP": ([0.5, 1.0, 1.5, 2.0], [2.5, 2.0, 1.5, 1.0], [0.04, 0.02, 0.03, 0.05]),
    "SCHC": ([0.9, 2.1, 2.8, 4.2], [1.9, 3.2, 3.7, 5.5], [0.01, 0.03, 0.02, 0.02]),
    "SCHC-8x8": ([1.2, 1.7, 3.0, 3.0], [2.2, 2.9, 4.1, 4.0], [0.03, 0.01, 0.04, 0.05]),
}
ROTATION = {
    "FP": ([2.0, 4.0, 6.0, 8.0], [3.0, 3.5, 5.0, 6.0], [0.0, 0.0, 0.0, 0.0]),
    "PROP": ([1.5, 3.5, 5.0, 7.0], [2.0, 3.0, 4.0, 4.0], [0.1, 0.2, 0.15, 0.12]),
    "SCHC": ([1.8, 3.9, 6.3, NAN], [2.8, 3.6, 4.5, NAN], [0.05, 0.1, 0.2, NAN]),
    "SCHC-8x8": ([2.1, 3.5, 5.5, 7.5], [3.1, 3.0, 5.5, 5.0], [0.08, 0.25, 0.1, 0.2]),
}
LEFT = {"PROP": ([1.0, 2.0, 3.0], [1.0, 1.0, 4.0]), "SCHC": ([1.5, 2.5, 2.0], [2.0, 2.0, 2.0])}
SUBJECTS = ("V01", "V02", "V03", "V04")


def _row(subject: str, trial: str, variant: str, status: str = "ok", **values: float) -> dict:
    row = {c: NAN for c in COLUMNS}
    row.update(subject=subject, trial=trial, variant=variant, condition="", status=status, **values)
    return row


def _rows() -> list[dict]:
    rows = []
    for trial, table in (("right-leg", RIGHT), ("rotation", ROTATION)):
        for i, s in enumerate(SUBJECTS):
            for variant, (ml, ap, eu) in table.items():
                failed = trial == "rotation" and variant == "SCHC" and s == "V04"
                rows.append(_row(s, trial, variant, "error: ValueError: corrupt" if failed else "ok",
                                 sd_ml_cm=ml[i], sd_ap_cm=ap[i], eu_cm=eu[i], eu_ml_cm=0.6 * eu[i],
                                 eu_ap_cm=0.8 * eu[i]))
        if trial == "right-leg":
            rows.append(_row("V05", trial, "FP", "no force-platform file"))
            for variant in ("PROP", "SCHC", "SCHC-8x8"):
                rows.append(_row("V05", trial, variant, "no force-platform file: no Eu, no lag",
                                 sd_ml_cm=0.1, sd_ap_cm=0.1))
    for i, s in enumerate(SUBJECTS[:3]):
        for variant, (ml, ap) in LEFT.items():
            rows.append(_row(s, "left-leg", variant, sd_ml_cm=ml[i], sd_ap_cm=ap[i]))
    return rows


def _traces() -> dict:
    t = 100.0 + 0.02 * np.arange(600)
    fp = np.c_[10.0 + np.sin(t), 20.0 + 0.7 * np.cos(0.6 * t)]
    out = {}
    for trial in ("right-leg", "rotation"):
        for s in SUBJECTS + ("V05",):
            out[(s, trial)] = {"t_s": t, "FP": fp, "PROP": 0.7 * fp + 1.0, "SCHC": 0.9 * fp - 0.5,
                               "SCHC-8x8": 0.85 * fp + 0.05 * np.sin(7.0 * t)[:, None]}
    return out


def _by(rows: list[dict], **key: str) -> dict:
    found = [r for r in rows if all(r[k] == v for k, v in key.items())]
    assert len(found) == 1, key
    return found[0]


@pytest.fixture(scope="module")
def written(tmp_path_factory):
    d = tmp_path_factory.mktemp("results")
    return d, write_results(d, _rows(), _traces(), ["V06_rotation: no subject in subjects.csv"],
                            label="simulation")


def _read_csv(path) -> list[dict]:
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def test_summary_means_correlations_percentages_and_bland_altman(written) -> None:
    d, _ = written
    rows = _read_csv(d / "summary.csv")
    variants = ("FP", "PROP", "SCHC", "SCHC-8x8")  # FP first, then in order of appearance
    assert [(r["trial"], r["variant"]) for r in rows] == [("right-leg", v) for v in variants] + [
        ("rotation", v) for v in variants] + [("left-leg", "PROP"), ("left-leg", "SCHC")]
    prop = {k: float(v) for k, v in _by(rows, trial="right-leg", variant="PROP").items()
            if k not in ("trial", "variant")}
    # V05 excluded (its 0.1 cm would pull the means) and counted
    assert (prop["n"], prop["n_ok"], prop["n_failed"]) == (4, 4, 1)
    assert prop["sd_ml_mean_cm"] == pytest.approx((0.5 + 1.0 + 1.5 + 2.0) / 4)
    # deviations ±0.75, ±0.25 from 1.25: (0.5625 + 0.0625) * 2 / 3
    assert prop["sd_ml_sd_cm"] == pytest.approx(math.sqrt(1.25 / 3))
    assert prop["sd_ap_mean_cm"] == pytest.approx(1.75)
    assert prop["r_sd_ml"] == pytest.approx(1.0)  # PROP = FP / 2
    assert prop["r_sd_ap"] == pytest.approx(-1.0)  # PROP = 3.5 - FP / 2
    assert prop["pct_smaller_sd_ml"] == 100.0
    assert prop["pct_smaller_sd_ap"] == 75.0  # 2.5 > 2.0 for V01
    assert prop["eu_mean_cm"] == pytest.approx(0.035)
    assert prop["eu_sd_cm"] == pytest.approx(math.sqrt(5e-4 / 3))
    assert prop["eu_ml_mean_cm"] == pytest.approx(0.6 * 0.035)
    assert prop["eu_ap_mean_cm"] == pytest.approx(0.8 * 0.035)
    # Bland–Altman: d_ML = -0.5, -1, -1.5, -2; d_AP = 0.5, -1, -2.5, -4 (SD² = 11.25 / 3)
    assert prop["ba_sd_ml_bias_cm"] == pytest.approx(-1.25)
    assert prop["ba_sd_ml_loa_low_cm"] == pytest.approx(-1.25 - 1.96 * math.sqrt(1.25 / 3))
    assert prop["ba_sd_ml_loa_high_cm"] == pytest.approx(-1.25 + 1.96 * math.sqrt(1.25 / 3))
    assert prop["ba_sd_ap_bias_cm"] == pytest.approx(-1.75)
    assert prop["ba_sd_ap_loa_high_cm"] == pytest.approx(-1.75 + 1.96 * math.sqrt(3.75))

    schc = _by(rows, trial="right-leg", variant="SCHC")
    assert float(schc["pct_smaller_sd_ml"]) == 50.0  # 0.9 < 1, 2.1 > 2, 2.8 < 3, 4.2 > 4
    assert float(schc["pct_smaller_sd_ap"]) == 50.0
    assert float(schc["r_sd_ml"]) == pytest.approx(np.corrcoef(RIGHT["SCHC"][0], RIGHT["FP"][0])[0, 1])

    # rotation: SCHC failed for V04 -> 3 volunteers
    rot = _by(rows, trial="rotation", variant="SCHC")
    assert (int(rot["n"]), int(rot["n_failed"])) == (3, 1)
    assert float(rot["pct_smaller_sd_ml"]) == pytest.approx(200.0 / 3)  # 1.8 < 2, 3.9 < 4, 6.3 > 6
    assert float(rot["r_sd_ap"]) == pytest.approx(np.corrcoef([2.8, 3.6, 4.5], [3.0, 3.5, 5.0])[0, 1])
    assert float(rot["sd_ml_mean_cm"]) == pytest.approx((1.8 + 3.9 + 6.3) / 3)
    fp = _by(rows, trial="rotation", variant="FP")
    assert (int(fp["n"]), int(fp["n_failed"])) == (4, 0)


def test_a_trial_without_platform_gives_nan_where_fp_is_needed(written) -> None:
    d, _ = written
    left = _by(_read_csv(d / "summary.csv"), trial="left-leg", variant="PROP")
    assert (int(left["n"]), int(left["n_ok"])) == (0, 3)
    assert float(left["sd_ml_mean_cm"]) == pytest.approx(2.0)
    assert float(left["sd_ap_sd_cm"]) == pytest.approx(math.sqrt(3.0))  # 1, 1, 4: deviations -1, -1, 2
    for key in ("r_sd_ml", "pct_smaller_sd_ap", "ba_sd_ml_bias_cm", "ba_sd_ap_loa_low_cm"):
        assert math.isnan(float(left[key])), key
    pair = _by(_read_csv(d / "pairwise.csv"), trial="left-leg", variant="PROP", other="SCHC", metric="sd_ml_cm")
    assert int(pair["n"]) == 0 and math.isnan(float(pair["pct_closer"]))


def test_pairwise_percent_closer_to_the_platform(written) -> None:
    d, _ = written
    rows = _read_csv(d / "pairwise.csv")

    def pct(trial: str, v: str, w: str, metric: str) -> tuple[int, float]:
        r = _by(rows, trial=trial, variant=v, other=w, metric=metric)
        return int(r["n"]), float(r["pct_closer"])

    # |SCHC - FP| = .1 .1 .2 .2 against |PROP - FP| = .5 1 1.5 2
    assert pct("right-leg", "SCHC", "PROP", "sd_ml_cm") == (4, 100.0)
    assert pct("right-leg", "PROP", "SCHC", "sd_ml_cm") == (4, 0.0)
    # |8x8 - FP| = .2 .3 0 1 (ML), .2 .1 .1 1 (AP); |SCHC - FP| = .1 .1 .2 .2 (ML), .1 .2 .3 .5 (AP)
    assert pct("right-leg", "SCHC", "SCHC-8x8", "sd_ml_cm") == (4, 75.0)
    assert pct("right-leg", "SCHC-8x8", "SCHC", "sd_ml_cm") == (4, 25.0)
    assert pct("right-leg", "SCHC", "SCHC-8x8", "sd_ap_cm") == (4, 50.0)
    # Eu: SCHC .01 .03 .02 .02, PROP .04 .02 .03 .05, 8x8 .03 .01 .04 .05 (a tie with PROP for V04)
    assert pct("right-leg", "SCHC", "PROP", "eu_cm") == (4, 75.0)
    assert pct("right-leg", "PROP", "SCHC", "eu_cm") == (4, 25.0)
    assert pct("right-leg", "PROP", "SCHC-8x8", "eu_cm") == (4, 25.0)
    assert pct("right-leg", "SCHC-8x8", "PROP", "eu_cm") == (4, 50.0)  # the tie counts for neither
    assert pct("right-leg", "SCHC", "SCHC-8x8", "eu_ap_cm") == (4, 75.0)
    # rotation, without SCHC's failed V04: .05 < .1, .1 < .2, .2 > .15
    assert pct("rotation", "SCHC", "PROP", "eu_cm") == (3, pytest.approx(200.0 / 3))
    assert pct("rotation", "PROP", "SCHC-8x8", "eu_cm") == (4, 50.0)  # .1<.08 no, .2<.25, .15<.1 no, .12<.2


def test_every_figure_is_a_png(written) -> None:
    d, paths = written
    assert set(paths) == {"summary", "pairwise", "report", "sigma_bars", "eu_bars", "cop_traces_right-leg",
                          "cop_traces_rotation", "bland_altman_ml", "bland_altman_ap"}
    for name, path in paths.items():
        assert path.is_file(), name
        if name not in ("summary", "pairwise", "report"):
            assert path.parent == d / "figures"
            data = path.read_bytes()
            assert data[:8] == PNG and len(data) > 10_000, name


def test_the_drawn_session_has_the_median_eu() -> None:
    from psmat.study import median_session

    study = index_rows(_rows())
    # SCHC Eu, right-leg: V01 .01, V03 .02, V04 .02, V02 .03 -> lower middle V03 (V05 not ok)
    assert median_session(study, "right-leg", _traces()) == "V03"
    assert median_session(study, "rotation", _traces()) == "V02"  # .05, .1, .2
    assert median_session(study, "left-leg", _traces()) is None


def test_report_sets_the_thesis_beside_ours(written) -> None:
    d, _ = written
    text = (d / "report.md").read_text(encoding="utf-8")
    assert text.startswith("# Balance study results (simulation)\n")
    assert "5 volunteers, 3 trials (right-leg, rotation, left-leg), 12 sessions;" in text
    assert "| V05 | right-leg | FP | no force-platform file |" in text
    assert "| V05 | right-leg | PROP, SCHC, SCHC-8x8 | no force-platform file: no Eu, no lag |" in text
    assert "| V04 | rotation | SCHC | error: ValueError: corrupt |" in text
    assert "- V06_rotation: no subject in subjects.csv" in text
    assert "| right-leg | PROP | 4 | 1 | 1.25 ± 0.645 | 1.75 ± 0.645 | 1.00 | -1.00 | 100.0 | 75.0 |" in text
    # Table 3.5: thesis PROP 97.6 beside ours 75.0; PROP-C, PROP-8x8, Seating Mat not ours
    assert "### Thesis Table 3.5 (§3.3.1): first prototype" in text
    assert "| σ_AP (right-leg) | 97.6 | 75.0 | 100.0 | — | 95.2 | — | 100.0 | — |" in text
    # Table 3.6: SCHC 50.0, PROP 100.0, SCHC-8x8 50.0 (1.2 > 1, 1.7 < 2, 3 = 3, 3 < 4)
    assert "| σ_ML (right-leg) | 100.0 | 50.0 | 100.0 | — | 100.0 | 100.0 | 100.0 | 50.0 |" in text
    # Table 3.7: the thesis' mean Eu_ML, right-leg SCHC (2.8 + 5.0 + 3.6 + 4.3) / 4 = 3.925e-3; ours 0.6 * 0.02
    assert "| mean (thesis) | 0.003925 |" in text
    assert "| mean (ours) | 0.012 |" in text
    assert "| SCHC vs PROP | σ_ML | right-leg | 100.0 | 100.0 (n=4) | §3.3.2 |" in text
    assert "| SCHC vs SCHC-8x8 | Eu | right-leg | 100.0 | 75.0 (n=4) | §3.3.2 |" in text
    assert "| PROP vs PROP-8x8 | σ_AP | right-leg | 11.9 | — | §3.3.1 |" in text
    assert "ours: right-leg 42.9 %" in text  # 1 - 0.02 / 0.035
    for name in ("sigma_bars", "eu_bars", "cop_traces_right-leg", "bland_altman_ap"):
        assert f"![{name}](figures/{name}.png)" in text


def test_same_rows_give_identical_files(tmp_path, written) -> None:
    d, _ = written
    # the rows as the runner writes and reads metrics.csv: text
    buf = io.StringIO()
    w = csv.DictWriter(buf, COLUMNS)
    w.writeheader()
    w.writerows(_rows())
    again = list(csv.DictReader(io.StringIO(buf.getvalue())))
    write_results(tmp_path, again, _traces(), ["V06_rotation: no subject in subjects.csv"], label="simulation")
    for name in ("summary.csv", "pairwise.csv", "report.md"):
        assert (tmp_path / name).read_bytes() == (d / name).read_bytes(), name


def test_variants_are_not_a_fixed_list(tmp_path) -> None:
    rows = [_row(s, "sit-to-stand", v, sd_ml_cm=m, sd_ap_cm=m, eu_cm=e)
            for s, base in (("A", 1.0), ("B", 2.0), ("C", 4.0))
            for v, m, e in (("NEW-2", 0.5 * base, 0.2), ("FP", base, 0.0), ("NEW-1", 0.9 * base, 0.1))]
    study = index_rows(rows)
    assert study.variants == ("FP", "NEW-2", "NEW-1") and study.trials == ("sit-to-stand",)
    summary = summary_rows(study)
    assert [r["variant"] for r in summary] == ["FP", "NEW-2", "NEW-1"]
    assert summary[1]["r_sd_ml"] == pytest.approx(1.0)
    assert [(r["variant"], r["other"], r["metric"], r["pct_closer"]) for r in pairwise_rows(study)
            if r["metric"] == "sd_ml_cm"] == [("NEW-2", "NEW-1", "sd_ml_cm", 0.0), ("NEW-1", "NEW-2", "sd_ml_cm", 100.0)]
    paths = write_results(tmp_path, rows, {})
    assert "cop_traces_sit-to-stand" not in paths  # no traces given
    assert (tmp_path / "report.md").read_text(encoding="utf-8").startswith("# Balance study results\n")


def test_bad_rows_are_one_clear_error(tmp_path) -> None:
    rows = [_row("V01", "rotation", "FP"), _row("V01", "rotation", "FP")]
    with pytest.raises(ValueError, match="two metrics rows for subject V01, trial rotation, variant FP"):
        write_results(tmp_path, rows, {})
    with pytest.raises(ValueError, match="lacks column"):
        write_results(tmp_path, [{"subject": "V01", "trial": "rotation", "variant": "FP"}], {})


def _names(passage: str, variant: str) -> bool:
    """Whether ``passage`` names ``variant`` as a whole word ("PROP" is not in "PROP-C")."""
    return re.search(rf"(?<![\w-]){re.escape(variant)}(?![\w-])", passage) is not None


def _states(passage: str, metric: str, values: list[float]) -> bool:
    """Whether a clause of ``passage`` about ``metric`` gives ``values`` (%) one after the other,
    or 100 % for every trial. A clause (split at ";") is about σ_ML or σ_AP when it names it, and
    about Eu when it names no σ."""
    axis = {"sd_ml_cm": "σ_{ML}", "sd_ap_cm": "σ_{AP}"}.get(metric)
    for clause in passage.split(";"):
        if (axis in clause) if axis else ("σ_{" not in clause):
            pcts = [float(x) for x in re.findall(r"(\d+(?:\.\d+)?)%", clause)]
            if any(pcts[i:i + len(values)] == values for i in range(len(pcts))):
                return True
            if set(values) == {100.0} and any(s in clause for s in ("always 100%", "100% in all trials",
                                                                      "(100% percentage)")):
                return True
    return False


def test_thesis_numbers_are_those_of_the_cited_tables_and_sections() -> None:
    # the thesis' own lines, verbatim, in tests/data/thesis_excerpts.txt
    def numbers(line: str) -> list[float]:
        return [float(x) for x in line.split("\t")[1:] if x.strip()]

    for table in (thesis.TABLE_3_5, thesis.TABLE_3_6):
        caption, header, *rows = thesis_excerpt(f"{table.name} ({table.section})")
        assert caption.startswith(table.name + ":")
        assert tuple(header.split("\t")[1:]) == table.variants
        assert len(rows) == len(table.rows)
        for (metric, trial), values in table.rows.items():
            axis = {"sd_ml_cm": "ML", "sd_ap_cm": "AP"}[metric]
            name = {"right-leg": "RightLeg", "left-leg": "LeftLeg", "rotation": "Rotation"}[trial]
            line = next(r for r in rows if r.startswith(f"$\\sigma_{{{axis}}}({name})$"))
            assert numbers(line) == list(values), line
    for table in (thesis.TABLE_3_7, thesis.TABLE_3_8):
        caption, _, _, *rows = thesis_excerpt(f"{table.name} ({table.section})")
        assert caption.startswith(table.name + ":")
        assert [r.split("\t")[0] for r in rows] == ["1", "2", "3", "4"]
        for i, line in enumerate(rows):
            assert numbers(line) == [v for t in thesis.TRIALS for v in table.by_volunteer[t][i]], line
    assert thesis.TABLE_3_7.mean("right-leg", "SCHC") == pytest.approx((2.8e-3 + 5.0e-3 + 3.6e-3 + 4.3e-3) / 4)
    for h in thesis.HEADLINES:
        text = thesis_excerpt(h.section)
        if h.metric in ("eu_ml_cm", "eu_ap_cm"):  # "For all the volunteers and trials SCHC improves SCHC-8x8"
            assert set(h.values.values()) == {100.0}
            assert any(p.startswith("For all the volunteers and trials") and _names(p, h.variant)
                       and _names(p, h.other) for p in text), h
            continue
        # a passage that names both variants (or "the rest of variants") and gives the three
        # percentages in trial order, or says 100 % for all trials
        values = [h.values[trial] for trial in thesis.TRIALS]
        assert any(_names(p, h.variant) and (_names(p, h.other) or "the rest of variants" in p)
                   and _states(p, h.metric, values) for p in text), h
    for c in thesis.CORRELATIONS:
        assert any(_names(p, c.variant) and f"{c.value:.2f}".rstrip("0") in p for p in thesis_excerpt(c.section)), c
    lo, hi = thesis.EU_GAIN_SCHC_VS_PROP
    assert any(f"from {lo:g}% to {hi:g}%" in p for p in thesis_excerpt(thesis.EU_GAIN_SECTION))

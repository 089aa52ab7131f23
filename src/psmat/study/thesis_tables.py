"""The thesis' balance results (chapter 3), transcribed once so the report and the docs quote
the same numbers: Tables 3.5-3.8, the percentages of its text and its correlations.

Every value cites where the thesis states it: its table, or the section whose text gives it
(§3.3.1 for the first prototype, §3.3.2 for the second). Trials use the study's names
("right-leg", "left-leg", "rotation"); metrics use the column names of ``metrics.csv``
(``sd_ml_cm``, ``sd_ap_cm``, ``eu_cm``, ``eu_ml_cm``, ``eu_ap_cm``). Percentages are % of
volunteers; Eu in cm (eq. 3.1-3.2, division by N).

Two different experiments: the first prototype (42 volunteers, 60 s at 10 Hz, PROP variants
and a commercial mat, the "Seating Mat") and the second (4 volunteers, 30 s at 100 Hz, the
sensor-model variants).
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["TRIALS", "FIRST", "SECOND", "PercentTable", "EuTable", "Headline", "Correlation", "TABLE_3_5",
           "TABLE_3_6", "TABLE_3_7", "TABLE_3_8", "HEADLINES", "CORRELATIONS", "EU_GAIN_SCHC_VS_PROP",
           "EU_GAIN_SECTION"]

TRIALS = ("right-leg", "left-leg", "rotation")
FIRST = "first prototype: 42 volunteers, 60 s at 10 Hz (thesis §3.2.1)"
SECOND = "second prototype: 4 volunteers, 30 s at 100 Hz (thesis §3.2.2)"


@dataclass(frozen=True)
class PercentTable:
    """% of volunteers whose mat trace spreads less than the platform's (σ_mat < σ_FP)."""

    name: str
    section: str  # the thesis section that presents the table
    experiment: str
    variants: tuple[str, ...]
    #: (metric, trial) -> one % per variant
    rows: dict[tuple[str, str], tuple[float, ...]]


@dataclass(frozen=True)
class EuTable:
    """Eu along one axis by volunteer (cm), SCHC against SCHC-8x8 (Tables 3.7, 3.8)."""

    name: str
    metric: str
    section: str  # the thesis section that presents the table
    variants: tuple[str, ...]
    #: trial -> one (SCHC, SCHC-8x8) pair per volunteer (IDs 1-4)
    by_volunteer: dict[str, tuple[tuple[float, float], ...]]

    def mean(self, trial: str, variant: str) -> float:
        """Mean over the thesis' volunteers of one trial and variant (cm)."""
        k = self.variants.index(variant)
        values = [pair[k] for pair in self.by_volunteer[trial]]
        return sum(values) / len(values)


@dataclass(frozen=True)
class Headline:
    """% of volunteers for whom ``variant`` is closer to FP than ``other`` (the thesis' text):
    for σ, |σ_variant − σ_FP| < |σ_other − σ_FP|; for Eu, Eu_variant < Eu_other."""

    variant: str
    other: str
    metric: str
    section: str  # the thesis section whose text states it
    experiment: str
    #: trial -> %
    values: dict[str, float]


@dataclass(frozen=True)
class Correlation:
    """A Pearson r of σ across volunteers against FP that the text reports: ``value`` exact
    (``bound`` False) or a lower bound over every trial listed (``bound`` True)."""

    variant: str
    metric: str
    trials: tuple[str, ...]
    value: float
    bound: bool
    section: str  # the thesis section whose text states it
    experiment: str


def _three(a: float, b: float, c: float) -> dict[str, float]:
    return dict(zip(TRIALS, (a, b, c)))


# Table 3.5 (thesis §3.3.1): first prototype.
TABLE_3_5 = PercentTable(
    name="Table 3.5", section="§3.3.1", experiment=FIRST, variants=("PROP", "PROP-C", "PROP-8x8", "Seating Mat"),
    rows={("sd_ml_cm", "right-leg"): (100.0, 100.0, 100.0, 97.6),
          ("sd_ap_cm", "right-leg"): (97.6, 100.0, 95.2, 100.0),
          ("sd_ml_cm", "left-leg"): (100.0, 100.0, 100.0, 100.0),
          ("sd_ap_cm", "left-leg"): (97.6, 100.0, 97.6, 100.0),
          ("sd_ml_cm", "rotation"): (85.7, 100.0, 83.3, 100.0),
          ("sd_ap_cm", "rotation"): (66.7, 100.0, 69.0, 100.0)})

# Table 3.6 (thesis §3.3.2): second prototype.
TABLE_3_6 = PercentTable(
    name="Table 3.6", section="§3.3.2", experiment=SECOND, variants=("SCHC", "CHC", "PROP", "SCHC-8x8"),
    rows={("sd_ml_cm", "right-leg"): (100.0, 100.0, 100.0, 100.0),
          ("sd_ap_cm", "right-leg"): (100.0, 100.0, 100.0, 75.0),
          ("sd_ml_cm", "left-leg"): (100.0, 100.0, 100.0, 100.0),
          ("sd_ap_cm", "left-leg"): (100.0, 100.0, 100.0, 75.0),
          ("sd_ml_cm", "rotation"): (100.0, 100.0, 100.0, 100.0),
          ("sd_ap_cm", "rotation"): (100.0, 100.0, 100.0, 100.0)})

# Table 3.7 (thesis §3.3.2): Eu_ML, volunteers 1-4.
TABLE_3_7 = EuTable(
    name="Table 3.7", metric="eu_ml_cm", section="§3.3.2", variants=("SCHC", "SCHC-8x8"),
    by_volunteer={"right-leg": ((2.8e-3, 3.3e-3), (5.0e-3, 5.7e-3), (3.6e-3, 4.2e-3), (4.3e-3, 4.7e-3)),
                  "left-leg": ((4.0e-3, 4.5e-3), (4.9e-3, 5.6e-3), (3.7e-3, 4.5e-3), (6.2e-3, 6.5e-3)),
                  "rotation": ((1.99e-2, 2.75e-2), (1.99e-2, 2.37e-2), (1.59e-2, 2.07e-2), (2.41e-2, 2.71e-2))})

# Table 3.8 (thesis §3.3.2): Eu_AP, volunteers 1-4.
TABLE_3_8 = EuTable(
    name="Table 3.8", metric="eu_ap_cm", section="§3.3.2", variants=("SCHC", "SCHC-8x8"),
    by_volunteer={"right-leg": ((6.9e-3, 1.24e-2), (9.3e-3, 1.19e-2), (7.5e-3, 1.03e-2), (6.2e-3, 9.1e-3)),
                  "left-leg": ((7.1e-3, 1.25e-2), (7.6e-3, 1.23e-2), (7.8e-3, 1.32e-2), (6.8e-3, 1.08e-2)),
                  "rotation": ((2.48e-2, 2.78e-2), (2.51e-2, 2.77e-2), (2.13e-2, 2.75e-2), (2.92e-2, 3.12e-2))})

# The text's "% of volunteers for whom <variant> is better than <other>" (better = closer to FP).
HEADLINES = (
    Headline("PROP", "Seating Mat", "sd_ml_cm", "§3.3.1", FIRST, _three(97.6, 85.7, 100.0)),
    Headline("PROP", "Seating Mat", "sd_ap_cm", "§3.3.1", FIRST, _three(95.2, 100.0, 100.0)),
    Headline("PROP", "Seating Mat", "eu_cm", "§3.3.1", FIRST, _three(90.5, 95.2, 100.0)),
    Headline("PROP", "PROP-C", "sd_ml_cm", "§3.3.1", FIRST, _three(97.6, 97.6, 100.0)),
    Headline("PROP", "PROP-C", "sd_ap_cm", "§3.3.1", FIRST, _three(97.6, 100.0, 100.0)),
    Headline("PROP", "PROP-C", "eu_cm", "§3.3.1", FIRST, _three(92.8, 90.5, 97.6)),
    Headline("PROP", "PROP-8x8", "sd_ml_cm", "§3.3.1", FIRST, _three(42.9, 52.3, 33.3)),
    Headline("PROP", "PROP-8x8", "sd_ap_cm", "§3.3.1", FIRST, _three(11.9, 14.3, 50.0)),
    Headline("PROP", "PROP-8x8", "eu_cm", "§3.3.1", FIRST, _three(100.0, 100.0, 100.0)),
    Headline("SCHC", "PROP", "sd_ml_cm", "§3.3.2", SECOND, _three(100.0, 75.0, 100.0)),
    Headline("SCHC", "PROP", "sd_ap_cm", "§3.3.2", SECOND, _three(100.0, 100.0, 100.0)),
    Headline("SCHC", "CHC", "sd_ml_cm", "§3.3.2", SECOND, _three(75.0, 25.0, 50.0)),
    Headline("SCHC", "CHC", "sd_ap_cm", "§3.3.2", SECOND, _three(100.0, 100.0, 25.0)),
    Headline("SCHC", "SCHC-8x8", "sd_ml_cm", "§3.3.2", SECOND, _three(75.0, 50.0, 25.0)),
    Headline("SCHC", "SCHC-8x8", "sd_ap_cm", "§3.3.2", SECOND, _three(0.0, 0.0, 75.0)),
    # "it outperforms all of them for all volunteers and kind of trial (100% percentage)"
    Headline("SCHC", "PROP", "eu_cm", "§3.3.2", SECOND, _three(100.0, 100.0, 100.0)),
    Headline("SCHC", "CHC", "eu_cm", "§3.3.2", SECOND, _three(100.0, 100.0, 100.0)),
    Headline("SCHC", "SCHC-8x8", "eu_cm", "§3.3.2", SECOND, _three(100.0, 100.0, 100.0)),
    # "For all the volunteers and trials SCHC improves SCHC-8x8 even considering only a single direction"
    Headline("SCHC", "SCHC-8x8", "eu_ml_cm", "§3.3.2", SECOND, _three(100.0, 100.0, 100.0)),
    Headline("SCHC", "SCHC-8x8", "eu_ap_cm", "§3.3.2", SECOND, _three(100.0, 100.0, 100.0)),
)

# Pearson r of σ against FP reported in the text.
CORRELATIONS = (
    Correlation("PROP", "sd_ml_cm", TRIALS, 0.85, True, "§3.3.1", FIRST),
    Correlation("PROP", "sd_ap_cm", TRIALS, 0.85, True, "§3.3.1", FIRST),
    Correlation("PROP-C", "sd_ml_cm", TRIALS, 0.85, True, "§3.3.1", FIRST),
    Correlation("PROP-C", "sd_ap_cm", TRIALS, 0.85, True, "§3.3.1", FIRST),
    Correlation("PROP-8x8", "sd_ml_cm", TRIALS, 0.85, True, "§3.3.1", FIRST),
    Correlation("PROP-8x8", "sd_ap_cm", TRIALS, 0.85, True, "§3.3.1", FIRST),
    Correlation("SCHC", "sd_ml_cm", TRIALS, 0.8, True, "§3.3.2", SECOND),
    Correlation("SCHC", "sd_ap_cm", TRIALS, 0.8, True, "§3.3.2", SECOND),
    Correlation("PROP", "sd_ml_cm", ("right-leg",), 0.70, False, "§3.3.2", SECOND),
    Correlation("CHC", "sd_ml_cm", ("right-leg",), 0.57, False, "§3.3.2", SECOND),
    Correlation("SCHC-8x8", "sd_ml_cm", ("right-leg",), 0.66, False, "§3.3.2", SECOND),
    Correlation("SCHC-8x8", "sd_ml_cm", ("left-leg",), 0.78, False, "§3.3.2", SECOND),
    Correlation("SCHC-8x8", "sd_ap_cm", ("left-leg",), 0.59, False, "§3.3.2", SECOND),
)

# "The average relative improvement of SCHC with respect to PROP [...] ranges from 13% to 37%
# depending on the kind of trial" (mean Eu, second prototype).
EU_GAIN_SCHC_VS_PROP = (13.0, 37.0)
EU_GAIN_SECTION = "§3.3.2"

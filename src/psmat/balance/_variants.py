"""The thesis' processing variants of the mat (Tables 3.2 and 3.4, docs/spec.md §7) as named recipes
on the products of the one chain (:mod:`psmat.process`).

=========  ==============================================================================
PROP       crosstalk removed (IECM), pressure taken proportional to the cell conductance g
PROP-C     as PROP without IECM: the raw equivalent conductance G
CHC        IECM, then the inverse sensor model (hysteresis and creep compensated)
SCHC       CHC on ``f·g``, ``f`` from the body weight (eq. 3.3, :func:`scale_factor`)
SCHC-EQ    SCHC on the equilibrated ``f·g/a``: per-cell gains ``a`` learned from the trial
           itself (:func:`psmat.balance.equilibrate`; beyond the thesis, not in the default
           :data:`VARIANTS`, in :data:`KNOWN_VARIANTS`)
X-8x8      any of them on the emulated 8×8 mat (:func:`psmat.balance.subgrids`), the four
           choices of rows and columns kept apart (the thesis averages their metrics)
=========  ==============================================================================

The force platform (FP) is the reference and not a recipe here. For X-8x8 the per-cell
recipes commute with the selection, so the 8×8 image is a selection of the 16×16 one;
SCHC-8x8 solves eq. 3.3 again on the selected cells, each standing for the area it
represents on the coarser mat, ``(2·pitch)²``. There is no SCHC-EQ-8x8: the emulated 8×8 mat
sees a quarter of the cells, so the force it adds up changes as the load moves between selected
and skipped cells, and the equilibration would read that sampling error as cell gains (measured:
maps of 0.5–2.5 and CoP moved by 1–2 cm on a twin trial whose gains are 15 %).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..profile import Geometry
from ..sensor import MPICreep, inverse_over_gaps
from ._cop import _geometry, cop
from ._emulate import subgrids
from ._equilibrate import equilibrate
from ._scale import _Search, _shared_searches, scale_factor

__all__ = ["BASE_VARIANTS", "VARIANTS", "EXTRA_VARIANTS", "KNOWN_VARIANTS", "VariantName", "describe",
           "legend_label", "VariantTrace", "variant_traces"]

BASE_VARIANTS = ("PROP", "PROP-C", "CHC", "SCHC")
#: The thesis' variants: what a study computes by default.
VARIANTS = BASE_VARIANTS + tuple(f"{v}-8x8" for v in BASE_VARIANTS)
#: Variants beyond the thesis, computed when asked for by name.
EXTRA_VARIANTS = ("SCHC-EQ",)
KNOWN_VARIANTS = VARIANTS + EXTRA_VARIANTS
#: Rows and columns of the full mat per row and column of the emulated 8×8 one (thesis §3.2.1).
_FACTOR = 2


@dataclass(frozen=True)
class VariantName:
    """What a variant's name stands for, for a person reading a report or a figure.

    Attributes
    ----------
    name : str
        As in ``metrics.csv`` (e.g. ``"SCHC-8x8"``).
    expansion : str
        The abbreviation spelled out (the thesis' list of acronyms), e.g. "Scaled Creep and
        Hysteresis Compensation, on an emulated 8x8 mat".
    recipe : str
        What it computes, in one sentence; a composite (``SCHC-8x8``) names its base.
    key : str
        A short key for a figure legend ("IECM + sensor model, scaled to body weight").
    """

    name: str
    expansion: str
    recipe: str
    key: str


# (expansion, recipe, key) of each base name and of each suffix (thesis Tables 3.2, 3.4 and its
# list of acronyms; IECM, the crosstalk removal, is spelled out by whoever shows these)
_BASES = {
    "FP": ("force platform", "the reference, the centre of pressure the platform measures",
           "force platform (reference)"),
    "PROP": ("proportional model", "crosstalk removed by IECM, then pressure taken proportional to the cell "
             "conductance (thesis Tables 3.2, 3.4)", "IECM, pressure ∝ conductance"),
    "PROP-C": ("proportional model without crosstalk removal", "pressure taken proportional to the raw "
               "equivalent conductance, the crosstalk left in (no IECM; thesis Table 3.2)",
               "no crosstalk removal, pressure ∝ conductance"),
    "CHC": ("Creep and Hysteresis Compensation", "crosstalk removed by IECM, then the inverse sensor model, "
            "which compensates the sensor's hysteresis and creep (thesis Table 3.4, §2.5)", "IECM + sensor model"),
    "SCHC": ("Scaled Creep and Hysteresis Compensation", "crosstalk removed by IECM, the conductances scaled so "
             "that the mat's total force matches the body weight (eq. 3.3), then the inverse sensor model "
             "(thesis Table 3.4)", "IECM + sensor model, scaled to body weight"),
}
_SUFFIXES = {
    "-8x8": ("on an emulated 8x8 mat", "on an emulated 8x8 mat: one of every two rows and columns of the 16x16 "
             "(thesis Tables 3.2, 3.4; the four choices kept apart)", "emulated 8x8 mat"),
    "-EQ": ("with per-cell equilibration", "with per-cell gains learned from the trial itself (beyond the "
            "thesis)", "per-cell gains equilibrated"),
    "-DYN": ("with a dynamic correction", "with its centre of pressure corrected by a linear filter fitted on "
             "the other volunteers (beyond the thesis)", "filter fitted on other volunteers"),
}


def describe(name: str) -> VariantName | None:
    """What ``name`` stands for: a base name (FP, PROP, PROP-C, CHC, SCHC) followed by any of the
    suffixes -EQ, -DYN, -8x8 (e.g. ``"SCHC-8x8"``, ``"SCHC-DYN"``); None for a name psmat does not know."""
    base, suffixes = name, []
    while True:
        suffix = next((s for s in _SUFFIXES if base.endswith(s) and len(base) > len(s)), None)
        if suffix is None:
            break
        suffixes.insert(0, suffix)
        base = base[: -len(suffix)]
    if base not in _BASES:
        return None
    parts = [_BASES[base], *(_SUFFIXES[s] for s in suffixes)]
    # a composite names its base (spelled out in its expansion) rather than repeating the base's recipe
    recipe = parts[0][1] if not suffixes else f"{base} " + "; ".join(p[1] for p in parts[1:])
    return VariantName(name, ", ".join(p[0] for p in parts), recipe, ", ".join(p[2] for p in parts))


def legend_label(name: str) -> str:
    """``"SCHC: IECM + sensor model, scaled to body weight"``: a variant with its short key (the name
    alone when psmat does not know it)."""
    found = describe(name)
    return f"{name}: {found.key}" if found else name


@dataclass
class VariantTrace:
    """CoP of one variant: ``cop_cm`` (K, T, 2), K = 1, or 4 for an emulated 8×8 (one per choice)."""

    name: str
    cop_cm: NDArray[np.float64]
    factor: NDArray[np.float64] | None = None  # SCHC's (SCHC-EQ's) f, one per trace


def variant_traces(G: ArrayLike, g: ArrayLike, periods: float | ArrayLike, *, weight_n: float | None,
                   sensor: MPICreep | None = None, pitch_cm: float | None = None,
                   cell_area_cm2: float | None = None, names: tuple[str, ...] = VARIANTS,
                   geometry: Geometry | None = None) -> dict[str, VariantTrace]:
    """The CoP of each named variant from the chain's G and g (T, R, C); missing frames NaN.

    Parameters
    ----------
    G, g : arrays (T, R, C)
        Equivalent conductances and cell conductances after IECM (S), as
        :class:`psmat.process.Processed` holds them (NaN on missing frames).
    periods : float or (T,)
        Frame period(s) (s), for the sensor model's creep.
    weight_n : float or None
        Body weight (N), needed by the SCHC variants only.
    sensor : MPICreep, optional
        The nominal sensor model (default the thesis' Table 2.11).
    pitch_cm : float, optional
        Cell pitch of the full mat (cm), in the default orientation (:func:`cop`); not with
        ``geometry``.
    cell_area_cm2 : float, optional
        Cell area of the full mat (cm²); default the geometry's, ``pitch²``.
    names : tuple of str
        Which variants (default :data:`VARIANTS`; any of :data:`KNOWN_VARIANTS`).
    geometry : psmat.profile.Geometry, optional
        Where the full mat's cells are (a profile's geometry); the 8×8 choices are placed in its
        coordinates (:meth:`~psmat.profile.Geometry.subgrid`). Neither this nor ``pitch_cm``:
        the default profile's geometry.
    """
    unknown = [n for n in names if n not in KNOWN_VARIANTS]
    if unknown:
        raise ValueError(f"unknown variant(s) {unknown}; known: {', '.join(KNOWN_VARIANTS)}")
    if any(n.startswith("SCHC") for n in names) and weight_n is None:
        raise ValueError("SCHC needs the body weight (weight_n)")
    G = np.asarray(G, dtype=np.float64)
    g = np.asarray(g, dtype=np.float64)
    sensor = sensor or MPICreep.thesis()
    geo = _geometry(G.shape[-2:], pitch_cm, geometry)
    cell_area = geo.cell_area_cm2 if cell_area_cm2 is None else float(cell_area_cm2)
    # Work shared between variants, each computed once when first needed. The sensor model acts
    # cell by cell, so a sub-grid's CHC is the slice of the full mat's where their complete frames
    # agree (each frame complete or missing as a whole, as the chain gives them); the SCHC
    # searches share their runs (:func:`scale_factors`), their first at f = 1 being CHC's when CHC
    # came first, and each variant's pressures are its search's last run (the factor is where it ran).
    chc: NDArray[np.float64] | None = None
    whole = _whole_frames(g)
    schc: tuple[tuple[float | None, dict[tuple[int, int], float]], _Search, dict[tuple[int, int], _Search]] | None = None
    out: dict[str, VariantTrace] = {}
    for name in names:
        base, coarse = name.removesuffix("-8x8"), name.endswith("-8x8")
        if coarse:
            choices = [(s.images, geo.subgrid(s.rows0, s.cols0, _FACTOR), (s.rows0, s.cols0))
                       for s in subgrids(G if base == "PROP-C" else g, geo.pitch_cm, _FACTOR)]
            area = cell_area * _FACTOR**2  # each kept cell stands for the cells skipped around it
        else:
            choices = [(G if base == "PROP-C" else g, geo, None)]
            area = cell_area
        cops, factors = [], []
        for img, where, sub in choices:
            if base in ("PROP", "PROP-C"):
                p = img
            elif base == "CHC":
                if sub is not None and not whole:
                    p = inverse_over_gaps(sensor, img, periods)
                else:
                    if chc is None:
                        chc = inverse_over_gaps(sensor, g, periods)
                    # contiguous, as a run of its own gives it: the CoP then sums in the same order
                    p = chc if sub is None else np.ascontiguousarray(chc[:, sub[0]::_FACTOR, sub[1]::_FACTOR])
            elif base == "SCHC-EQ":
                eq = equilibrate(img, periods, float(weight_n), sensor=sensor, cell_area_cm2=area)
                factors.append(eq.factor)
                p = inverse_over_gaps(sensor, eq.apply(img), periods)
            else:
                if schc is None:
                    schc = _shared_searches(g, periods, float(weight_n), sensor, cell_area, _FACTOR,
                                            "SCHC" in names, chc)
                (f_full, f_sub), full_search, sub_searches = schc
                f = f_sub[sub] if sub is not None else f_full
                p = None
                if f is None:  # not in the shared searches
                    f = scale_factor(img, periods, float(weight_n), sensor, area)
                else:  # the search's last run, at f: what inverse_over_gaps gives for f * img
                    p = (full_search if sub is None else sub_searches[sub]).pressure(f, img.shape)
                factors.append(f)
                if p is None:
                    p = inverse_over_gaps(sensor, f * img, periods)
            cops.append(cop(p, geometry=where))
        out[name] = VariantTrace(name, np.stack(cops), np.array(factors) if factors else None)
    return out


def _whole_frames(g: NDArray[np.float64]) -> bool:
    """Every frame of ``g`` (T, R, C) complete or missing as a whole (all NaN): the chain's frames."""
    finite = np.isfinite(g.reshape(g.shape[0], -1))
    return bool(np.all(finite.all(axis=1) | ~finite.any(axis=1)))

"""psmat.regions on synthetic frames whose regions and loads are worked out by hand (docs/spec.md §7 "Regions").

The mat is the thesis' 16×16, 2 cm pitch: a cell is 4 cm², 1 kPa on it is 0.4 N; cell (i, p) sits at
x = 2p cm, y = 2i cm in the default geometry, the subject facing +y (left = smaller x).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from psmat.profile import Geometry
from psmat.regions import (FOOT_REGIONS, SEAT_REGIONS, coefficient_of_variation, dispersion_index_pct, foot_masks,
                           peak_pressure_index_kpa, region_table, seat_masks)

SHAPE = (16, 16)
GEO = Geometry(SHAPE, 2.0)


def block(rows: range, cols: range) -> np.ndarray:
    m = np.zeros(SHAPE, dtype=bool)
    m[rows.start:rows.stop, cols.start:cols.stop] = True
    return m


# Two rectangular feet, rows 2..13 (12 rows, 24 cm long), 4 columns wide: one at columns 2..5
# (50 kPa), one at columns 10..13 (30 kPa); columns 6..9 are empty between them.
FOOT_A = block(range(2, 14), range(2, 6))
FOOT_B = block(range(2, 14), range(10, 14))


def feet_frame() -> np.ndarray:
    p = np.zeros(SHAPE)
    p[FOOT_A] = 50.0
    p[FOOT_B] = 30.0
    p[0, 0] = 2.0            # below the 5 kPa threshold: never loaded
    return p


def ramp(frame: np.ndarray, n: int = 5) -> np.ndarray:
    """Frame k is (k + 1) × frame: a load rising linearly in time."""
    return np.stack([(k + 1) * frame for k in range(n)])


def test_feet_are_found_exactly_with_their_thirds() -> None:
    masks = foot_masks(feet_frame(), GEO)
    assert tuple(masks) == FOOT_REGIONS
    np.testing.assert_array_equal(masks["left"], FOOT_A)     # columns 2..5: x 4..10 cm, the smaller x
    np.testing.assert_array_equal(masks["right"], FOOT_B)
    # 24 cm long from y = 3 cm (rear edge of row 2) to 27 cm: thirds end at 11 and 19 cm, 4 rows each
    for side, cols in (("left", range(2, 6)), ("right", range(10, 14))):
        np.testing.assert_array_equal(masks[f"{side}_rearfoot"], block(range(2, 6), cols))
        np.testing.assert_array_equal(masks[f"{side}_midfoot"], block(range(6, 10), cols))
        np.testing.assert_array_equal(masks[f"{side}_forefoot"], block(range(10, 14), cols))


def test_feet_of_uneven_length_split_into_thirds_by_their_own_length() -> None:
    p = np.zeros(SHAPE)
    p[4:13, 1:4] = 20.0      # 9 rows: 18 cm, thirds of 3 rows
    p[0:6, 9:15] = 20.0      # 6 rows: thirds of 2 rows
    masks = foot_masks(p, GEO)
    np.testing.assert_array_equal(masks["left_rearfoot"], block(range(4, 7), range(1, 4)))
    np.testing.assert_array_equal(masks["left_forefoot"], block(range(10, 13), range(1, 4)))
    np.testing.assert_array_equal(masks["right_midfoot"], block(range(2, 4), range(9, 15)))


def test_mirrored_geometry_keeps_left_on_the_subjects_left() -> None:
    # x = 30 - 2p cm: columns 10..13 now lie at x = 10..4 cm, the smaller x, so they are the left foot
    mirrored = Geometry(SHAPE, 2.0, origin_cm=(30.0, 0.0), x="-columns")
    masks = foot_masks(feet_frame(), mirrored)
    np.testing.assert_array_equal(masks["left"], FOOT_B)
    np.testing.assert_array_equal(masks["right"], FOOT_A)
    # y = -2i: the heel (smaller y) is at the larger row index
    flipped = Geometry(SHAPE, 2.0, y="-rows")
    np.testing.assert_array_equal(foot_masks(feet_frame(), flipped)["left_rearfoot"], block(range(10, 14), range(2, 6)))
    # the CoP in the mirrored coordinates: columns 10..13 -> x = 30 - 23 = 7 cm, rows 2..13 -> y = 15 cm
    table = region_table(feet_frame(), masks, mirrored, dt_s=0.1)
    np.testing.assert_allclose(table["left"].cop_cm[0], [7.0, 15.0])


def test_region_loads_by_hand() -> None:
    masks = foot_masks(feet_frame(), GEO)
    table = region_table(ramp(feet_frame()), masks, GEO, dt_s=0.1)
    k = np.arange(1, 6)
    left, right = table["left"], table["right"]
    # 48 cells × 4 cm² = 192 cm²; 50 kPa × 192 cm² = 9600 kPa·cm² = 960 N
    np.testing.assert_allclose(left.force_n, 960.0 * k)
    np.testing.assert_allclose(right.force_n, 30.0 * 192.0 * 0.1 * k)
    np.testing.assert_allclose(left.contact_area_cm2, 192.0)
    np.testing.assert_allclose(left.peak_kpa, 50.0 * k)
    np.testing.assert_allclose(left.mean_kpa, 50.0 * k)
    assert left.n_cells == 48
    # rectangle centres: left x = (4 + 10)/2 = 7, right x = (20 + 26)/2 = 23, both y = (4 + 26)/2 = 15
    np.testing.assert_allclose(left.cop_cm, np.tile([7.0, 15.0], (5, 1)))
    np.testing.assert_allclose(right.cop_cm, np.tile([23.0, 15.0], (5, 1)))
    np.testing.assert_allclose(table["left_forefoot"].cop_cm[0], [7.0, 23.0])     # rows 10..13: y 20..26
    np.testing.assert_allclose(table["left_forefoot"].force_n, 320.0 * k)        # 16 cells
    # a linear ramp over 0.4 s: ∫ 50(1 + 10t) dt = 50 × (0.4 + 0.8) = 60 kPa·s; ∫ 960(1 + 10t) dt = 1152 N·s
    assert left.pti_kpa_s == pytest.approx(60.0)
    assert left.fti_n_s == pytest.approx(1152.0)
    assert table["left_forefoot"].fti_n_s == pytest.approx(384.0)
    assert table.integrated_s == pytest.approx(0.4)


def test_threshold_counts_contact_but_force_counts_every_cell() -> None:
    user = {"left_half": block(range(0, 16), range(0, 8))}      # a user's mask: holds foot A and the 2 kPa cell
    table = region_table(feet_frame(), user, GEO, t_s=[0.0])
    r = table["left_half"]
    assert r.force_n[0] == pytest.approx(960.0 + 2.0 * 4.0 * 0.1)
    assert r.contact_area_cm2[0] == pytest.approx(192.0)
    assert r.mean_kpa[0] == pytest.approx(50.0) and r.peak_kpa[0] == pytest.approx(50.0)
    assert r.pti_kpa_s == 0.0 and table.integrated_s == 0.0
    # raising the threshold above 50 kPa leaves the foot unloaded: peak 0, mean NaN, contact 0
    high = region_table(feet_frame(), user, GEO, t_s=[0.0], threshold_kpa=60.0)["left_half"]
    assert high.peak_kpa[0] == 0.0 and math.isnan(high.mean_kpa[0]) and high.contact_area_cm2[0] == 0.0


def test_missing_frame_is_left_out_of_the_integrals() -> None:
    p = ramp(feet_frame())
    p[2] = np.nan
    table = region_table(p, foot_masks(feet_frame(), GEO), GEO, t_s=np.arange(5) * 0.1)
    left = table["left"]
    assert table.missing.tolist() == [False, False, True, False, False]
    assert math.isnan(left.force_n[2]) and np.isnan(left.cop_cm[2]).all()
    # only [0, 0.1] and [0.3, 0.4] remain: 0.1 × 50 × ((1 + 2)/2 + (4 + 5)/2) = 30 kPa·s
    assert left.pti_kpa_s == pytest.approx(30.0)
    assert left.fti_n_s == pytest.approx(0.1 * 960.0 * 6.0)
    assert table.integrated_s == pytest.approx(0.2)


# A seat: sacrum rows 0–1 (columns 7–8, 10 kPa); buttocks rows 2–6, columns 2–13 at 20 kPa with
# two ischial peaks of 80 kPa at (4, 4) and (4, 11); thighs rows 8–15, columns 2–6 and 9–13, 30 kPa.
def seat_frame() -> np.ndarray:
    p = np.zeros(SHAPE)
    p[0:2, 7:9] = 10.0
    p[2:7, 2:14] = 20.0
    p[4, 4] = p[4, 11] = 80.0
    p[8:16, 2:7] = 30.0
    p[8:16, 9:14] = 30.0
    return p


def disc(i0: int, j0: int) -> np.ndarray:
    """Cells within 5 cm of cell (i0, j0) on the 2 cm mat: offsets (a, b) with 4(a² + b²) <= 25."""
    m = np.zeros(SHAPE, dtype=bool)
    for a in range(-2, 3):
        for b in range(-2, 3):
            if a * a + b * b <= 6:
                m[i0 + a, j0 + b] = True
    return m


def test_seat_regions_by_hand() -> None:
    masks = seat_masks(np.stack([seat_frame()] * 3), GEO)
    assert tuple(masks) == SEAT_REGIONS
    # loaded extent y = -1..31 cm, middle 15 cm: rows 0..7 rear, 8..15 front
    assert disc(4, 4).sum() == 21
    np.testing.assert_array_equal(masks["left_ischial"], disc(4, 4))
    np.testing.assert_array_equal(masks["right_ischial"], disc(4, 11))
    # behind row 2 (the rearmost ischial row), between columns 4 and 11: the 2×2 sacral block
    np.testing.assert_array_equal(masks["sacrum"], block(range(0, 2), range(7, 9)))
    np.testing.assert_array_equal(masks["thighs"], block(range(8, 16), range(2, 7)) | block(range(8, 16), range(9, 14)))


def test_seat_indices_by_hand() -> None:
    p = seat_frame()
    masks = seat_masks(p, GEO)
    # ischial sum 2 × (20 × 20 + 80) = 960; mat: 4×10 + (58×20 + 2×80) + 80×30 = 3760
    assert dispersion_index_pct(p, masks) == pytest.approx(100.0 * 960.0 / 3760.0)
    # 2 cm pitch: 1 cell = 4 cm², 2×2 = 16 cm² > 10: the 2×2 square, best (80 + 3×20)/4 = 35 kPa
    ppi = peak_pressure_index_kpa(p, GEO)
    assert (ppi.side_cells, ppi.square_area_cm2, ppi.within_range) == (2, 16.0, False)
    assert ppi.value_kpa == pytest.approx(35.0)
    assert (ppi.row, ppi.col) in {(3, 3), (3, 4), (4, 3), (4, 4), (3, 10), (3, 11), (4, 10), (4, 11)}
    # 1 cm pitch: 3×3 = 9 cm², within 9–10; around a peak (80 + 8×20)/9 = 26.7 kPa, inside a thigh 30 kPa
    fine = peak_pressure_index_kpa(p, Geometry(SHAPE, 1.0))
    assert (fine.side_cells, fine.within_range) == (3, True)
    assert fine.value_kpa == pytest.approx(30.0) and fine.row >= 8
    # a pitch of √10 cm: one cell is 10 cm², the peak cell alone
    assert peak_pressure_index_kpa(p, Geometry(SHAPE, math.sqrt(10.0))).value_kpa == pytest.approx(80.0)
    values = np.array([10.0] * 4 + [20.0] * 58 + [80.0] * 2 + [30.0] * 80)
    mean = values.mean()
    sd = math.sqrt(((values - mean) ** 2).mean())
    assert coefficient_of_variation(p) == pytest.approx(sd / mean)
    thighs = coefficient_of_variation(p, mask=masks["thighs"])
    assert thighs == pytest.approx(0.0, abs=1e-12)


def test_user_masks_are_accepted_everywhere() -> None:
    p = seat_frame()
    user = {"front": block(range(8, 16), range(0, 16)), "rear": block(range(0, 8), range(0, 16))}
    assert dispersion_index_pct(p, user, ischial=["rear"]) == pytest.approx(100.0 * 1360.0 / 3760.0)
    table = region_table(p, user, GEO, dt_s=0.05)
    assert table.names == ["front", "rear"]
    assert table["front"].force_n[0] == pytest.approx(80 * 30.0 * 4.0 * 0.1)
    # the rear's CoP by hand: x is symmetric about 15 cm; y = Σ p·y / Σ p
    # row sums: rows 0–1 carry 20 kPa each, rows 2–6 240 kPa, except row 4: 10×20 + 2×80 = 360; row 7 none
    rows = np.array([20.0, 20.0, 240.0, 240.0, 360.0, 240.0, 240.0, 0.0])
    y = (rows * 2.0 * np.arange(8)).sum() / rows.sum()
    np.testing.assert_allclose(table["rear"].cop_cm[0], [15.0, y])


def test_bad_input_is_refused_in_one_line() -> None:
    with pytest.raises(ValueError, match="bool"):
        region_table(feet_frame(), {"a": np.ones(SHAPE)}, GEO, dt_s=0.1)
    with pytest.raises(ValueError, match="shape"):
        region_table(feet_frame(), {"a": np.ones((4, 4), dtype=bool)}, GEO, dt_s=0.1)
    with pytest.raises(ValueError, match="exactly one"):
        region_table(feet_frame(), {"a": FOOT_A}, GEO)
    one = np.zeros(SHAPE)
    one[2:10, 3:12] = 40.0
    with pytest.raises(ValueError, match="one block"):
        foot_masks(one, GEO)
    with pytest.raises(ValueError, match=">= 0"):
        foot_masks(-feet_frame(), GEO)
    with pytest.raises(ValueError, match="ischial"):
        dispersion_index_pct(seat_frame(), {"rear": FOOT_A})

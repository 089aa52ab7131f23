"""Tests of the twin's pressure fields and scenes (psmat.twin.field, .anatomy, .scenes).

Expectations come from physics, computed here independently of the module's closed forms:
forces are Σ p·A with p converted psi → Pa by hand, centres of pressure are first moments
of the field sampled on a fine grid or of the cell image at cell centres (docs/spec.md §7).
"""

from __future__ import annotations

import numpy as np
import pytest

from psmat.balance import cop
from psmat.twin import field as tp
from psmat.twin import (
    PressureScene,
    foot,
    quiet_standing,
    single_leg_sway,
    sitting,
    trajectory_sway,
)

from psmat.io import bds_dir

PSI_IN_PA = 6894.757  # by definition, 1 psi = 6894.757 Pa
PITCH = 2.0
CELL_AREA_M2 = (PITCH / 100.0) ** 2  # 4 cm²


def force_n(pressure_psi: np.ndarray, pitch_cm: float = PITCH) -> np.ndarray:
    """Σ p·A, psi → Pa → N."""
    return pressure_psi.sum(axis=(-2, -1)) * PSI_IN_PA * (pitch_cm / 100.0) ** 2


def cop_cells(pressure: np.ndarray, pitch_cm: float = PITCH) -> np.ndarray:
    """docs/spec.md §7 at cell centres: cell (i, p) at x = p·pitch, y = i·pitch."""
    r, c = pressure.shape[-2:]
    y, x = np.meshgrid(np.arange(r) * pitch_cm, np.arange(c) * pitch_cm, indexing="ij")
    tot = pressure.sum(axis=(-2, -1))
    return np.stack([(pressure * x).sum(axis=(-2, -1)) / tot, (pressure * y).sum(axis=(-2, -1)) / tot], axis=-1)


def field_moments(lobes: tp.Lobes, h: float = 0.05, lim: tuple[float, float] = (-12.0, 44.0)):
    """Total force (N) and CoP (cm) of a continuous field by fine-grid integration."""
    g = np.arange(lim[0], lim[1], h) + h / 2
    x, y = np.meshgrid(g, g)
    p = lobes.pressure_psi(x, y)
    f = p.sum() * PSI_IN_PA * (h / 100.0) ** 2
    return f, np.array([(p * x).sum() / p.sum(), (p * y).sum() / p.sum()])


# ------------------------------------------------------------------------------ foot model
def test_foot_field_integrates_to_load_and_stays_inside_the_foot():
    f = foot(15.0, 15.0, 350.0, side="left", length_cm=24.0, width_cm=9.0)
    total, cop = field_moments(f)
    assert total == pytest.approx(350.0, rel=1e-4)
    assert f.total_force_n == pytest.approx(350.0, rel=1e-12)
    np.testing.assert_allclose(cop, f.cop_cm, atol=1e-3)
    # The foot is 24 cm x 9 cm: no pressure outside its outline.
    g = np.arange(-12.0, 44.0, 0.1)
    x, y = np.meshgrid(g, g)
    p = f.pressure_psi(x, y)
    assert p.min() >= 0.0
    assert np.all(p[np.abs(y - 15.0) > 12.0] == 0.0)
    assert np.all(p[np.abs(x - 15.0) > 4.5] == 0.0)
    loaded = p > 0
    assert np.ptp(y[loaded]) > 21.0 and np.ptp(x[loaded]) > 7.0  # and it fills most of it
    # Heel at the back (small y), forefoot in front; left foot: lateral midfoot at -x.
    heel = f.pressure_psi(15.0, 15.0 - 7.5)
    arch_medial = f.pressure_psi(15.0 + 2.5, 15.0 - 2.0)
    arch_lateral = f.pressure_psi(15.0 - 2.5, 15.0 - 2.0)
    assert heel > arch_lateral > arch_medial


def test_foot_scales_with_length_and_width():
    f = foot(15.0, 15.0, 100.0, length_cm=20.0, width_cm=7.0)
    g = np.arange(0.0, 30.0, 0.1)
    x, y = np.meshgrid(g, g)
    p = f.pressure_psi(x, y)
    assert np.all(p[np.abs(y - 15.0) > 10.0] == 0.0)
    assert np.all(p[np.abs(x - 15.0) > 3.5] == 0.0)


def test_foot_cell_image_carries_the_load():
    f = foot(15.0, 14.0, 350.0, toe_out_deg=10.0)
    img = tp.cell_pressure_psi(f, (16, 16), PITCH)
    assert img.shape == (16, 16) and img.min() >= 0.0
    assert force_n(img) == pytest.approx(350.0, rel=1e-2)
    assert tp.cell_force_n(img, PITCH) == pytest.approx(force_n(img), rel=1e-12)
    np.testing.assert_allclose(cop(img, PITCH), cop_cells(img), atol=1e-12)  # the twin's grid is balance.cop's


def test_moving_foot_gives_a_continuously_moving_cell_cop():
    """A foot sliding by 2 cm in 0.05 cm steps: the cell CoP follows smoothly (supersampling)."""
    dx = np.arange(0.0, 2.0001, 0.05)
    feet = [foot(13.0 + d, 14.0 + 0.5 * d, 350.0) for d in dx]
    imgs = np.stack([f.cells_psi((16, 16), PITCH) for f in feet])
    cc = cop_cells(imgs)
    true = np.array([f.cop_cm for f in feet])
    assert np.abs(cc - true).max() < 0.05 * PITCH
    steps = np.diff(cc, axis=0)
    # Every step moves the cell CoP forward by about the true step (0.05, 0.025) cm.
    np.testing.assert_allclose(steps, np.diff(true, axis=0), atol=0.01)
    # Without supersampling (the cell-centre value only) motion is much rougher.
    rough = np.stack([f.cells_psi((16, 16), PITCH, supersample=1) for f in feet])
    assert np.abs(np.diff(cop_cells(rough), axis=0) - np.diff(true, axis=0)).max() > 0.01


def test_right_foot_is_the_mirror_image_of_the_left():
    left = foot(11.0, 15.0, 300.0, side="left", toe_out_deg=8.0)
    right = foot(19.0, 15.0, 300.0, side="right", toe_out_deg=8.0)
    # Mirror about x = 15 cm, which is the mat's midline for 16 columns at 2 cm.
    np.testing.assert_allclose(left.cells_psi()[:, ::-1], right.cells_psi(), rtol=1e-9, atol=1e-12)


def test_lobes_algebra_and_validation():
    a = tp.Lobes([[0.0, 0.0]], [[2.0, 1.0]], [0.3], [10.0])
    b = a.shifted(4.0, 0.0).scaled(3.0)
    both = a + b
    assert both.total_force_n == pytest.approx(40.0)
    np.testing.assert_allclose(both.cop_cm, [3.0, 0.0])
    assert both.with_total(8.0).total_force_n == pytest.approx(8.0)
    with pytest.raises(ValueError, match="force_n must be >= 0"):
        tp.Lobes([[0.0, 0.0]], [[2.0, 1.0]], [0.0], [-1.0])
    with pytest.raises(ValueError, match="semi_axes_cm must be > 0"):
        tp.Lobes([[0.0, 0.0]], [[0.0, 1.0]], [0.0], [1.0])
    with pytest.raises(ValueError, match="finite"):
        tp.Lobes([[np.nan, 0.0]], [[1.0, 1.0]], [0.0], [1.0])
    with pytest.raises(ValueError, match="same number"):
        tp.Lobes([[0.0, 0.0], [1.0, 1.0]], [[1.0, 1.0]], [0.0], [1.0])


# ------------------------------------------------------------------------------ scenes
def _check_scene_basics(s: PressureScene, n: int, shape=(16, 16)):
    assert isinstance(s, PressureScene)
    assert s.pressure_psi.shape == (n,) + shape
    assert s.t.shape == (n,) and s.force_n.shape == (n,) and s.cop_true_cm.shape == (n, 2)
    assert np.all(np.isfinite(s.pressure_psi)) and s.pressure_psi.min() >= 0.0
    assert np.all(np.diff(s.t) > 0)


@pytest.mark.parametrize(
    "make, n, load",
    [
        (lambda: quiet_standing(10.0, 50.0, seed=3), 500, 700.0),
        (lambda: single_leg_sway(10.0, 50.0, seed=3), 500, 700.0),
        (lambda: sitting(20.0, 10.0, seed=3), 200, 0.75 * 700.0),
        (lambda: quiet_standing(5.0, 20.0, shape=(32, 32), pitch_cm=1.0, weight_n=900.0), 100, 900.0),
    ],
    ids=["quiet_standing", "single_leg", "sitting", "quiet_standing_32x32"],
)
def test_scene_force_and_cop_from_the_cell_image(make, n, load):
    s = make()
    shape = s.pressure_psi.shape[1:]
    _check_scene_basics(s, n, shape)
    pitch = s.meta["pitch_cm"]
    np.testing.assert_allclose(s.force_n, load, rtol=1e-12)
    # Σ p·A of the image = the load within 1 % (feet fully on the 32 cm mat).
    np.testing.assert_allclose(force_n(s.pressure_psi, pitch), load, rtol=1e-2)
    # The docs/spec.md §7 CoP of the image tracks the field's CoP within a small fraction of the pitch.
    err = cop_cells(s.pressure_psi, pitch) - s.cop_true_cm
    assert np.abs(err).max() < 0.1 * pitch
    np.testing.assert_allclose(cop(s.pressure_psi, s.pitch_cm), cop_cells(s.pressure_psi, pitch), atol=1e-12)
    # cop_true is the CoP of the continuous field (checked on a few frames by integration).
    for k in (0, n // 2, n - 1):
        f, c = field_moments(s.field(k), h=0.1)
        assert f == pytest.approx(s.force_n[k], rel=1e-3)
        np.testing.assert_allclose(c, s.cop_true_cm[k], atol=2e-3)


def test_quiet_standing_sways_by_a_few_mm_in_the_band():
    s = quiet_standing(60.0, 50.0, seed=1)
    c = s.cop_true_cm - s.cop_true_cm.mean(axis=0)
    sd = c.std(axis=0)
    assert np.all((sd > 0.1) & (sd < 1.0))  # a few mm
    assert sd[1] > sd[0]  # A-P sway larger than M-L in two-feet standing
    # Nominal CoP at the mat centre (15, 15) cm.
    np.testing.assert_allclose(s.cop_true_cm.mean(axis=0), [15.0, 15.0], atol=0.05)
    # Power between ~0.2 and 1 Hz.
    spec = np.abs(np.fft.rfft(c, axis=0)) ** 2
    freq = np.fft.rfftfreq(c.shape[0], 1.0 / 50.0)
    inband = spec[(freq >= 0.19) & (freq <= 1.01)].sum(axis=0) / spec.sum(axis=0)
    assert np.all(inband > 0.99)
    assert s.meta["n_clipped"] == 0


def test_single_leg_has_one_foot_and_larger_sway():
    qs = quiet_standing(60.0, 20.0, seed=2)
    sl = single_leg_sway(60.0, 20.0, seed=2, side="right")
    loaded_cols = np.flatnonzero(sl.pressure_psi.max(axis=(0, 1)) > 0.05)
    assert np.ptp(loaded_cols) * PITCH <= 10.0  # one foot wide, not two
    assert np.all(sl.cop_true_cm.std(axis=0) > qs.cop_true_cm.std(axis=0))
    # All the weight on one foot: higher pressures than on two feet.
    assert sl.pressure_psi.max() > 1.5 * qs.pressure_psi.max()
    # Clipping is rare and reported.
    assert sl.meta["n_clipped"] < 0.05 * sl.t.size
    assert sl.meta["clipped"].shape == sl.t.shape


def test_sitting_has_ischial_peaks_behind_thighs_and_leans_slowly():
    s = sitting(40.0, 10.0, seed=5, lean_cm=(1.0, 1.5), lean_period_s=20.0)
    mean_img = s.pressure_psi.mean(axis=0)
    i_peak, p_peak = np.unravel_index(np.argmax(mean_img), mean_img.shape)
    assert i_peak * PITCH < 15.0  # the peak is under the tuberosities, posterior half
    front = mean_img[9:].sum()
    assert front > 0.2 * mean_img.sum()  # the thighs carry load in front
    # Two symmetric peaks (left and right tuberosity), ~12 cm apart.
    row = mean_img[i_peak]
    left, right = np.argmax(row[:8]), 8 + np.argmax(row[8:])
    assert 8.0 <= (right - left) * PITCH <= 16.0
    # Slow lean: the CoP oscillates with the 20 s period, amplitude ~1.5 cm A-P.
    ap = s.cop_true_cm[:, 1] - s.cop_true_cm[:, 1].mean()
    spec = np.abs(np.fft.rfft(ap)) ** 2
    freq = np.fft.rfftfreq(ap.size, 0.1)
    assert freq[np.argmax(spec[1:]) + 1] == pytest.approx(0.05, abs=0.01)
    assert np.ptp(ap) == pytest.approx(3.0, rel=0.2)


# ------------------------------------------------------------------------------ symmetry
def test_symmetric_scenes_give_symmetric_images():
    qs = quiet_standing(2.0, 10.0, sway_cm=(0.0, 0.0))
    np.testing.assert_allclose(qs.pressure_psi, qs.pressure_psi[:, :, ::-1], rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(qs.cop_true_cm[:, 0], 15.0, atol=1e-9)
    # Equal load on both feet.
    assert force_n(qs.pressure_psi[:, :, :8]) == pytest.approx(force_n(qs.pressure_psi[:, :, 8:]), rel=1e-9)
    sit = sitting(2.0, 10.0, lean_cm=(0.0, 0.0), sway_cm=(0.0, 0.0))
    np.testing.assert_allclose(sit.pressure_psi, sit.pressure_psi[:, :, ::-1], rtol=1e-9, atol=1e-12)
    # A trajectory and its M-L mirror give mirror images.
    t = np.linspace(0.0, 4.0, 81)
    ml = 1.5 * np.sin(2 * np.pi * 0.5 * t)
    ap = 1.0 * np.cos(2 * np.pi * 0.25 * t)
    a = trajectory_sway(t, ml, ap, 650.0, 20.0, centre=False)
    b = trajectory_sway(t, -ml, ap, 650.0, 20.0, centre=False)
    np.testing.assert_allclose(a.pressure_psi[:, :, ::-1], b.pressure_psi, rtol=1e-9, atol=1e-10)


# ------------------------------------------------------------------------------ trajectories
def test_trajectory_sway_reproduces_a_circle():
    rate = 50.0
    t = np.arange(0.0, 10.0, 0.01)
    radius = 2.0
    ml = radius * np.cos(2 * np.pi * 0.2 * t)
    ap = radius * np.sin(2 * np.pi * 0.2 * t)
    fz = 700.0 + 30.0 * np.sin(2 * np.pi * 0.7 * t)  # the load varies too
    s = trajectory_sway(t, ml, ap, fz, rate, centre=False)
    n = int(np.floor(t[-1] * rate)) + 1
    _check_scene_basics(s, n)
    np.testing.assert_allclose(s.t, np.arange(n) / rate, atol=1e-12)
    want = np.column_stack([np.interp(s.t, t, ml), np.interp(s.t, t, ap)]) + 15.0
    assert s.meta["n_clipped"] == 0
    np.testing.assert_allclose(s.cop_true_cm, want, atol=1e-9)
    np.testing.assert_allclose(s.force_n, np.interp(s.t, t, fz), rtol=1e-12)
    # The continuous field itself (integrated on a fine grid) has that CoP: error << 1 mm.
    for k in range(0, n, 60):
        f, c = field_moments(s.field(k), h=0.1)
        assert f == pytest.approx(s.force_n[k], rel=1e-3)
        assert np.abs(c - want[k]).max() < 2e-3  # 0.02 mm
    # The image: force within 1 %, CoP within a fraction of the pitch; the circle is seen.
    np.testing.assert_allclose(force_n(s.pressure_psi), s.force_n, rtol=1e-2)
    cc = cop_cells(s.pressure_psi)
    assert np.abs(cc - want).max() < 0.1 * PITCH
    r = np.hypot(cc[:, 0] - 15.0, cc[:, 1] - 15.0)
    np.testing.assert_allclose(r, radius, atol=0.1)


def test_trajectory_sway_reproduces_a_real_bds_recording():
    d = np.loadtxt(bds_dir() / "BDS00001.txt.xz", skiprows=1)  # numpy reads the .xz itself
    t, fz, copx, copy = d[:, 0], d[:, 3], d[:, 7], d[:, 8]
    # In BDS COPx is A-P and COPy is M-L.
    s = trajectory_sway(t, copy, copx, fz, 100.0)
    _check_scene_basics(s, t.size)
    np.testing.assert_allclose(s.t, t, atol=1e-9)
    want = np.column_stack([copy - copy.mean(), copx - copx.mean()]) + 15.0
    assert s.meta["n_clipped"] == 0
    np.testing.assert_allclose(s.meta["offset_cm"], [15.0 - copy.mean(), 15.0 - copx.mean()])
    assert np.abs(s.cop_true_cm - want).max() < 1e-6
    for k in (0, 2999, 5999):
        _, c = field_moments(s.field(k), h=0.1)
        assert np.abs(c - want[k]).max() < 2e-3  # continuous field: << 1 mm
    np.testing.assert_allclose(force_n(s.pressure_psi), fz, rtol=1e-2)
    cc = cop_cells(s.pressure_psi)
    assert np.abs(cc - want).max() < 0.05 * PITCH
    # Sway measures of the image agree with the platform's.
    np.testing.assert_allclose(cc.std(axis=0), want.std(axis=0), rtol=0.02)
    # Resampled to the thesis' 10 Hz: frames sample the recording at their times.
    s10 = trajectory_sway(t, copy, copx, fz, 10.0)
    assert s10.t.size == 600
    np.testing.assert_allclose(np.diff(s10.t), 0.1, atol=1e-12)
    want10 = np.column_stack([np.interp(s10.t, t, want[:, 0]), np.interp(s10.t, t, want[:, 1])])
    assert np.abs(s10.cop_true_cm - want10).max() < 1e-6


def test_unreachable_targets_are_clipped_and_reported():
    t = np.linspace(0.0, 2.0, 41)
    ml = 25.0 * np.cos(2 * np.pi * 0.5 * t)  # far outside the feet
    ap = 25.0 * np.sin(2 * np.pi * 0.5 * t)
    s = trajectory_sway(t, ml, ap, 700.0, 20.0, centre=False)
    assert s.meta["n_clipped"] == s.t.size and np.all(s.meta["clipped"])
    assert np.all(s.meta["clip_cm"] > 10.0)
    # The reached CoP is where the field's CoP is, inside the feet, and the load is intact.
    assert np.all((s.cop_true_cm > 2.0) & (s.cop_true_cm < 28.0))
    dist = np.linalg.norm(s.meta["cop_target_cm"] - s.cop_true_cm, axis=1)
    np.testing.assert_allclose(dist, s.meta["clip_cm"], rtol=1e-6)
    f, c = field_moments(s.field(7), h=0.1)
    np.testing.assert_allclose(c, s.cop_true_cm[7], atol=2e-3)
    np.testing.assert_allclose(force_n(s.pressure_psi), 700.0, rtol=1e-2)
    w = s.meta["weights_n"]
    assert np.all(w >= 0.02 * 700.0 - 1e-9)


# ------------------------------------------------------------------------------ reproducibility
def test_same_seed_same_scene_and_different_seed_different_scene():
    for make in (quiet_standing, single_leg_sway, sitting):
        a = make(5.0, 20.0, seed=7)
        b = make(5.0, 20.0, seed=7)
        c = make(5.0, 20.0, seed=8)
        np.testing.assert_array_equal(a.pressure_psi, b.pressure_psi)
        np.testing.assert_array_equal(a.cop_true_cm, b.cop_true_cm)
        assert not np.array_equal(a.cop_true_cm, c.cop_true_cm)


# ------------------------------------------------------------------------------ bad inputs
@pytest.mark.parametrize(
    "call, match",
    [
        (lambda: quiet_standing(1.0, 10.0, shape=(16,)), "shape"),
        (lambda: quiet_standing(1.0, 10.0, shape=(0, 16)), "shape"),
        (lambda: quiet_standing(1.0, 10.0, weight_n=-700.0), "weight_n"),
        (lambda: quiet_standing(1.0, 10.0, weight_n=np.nan), "weight_n"),
        (lambda: quiet_standing(-1.0, 10.0), "duration_s"),
        (lambda: quiet_standing(1.0, 0.0), "rate_hz"),
        (lambda: quiet_standing(1.0, 10.0, pitch_cm=0.0), "pitch_cm"),
        (lambda: quiet_standing(1.0, 10.0, seed=-1), "seed"),
        (lambda: quiet_standing(1.0, 10.0, sway_cm=(0.1, -0.1)), "sway_cm"),
        (lambda: quiet_standing(1.0, 10.0, band_hz=(1.0, 0.5)), "band_hz"),
        (lambda: quiet_standing(1.0, 10.0, supersample=0), "supersample"),
        (lambda: single_leg_sway(1.0, 10.0, side="middle"), "side"),
        (lambda: sitting(1.0, 10.0, seat_fraction=1.5), "seat_fraction"),
        (lambda: foot(15.0, 15.0, -5.0), "load_n"),
        (lambda: foot(15.0, 15.0, 5.0, length_cm=0.0), "foot_length_cm"),
        (lambda: trajectory_sway([0, 1, 2], [0, np.nan, 0], [0, 0, 0], 700.0, 10.0), "cop_ml_cm"),
        (lambda: trajectory_sway([0, 1, 2], [0, 0, 0], [0, 0], 700.0, 10.0), "same length"),
        (lambda: trajectory_sway([0, 2, 1], [0, 0, 0], [0, 0, 0], 700.0, 10.0), "increasing"),
        (lambda: trajectory_sway([0, 1, 2], [0, 0, 0], [0, 0, 0], [700.0, -1.0, 700.0], 10.0), "fz_n"),
        (lambda: trajectory_sway([0, 1, 2], [0, 0, 0], [0, 0, 0], 700.0, -10.0), "rate_hz"),
        (lambda: trajectory_sway([[0, 1]], [0, 0], [0, 0], 700.0, 10.0), "1-D"),
        (lambda: trajectory_sway([0], [0], [0], 700.0, 10.0), "at least 2"),
    ],
)
def test_bad_inputs_raise_value_error(call, match):
    with pytest.raises(ValueError, match=match):
        call()


def test_a_fractional_cell_count_is_a_type_error():
    # psmat._checks.shape2: a float where an integer count is meant is the wrong kind of value
    with pytest.raises(TypeError, match="shape"):
        quiet_standing(1.0, 10.0, shape=(16.5, 16))


def test_unit_conversion_is_psi():
    # A 100 N load spread over the mat: Σ p [psi] · 6894.757 Pa/psi · 4e-4 m² = 100 N.
    f = foot(15.0, 15.0, 100.0)
    img = f.cells_psi()
    assert img.sum() * PSI_IN_PA * CELL_AREA_M2 == pytest.approx(100.0, rel=1e-2)
    assert tp.PSI_PA == PSI_IN_PA
    # Quiet standing of 70 kg: peak cell pressure in the tens of psi (sensor range 0-32 psi).
    s = quiet_standing(1.0, 10.0)
    assert 5.0 < s.pressure_psi.max() < 32.0


def test_load_off_a_small_mat_is_reported():
    s = quiet_standing(1.0, 10.0, shape=(8, 8), pitch_cm=2.0)  # a 16 cm mat: the feet overhang
    seen = force_n(s.pressure_psi) / s.force_n
    assert np.all(seen < 0.9)
    np.testing.assert_allclose(s.meta["force_on_mat_fraction"], seen, rtol=1e-9)
    np.testing.assert_allclose(s.force_n, 700.0)  # the person still weighs 700 N

"""Held-out subjects (beyond the thesis): invariant inputs, the calibration phase and the windows
scored after it, the calibrated ridge, fine-tuning on a subject's calibration windows only, and
``heldout_study``'s table."""

from __future__ import annotations

import csv
import sys

import numpy as np
import pytest

import posture_synth as ps
from psmat.posture.evaluate import heldout_windows, ridge_variants
from psmat.posture.data import (calibration_frames, cop_cells, invariant_features, invariant_recording,
                                     session_reference)
from psmat.posture.data import Recording
from psmat.posture.data import lso_split

W = 20
CAL_S = 10.0  # 100 samples at posture_synth's 10 Hz


def _placed(rec: Recording, size: int, row: int, col: int, k: float = 1.0) -> Recording:
    """The recording's print on a larger mat at (row, col), its values scaled by k (a heavier sitter)."""
    T, R, C = rec.image.shape
    img = np.zeros((T, size, size), np.float32)
    img[:, row:row + R, col:col + C] = k * rec.image
    return Recording(rec.subject, rec.day, rec.t_s, img, rec.angles_rad, rec.meta)


def _offset_study(n_subjects: int = 4, days: int = 2, T: int = 300, noise: float = 0.0) -> list[Recording]:
    """posture_synth's relation with a per-subject offset of the measured angles (e.g. the IMUs'
    mounting): the images cannot tell it, a calibration phase can."""
    recs = []
    for s in range(n_subjects):
        off = np.random.default_rng(100 + s).uniform(-0.3, 0.3, 5)
        for d in range(days):
            r = ps.recording(f"P{s + 1:02d}", d + 1, T, 8, 8, seed=s * 10 + d, noise=noise)
            recs.append(Recording(r.subject, r.day, r.t_s, r.image, r.angles_rad + off, r.meta))
    return recs


@pytest.mark.parametrize("centre", ["session", "frame"])
def test_invariant_images_ignore_weight_and_whole_cell_seat_moves(centre):
    rec = ps.recording("P01", 1, 200, 8, 8, seed=1)
    a = invariant_recording(_placed(rec, 14, 2, 3), CAL_S, centre=centre).image
    b = invariant_recording(_placed(rec, 14, 5, 1, k=3.0), CAL_S, centre=centre).image
    np.testing.assert_allclose(a, b, rtol=0, atol=1e-6 * np.abs(a).max())
    # each image is in units of the straight-back phase's mean total: those frames sum to 1 on average
    assert a[:100].sum(axis=(1, 2)).mean() == pytest.approx(1.0, rel=1e-6)
    mid = np.array([6.5, 6.5])
    if centre == "session":
        # the phase's summed print has its CoP on the mat's centre; frames move about it with the posture
        np.testing.assert_allclose(cop_cells(a[:100].sum(axis=0)[None])[0][0], mid, atol=1e-6)
        assert np.ptp(cop_cells(a)[0], axis=0).max() > 0.1
    else:
        np.testing.assert_allclose(cop_cells(a)[0], np.tile(mid, (200, 1)), atol=1e-6)


def test_invariant_features_ignore_weight_and_seat_and_measure_the_cop_from_the_reference():
    rec = ps.recording("P01", 1, 200, 8, 8, seed=2)
    f = invariant_features(_placed(rec, 14, 2, 3), CAL_S)
    g = invariant_features(_placed(rec, 14, 6, 4, k=0.4), CAL_S)
    np.testing.assert_allclose(f, g, rtol=1e-6, atol=1e-7)  # float32 images scaled by 0.4
    assert f.shape == (200, 6 + 14 + 14)
    # the reference CoP is the total-weighted mean of the phase's CoPs: their weighted deviations cancel
    phase = _placed(rec, 14, 2, 3).image[:100]
    cop, total = cop_cells(phase)
    np.testing.assert_allclose(total @ f[:100, :2], 0.0, atol=1e-9 * total.sum())
    np.testing.assert_allclose(cop[:, 0] - f[:, 0][:100], session_reference(_placed(rec, 14, 2, 3), CAL_S).cop_cells[0])
    # the load ratio and the row and column shares (fractions of each frame's total)
    np.testing.assert_allclose(f[:100, 5].mean(), 1.0, rtol=1e-9)
    np.testing.assert_allclose(f[:, 6:20].sum(axis=1), 1.0, rtol=1e-6)
    np.testing.assert_allclose(f[:, 20:].sum(axis=1), 1.0, rtol=1e-6)


def test_a_session_with_an_empty_calibration_phase_has_no_reference():
    rec = ps.recording("P01", 1, 200, 8, 8)
    img = rec.image.copy()
    img[:100] = 0
    with pytest.raises(ValueError, match="P01 day 1: the mat reads nothing in the first 10.0 s"):
        session_reference(Recording("P01", 1, rec.t_s, img, rec.angles_rad), CAL_S)


def test_scored_windows_start_after_the_calibration_phase_and_hold_no_training_subject():
    recs = ps.study(6, 2, 300)
    for r in recs:
        r.t_s = r.t_s + 1000.0  # the phase is timed from each recording's first sample
    sp = lso_split(recs, window=W)
    held = heldout_windows(recs, sp, CAL_S)
    assert held.n_calibration == [100] * len(recs)
    assert sp.subjects["test"] == ("P05", "P06") and sp.subjects["validation"] == ("P04",)
    test, cal = held.scored["test"], held.calibration["test"]
    assert {recs[r].subject for r in test[:, 0]} == {"P05", "P06"}
    assert not {recs[r].subject for r in test[:, 0]} & set(sp.subjects["train"])
    assert test[:, 1].min() == 100 and (test[:, 1] + W).max() == 300  # after the first 10 s, to the end
    assert len(test) == 4 * (300 - W + 1 - 100)
    assert len(cal) == 4 * (100 - W + 1) and (cal[:, 1] + W).max() == 100
    # no frame of a scored window lies in its session's calibration phase
    for r in np.unique(test[:, 0]):
        assert test[test[:, 0] == r, 1].min() >= calibration_frames(recs[r], CAL_S)
    assert {recs[r].subject for r in held.scored["validation"][:, 0]} == {"P04"}


def test_a_calibration_phase_shorter_than_a_window_is_one_clear_error():
    recs = ps.study(3, 1, 300)
    with pytest.raises(ValueError, match="P02 day 1: its first 1 s hold 10 samples, fewer than one window of 20"):
        heldout_windows(recs, lso_split(recs, window=W), 1.0)
    with pytest.raises(ValueError, match="no window of 20 samples after its first 29 s"):
        heldout_windows(recs, lso_split(recs, window=W), 29.0)


def test_an_offset_calibration_rescues_the_ridge_on_a_subject_with_an_offset():
    recs = _offset_study()
    sp = lso_split(recs, window=W)
    held = heldout_windows(recs, sp, CAL_S)
    inv = [invariant_recording(r, CAL_S) for r in recs]
    _, pred = ridge_variants(recs, inv, sp, held, CAL_S, calibrated_suffix=" calibrated")
    from psmat.posture.data import WindowTargets

    y = WindowTargets(recs, W)(held.scored["test"])
    mse = {k: float(np.mean((v["test"] - y) ** 2)) for k, v in pred.items()}
    # the raw image is exactly linear in the angles: calibrated, only the fit's own error remains
    assert mse["ridge-PCA calibrated"] < 0.05 * mse["ridge-PCA"]
    assert mse["ridge-PCA invariant features calibrated"] < 0.5 * mse["ridge-PCA invariant features"]
    # the raw ridge's error before calibration is the test subject's offset from the training subjects' mean
    offs = {s: np.random.default_rng(100 + s).uniform(-0.3, 0.3, 5) for s in range(4)}
    assert sp.subjects["train"] == ("P01", "P02") and sp.subjects["test"] == ("P04",)
    expected = offs[3] - (offs[0] + offs[1]) / 2
    np.testing.assert_allclose((y - pred["ridge-PCA"]["test"])[:, :5].mean(axis=0), expected, atol=0.03)


def test_the_invariant_modules_do_not_import_torch():
    import subprocess

    code = ("import sys, psmat.posture.data, psmat.posture.evaluate; "
            "sys.exit('torch' in sys.modules)")
    assert subprocess.run([sys.executable, "-c", code]).returncode == 0


torch = pytest.importorskip("torch")
from psmat.posture.data import Standardiser  # noqa: E402
from psmat.posture.learn import FinetuneConfig, PostureCNN, finetune, heldout_study, model_names  # noqa: E402


def test_finetuning_trains_on_the_given_windows_only_and_leaves_the_model_alone():
    recs = _offset_study(4, 1)
    torch.manual_seed(0)
    model = PostureCNN(W, 64).eval()
    before = {k: v.clone() for k, v in model.state_dict().items()}
    cal = np.array([[3, s] for s in range(0, 81)])
    std = Standardiser.fit(recs, cal, W)
    net, drawn = finetune(model, recs, cal, W, std, FinetuneConfig(epochs=2, layers="head"), seed=1)
    # each epoch draws every calibration window once, and nothing else
    assert drawn.shape == (2 * 81, 2)
    for e in range(2):
        assert sorted(map(tuple, drawn[e * 81:(e + 1) * 81])) == sorted(map(tuple, cal))
    assert all(torch.equal(before[k], v) for k, v in model.state_dict().items())
    after = net.state_dict()
    assert all(torch.equal(before[k], after[k]) for k in before if k.startswith("features."))
    assert not torch.equal(before["head.1.weight"], after["head.1.weight"])
    with pytest.raises(ValueError, match="layers must be one of last, head, all"):
        finetune(model, recs, cal, W, std, FinetuneConfig(layers="conv"))  # type: ignore[arg-type]


SMALL = dict(epochs=1, windows_per_epoch=64, calibration_s=CAL_S, window=W, threads=1, progress=False,
             finetune_config=FinetuneConfig(epochs=1))


def test_heldout_study_scores_every_model_on_the_same_windows_and_writes_the_table(tmp_path):
    recs = _offset_study(4, 2, noise=0.01)
    res = heldout_study(recs, tmp_path, **SMALL)
    names = model_names(CAL_S)
    assert names[2] == "CNN fine-tuned 10 s" and names[4] == "CNN calibrated 10 s"
    assert names[7] == "ridge-PCA calibrated 10 s"
    with (tmp_path / "heldout.csv").open() as f:
        table = list(csv.DictReader(f))
    n_test = 2 * (300 - W + 1 - 100)
    assert [(r["model"], r["subset"]) for r in table if r["subset"] == "test"] == [(n, "test") for n in names]
    assert {r["model"] for r in table if r["subset"] == "validation"} == {
        "CNN", "CNN invariant", "ridge-PCA", "ridge-PCA invariant", "ridge-PCA invariant features"}
    assert {(r["split"], r["n_windows"]) for r in table if r["subset"] == "test"} == {("lso", str(n_test))}
    assert all(np.isfinite(float(r["R2_Sum"])) for r in table)
    # the test subject P04's windows after its first 10 s, and each fine-tuning drew only its calibration windows
    test = res.windows.scored["test"]
    assert {recs[r].subject for r in test[:, 0]} == {"P04"} and test[:, 1].min() == 100
    for name in ("CNN fine-tuned 10 s", "CNN invariant fine-tuned 10 s"):
        (subject, drawn), = res.drawn[name].items()
        assert subject == "P04" and {recs[r].subject for r in drawn[:, 0]} == {"P04"}
        assert (drawn[:, 1] + W).max() == 100
    # the calibrated CNN: its own predictions plus the subject's mean residual over the calibration
    # windows (computed here by hand from the model, the targets and the windows)
    from psmat.posture.learn import WindowDataset, predict
    from psmat.posture.data import WindowTargets

    cal = res.windows.calibration["test"]
    resid = WindowTargets(recs, W)(cal) - predict(res.cnn.model, WindowDataset(recs, cal, W, res.cnn.standardiser))
    np.testing.assert_allclose(res.predictions["CNN calibrated 10 s"]["test"],
                               res.predictions["CNN"]["test"] + resid.mean(axis=0), rtol=1e-6, atol=1e-9)
    assert res.figure_path == tmp_path / "figures" / "heldout_r2.png" and res.figure_path.stat().st_size > 10_000
    assert (tmp_path / "model_lso.pt").is_file() and (tmp_path / "invariant" / "model_lso.pt").is_file()


def test_fewer_than_three_subjects_is_one_clear_error_before_any_training(tmp_path):
    with pytest.raises(ValueError, match="LSO needs at least 3 subjects"):
        heldout_study(ps.study(2, 1, 300), tmp_path, **SMALL)
    assert not any(tmp_path.iterdir())

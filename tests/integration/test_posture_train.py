"""Splits (KSI in contiguous blocks, the thesis' leaky KSI, LSO), training (loss, resume,
Table 4.4 CSV, figures) and the ridge-PCA baseline (beyond the thesis)."""

from __future__ import annotations

import csv

import numpy as np
import pytest

import posture_synth as ps
from psmat.posture.data import WindowTargets, ksi_leaky_split, ksi_split, lso_split, lso_subjects
from psmat.posture.evaluate import ridge_pca_rows

W = 50


def _frames(windows, r, window=W):
    return {f for rr, s in windows if rr == r for f in range(s, s + window)}


def test_ksi_contiguous_blocks_share_no_frame_and_keep_the_proportions():
    recs = ps.study(3, 2, 700)
    sp = ksi_split(recs, window=W, seed=5)
    for r, rec in enumerate(recs):
        sets = {k: _frames(sp.windows[k], r) for k in sp.windows}
        assert not sets["train"] & sets["validation"] and not sets["train"] & sets["test"]
        assert not sets["validation"] & sets["test"]
        # every frame of a block is in some window of it, so the blocks are 70/10/20 % of time
        assert len(sets["validation"]) == 70 and len(sets["test"]) == 140
        assert len(sets["train"]) == 490
    # no window appears in two sets, and each window is 50 consecutive frames of one recording
    rows = {k: {tuple(x) for x in v} for k, v in sp.windows.items()}
    assert not rows["train"] & rows["test"] and not rows["train"] & rows["validation"]
    assert sp.subjects["test"] == sp.subjects["train"] == ("P01", "P02", "P03")
    # the test block is not always at the same place
    assert len({int(sp.windows["test"][sp.windows["test"][:, 0] == r, 1].min()) for r in range(len(recs))}) > 1


def test_thesis_ksi_leaks_frames_into_test():
    recs = ps.study(2, 1, 700)
    sp = ksi_leaky_split(recs, window=W, seed=0)
    n = 2 * (700 - W + 1)
    assert [len(sp.windows[k]) for k in ("train", "validation", "test")] == [round(0.7 * n), round(0.1 * n),
                                                                             n - round(0.7 * n) - round(0.1 * n)]
    shared = sum(len(_frames(sp.windows["train"], r) & _frames(sp.windows["test"], r)) for r in range(2))
    assert shared > 0.9 * len(_frames(sp.windows["test"], 0) | _frames(sp.windows["test"], 1))


def test_ksi_refuses_recordings_too_short_for_a_block():
    with pytest.raises(ValueError, match="validation block has 40 frames"):
        ksi_split(ps.study(1, 1, 400), window=W)


def test_lso_holds_subjects_out():
    recs = ps.study(12, 1, 120)
    sp = lso_split(recs, window=W)
    # Table 4.3: P1-P8 train, P9 validation, P10-P12 test
    assert sp.subjects == {"train": tuple(f"P{i:02d}" for i in range(1, 9)), "validation": ("P09",),
                           "test": ("P10", "P11", "P12")}
    train_subjects = {recs[r].subject for r in sp.windows["train"][:, 0]}
    test_subjects = {recs[r].subject for r in sp.windows["test"][:, 0]}
    assert not train_subjects & test_subjects
    assert len(sp.windows["test"]) == 3 * (120 - W + 1)


def test_lso_seeded_choice_in_the_thesis_proportions():
    ids = [f"S{i}" for i in range(20)]
    a, b, c = lso_subjects(ids, seed=1), lso_subjects(ids, seed=1), lso_subjects(ids, seed=2)
    assert a == b and a != c
    assert [len(a[k]) for k in ("train", "validation", "test")] == [13, 2, 5]  # 20/12 -> 2, 20/4 -> 5
    assert set(a["train"]) | set(a["validation"]) | set(a["test"]) == set(ids)
    assert not set(a["train"]) & set(a["test"])
    with pytest.raises(ValueError, match="at least 3 subjects"):
        lso_subjects(["A", "B"])


def test_ridge_pca_recovers_an_exactly_linear_relation():
    # noise-free synthetic images are linear in the angles, so the window means are too
    recs = ps.study(5, 1, 300, 8, 8, noise=0.0)
    sp = lso_split(recs, window=W)
    model, rows, pred = ridge_pca_rows(recs, sp)
    y_test = WindowTargets(recs, W)(sp.windows["test"])
    np.testing.assert_allclose(pred["test"], y_test, atol=1e-5)
    assert min(rows[1][k] for k in rows[1] if k.startswith("R2_")) > 0.9999
    assert model.n_components >= 5


torch = pytest.importorskip("torch")
from psmat.posture.learn import train_posture  # noqa: E402

SMALL = dict(window=20, windows_per_epoch=256, augment=False, progress=False, baseline=False, threads=1)


def test_training_lowers_the_validation_loss_below_a_constant_guess(tmp_path):
    recs = ps.study(3, 1, 600, 8, 8, noise=0.02)
    res = train_posture(recs, tmp_path, split="ksi", epochs=8, patience=8, **{**SMALL, "baseline": True})
    wt = WindowTargets(recs, 20)
    y_train, y_val = wt(res.split.windows["train"]), wt(res.split.windows["validation"])
    constant = np.mean((y_val - y_train.mean(axis=0)) ** 2)  # MSE of predicting the training mean
    assert res.history[-1]["epoch"] == 8
    best = min(h["val_loss"] for h in res.history[1:])
    assert best < res.history[0]["val_loss"] / 10 and best < 0.6 * constant
    assert res.rows[0]["MSE"] == pytest.approx(best, rel=1e-5)  # the best model was restored
    with (tmp_path / "table44_ksi.csv").open() as f:
        table = list(csv.DictReader(f))
    assert [(r["model"], r["split"], r["subset"]) for r in table] == [
        ("cnn", "ksi", "validation"), ("cnn", "ksi", "test"), ("ridge-pca", "ksi", "validation"),
        ("ridge-pca", "ksi", "test")]
    assert float(table[1]["R2_Sum"]) == pytest.approx(res.rows[1]["R2_Sum"], rel=1e-5)
    assert [p.name for p in res.figure_paths] == ["ksi_validation.png", "ksi_test.png"]
    assert all(p.stat().st_size > 10_000 for p in res.figure_paths)


class Killed(Exception):
    pass


def test_resumed_training_ends_with_the_same_weights(tmp_path):
    recs = ps.study(3, 1, 400, 8, 8, noise=0.02)
    kw = dict(split="lso", seed=3, epochs=3, **{**SMALL, "augment": True})
    whole = train_posture(recs, tmp_path / "whole", **kw)

    def kill(epoch, record):
        if epoch == 2:
            raise Killed

    with pytest.raises(Killed):
        train_posture(recs, tmp_path / "killed", on_epoch=kill, **kw)
    resumed = train_posture(recs, tmp_path / "killed", **kw)
    assert whole.resumed_from == 0 and resumed.resumed_from == 2
    a, b = whole.model.state_dict(), resumed.model.state_dict()
    assert a.keys() == b.keys() and all(torch.equal(a[k], b[k]) for k in a)
    assert [h["val_loss"] for h in resumed.history] == [h["val_loss"] for h in whole.history]
    with pytest.raises(ValueError, match="another training"):
        train_posture(recs, tmp_path / "killed", **{**kw, "lr": 1e-4})


def test_unknown_split_is_one_clear_error(tmp_path):
    with pytest.raises(ValueError, match="split must be one of ksi, ksi-leaky, lso"):
        train_posture(ps.study(3, 1, 200), tmp_path, split="loso")

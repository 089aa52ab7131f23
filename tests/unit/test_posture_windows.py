"""Windows of 50 frames at stride 1 without copies, their targets, the training-set
standardisation and the augmentation (thesis §4.3)."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("torch")

import posture_synth as ps  # noqa: E402
from psmat.posture.data import (Standardiser, WindowTargets, all_windows, augment_window, frame_masks,  # noqa: E402
                                ksi_split, window_image)
from psmat.posture.learn import WindowDataset  # noqa: E402

W = 50


@pytest.fixture(scope="module")
def recs():
    return [ps.recording("P01", 1, 600, seed=1), ps.recording("P02", 1, 720, 8, 8, seed=2, noise=0.1)]


def test_all_windows_stride_one_inside_each_recording(recs):
    w = all_windows(recs, W)
    assert len(w) == (600 - W + 1) + (720 - W + 1)
    assert w[0].tolist() == [0, 0] and w[600 - W].tolist() == [0, 600 - W] and w[-1].tolist() == [1, 720 - W]


def test_window_is_a_view_equal_to_the_slice(recs):
    x = window_image(recs, (1, 123), W)
    np.testing.assert_array_equal(x, recs[1].image[123:123 + W])
    assert np.shares_memory(x, recs[1].image)


def test_dataset_item_is_the_standardised_slice_and_holds_no_copies(recs):
    w = all_windows(recs, W)
    std = Standardiser(mean=1e-3, sd=2e-4)
    ds = WindowDataset(recs, w, W, std)
    x, y = ds[len(w) - 5]
    r, s = w[len(w) - 5]
    expected = ((recs[r].image[s:s + W].astype(np.float64) - 1e-3) / 2e-4).reshape(1, W, 64)
    np.testing.assert_allclose(x.numpy(), expected, rtol=1e-5, atol=1e-4)
    np.testing.assert_allclose(y.numpy(), recs[r].targets[s:s + W].mean(axis=0), rtol=1e-6, atol=1e-7)
    # what the dataset keeps per window: its (recording, start) row (2 int64) and 6 float32 targets
    held = sum(a.nbytes for a in vars(ds).values() if isinstance(a, np.ndarray))
    assert held == len(w) * (2 * 8 + 6 * 4)
    assert held * 50 < len(w) * W * 64 * 4  # far below one copy of the windows


def test_window_targets_are_means_over_the_window(recs):
    w = np.array([[0, 0], [1, 670], [0, 17]])
    got = WindowTargets(recs, W)(w)
    for row, (r, s) in zip(got, w):
        a = recs[r].angles_rad[s:s + W]
        np.testing.assert_allclose(row[:5], a.mean(axis=0), atol=1e-12)
        np.testing.assert_allclose(row[5], a.sum(axis=1).mean(), atol=1e-12)


def test_standardiser_uses_training_frames_only_each_once(recs):
    sp = ksi_split(recs, window=W, seed=3)
    masks = frame_masks(recs, sp.windows["train"], W)
    frames = np.concatenate([rec.image[m].ravel() for rec, m in zip(recs, masks)]).astype(np.float64)
    std = Standardiser.fit(recs, sp.windows["train"], W)
    assert std.mean == pytest.approx(frames.mean(), rel=1e-9)
    assert std.sd == pytest.approx(frames.std(), rel=1e-7)
    # a frame shared by many training windows is not weighted by their number
    stacked = np.concatenate([window_image(recs, row, W).ravel() for row in sp.windows["train"]]).astype(np.float64)
    assert abs(stacked.mean() - frames.mean()) > 1e-9
    # changing every validation and test frame leaves the statistics as they were
    changed = [ps.recording(r.subject, r.day, r.n_samples, seed=0) for r in recs]
    for rec, new, m in zip(recs, changed, masks):
        new.image[m] = rec.image[m]
        new.image[~m] *= 1000.0
    assert Standardiser.fit(changed, sp.windows["train"], W) == std


def test_augmentation_is_the_same_transform_for_every_frame():
    # frames c_t * base: every operation is linear, so the same transform gives c_t * T(base)
    base = ps.patterns(16, 16)[0].astype(np.float32) + 0.1
    c = np.linspace(0.5, 2.0, W).astype(np.float32)
    win = c[:, None, None] * base[None]
    for seed in range(20):
        out = augment_window(win, np.random.default_rng(seed))
        assert out.shape == win.shape and out.dtype == np.float32
        np.testing.assert_allclose(out, c[:, None, None] * (out[0] / c[0])[None], rtol=1e-5, atol=1e-6)


def test_augmentation_changes_the_window_and_not_the_recording(recs):
    rec = ps.recording("P03", 1, 120, 16, 16, seed=4)
    before = rec.image.copy()
    w = all_windows([rec], W)
    ds = WindowDataset([rec], w, W, Standardiser(0.0, 1.0), augment=True, seed=0)
    changed = sum(not np.allclose(ds[i][0].numpy().reshape(W, 16, 16), rec.image[i:i + W]) for i in range(10))
    np.testing.assert_array_equal(rec.image, before)
    assert changed >= 5  # each of 5 operations at probability 1/2: all skipped 1 time in 32
    again = WindowDataset([rec], w, W, Standardiser(0.0, 1.0), augment=True, seed=0)
    np.testing.assert_array_equal(ds[3][0].numpy(), again[3][0].numpy())  # seeded per item

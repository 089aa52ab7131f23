"""``heldout_study``: held-out subjects beyond the thesis (its §4.4 future work), all on the same windows.

On the LSO split (:func:`~psmat.posture.data.lso_split`, Table 4.3's subjects by default) every
model is scored on the same windows: those of the validation and test subjects that start after
their session's first ``calibration_s`` seconds (:func:`psmat.posture.evaluate.heldout_windows`), so
the calibration of (b) never scores.

=====================================  ====================================================================
model                                  what
=====================================  ====================================================================
``CNN``                                the thesis' CNN trained on LSO (:func:`~psmat.posture.learn.train_posture`;
                                       its checkpoint in ``out_dir`` is reused when data and settings match)
``CNN invariant``                      (a) the same CNN on :func:`~psmat.posture.data.invariant_images`
                                       (per session: ÷ the straight-back phase's mean Σg, its CoP moved to
                                       the mat's centre), trained in ``out_dir/invariant``
``CNN fine-tuned 30 s``                (b) ``CNN`` fine-tuned per test subject on the windows of their first
                                       30 s of each session (:func:`~psmat.posture.learn.finetune`)
``CNN invariant fine-tuned 30 s``      (a) and (b) together
``CNN (invariant) calibrated 30 s``    (b) as for the ridge models: the CNN unchanged, each test subject's mean
                                       residual over their calibration windows added to their predictions
``ridge-PCA``                          (c) ridge on a PCA of the window-mean image
                                       (:func:`~psmat.posture.evaluate.fit_ridge_pca`)
``ridge-PCA invariant``                (a)+(c) the same on the window-mean invariant image
``ridge-PCA invariant features``       (a)+(c) on the window means of
                                       :func:`~psmat.posture.data.invariant_features` (CoP relative to the
                                       straight-back CoP, second moments, load ratio, row and column shares)
``... calibrated 30 s``                (b) for the ridge models: each test subject's mean residual over their
                                       calibration windows added to their predictions (an offset)
=====================================  ====================================================================

Writes ``out_dir/heldout.csv`` (Table 4.4's columns, ``model`` naming the variant, ``split`` "lso";
``validation`` rows for the models that do not calibrate, ``test`` rows for all) and
``out_dir/figures/heldout_r2.png`` (R² per output and model on the test windows), and through
:func:`~psmat.posture.learn.train_posture` its LSO outputs in ``out_dir`` and ``out_dir/invariant``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

import numpy as np
from numpy.typing import NDArray

from ..._checks import positive, positive_int
from ..._cpus import usable_cpus
from ..._progress import tqdm
from ..data import WINDOW, Recording, Split, WindowTargets, invariant_recording, lso_split
from ..evaluate import (HeldoutWindows, apply_offsets, heldout_windows, offsets_from_calibration, plot_r2_bars,
                        ridge_variants, table44_row, write_table44)
from ._finetune import FinetuneConfig, finetune
from ._fit import predict
from ._torch import torch
from ._torchdata import WindowDataset
from ._train import PostureResult, train_posture

__all__ = ["HeldoutResult", "heldout_study", "model_names"]

TABLE = "heldout.csv"
FIGURE = "heldout_r2.png"


def model_names(calibration_s: float) -> list[str]:
    """The variants' names in the table's order (see the module note)."""
    cal = f"{calibration_s:g} s"
    return ["CNN", "CNN invariant", f"CNN fine-tuned {cal}", f"CNN invariant fine-tuned {cal}",
            f"CNN calibrated {cal}", f"CNN invariant calibrated {cal}", "ridge-PCA", f"ridge-PCA calibrated {cal}", "ridge-PCA invariant", f"ridge-PCA invariant calibrated {cal}",
            "ridge-PCA invariant features", f"ridge-PCA invariant features calibrated {cal}"]


@dataclass
class HeldoutResult:
    """What :func:`heldout_study` produced.

    Attributes
    ----------
    rows : list of dict
        Table 4.4 rows (:func:`~psmat.posture.evaluate.table44_row`), ``model`` naming the variant.
    split : Split
        The LSO split the models were trained on.
    windows : HeldoutWindows
        Scored and calibration windows of the validation and test subjects.
    targets : dict of str to ndarray
        Measured window means ``(N, 6)`` (rad) of ``windows.scored[subset]``.
    predictions : dict of str to dict of str to ndarray
        Per model name and subset, ``(N, 6)`` rad on ``windows.scored[subset]``.
    drawn : dict of str to dict of str to ndarray
        Per fine-tuned CNN and test subject, the window rows its fine-tuning trained on.
    cnn, cnn_invariant : PostureResult
        The LSO trainings (:func:`~psmat.posture.learn.train_posture`).
    table_path, figure_path : Path
    """

    rows: list[dict[str, Any]]
    split: Split
    windows: HeldoutWindows
    targets: dict[str, NDArray[np.float64]]
    predictions: dict[str, dict[str, NDArray[np.float64]]]
    drawn: dict[str, dict[str, NDArray[np.int64]]]
    cnn: PostureResult
    cnn_invariant: PostureResult
    table_path: Path
    figure_path: Path


def _finetuned(res: PostureResult, recordings: Sequence[Recording], held: HeldoutWindows, window: int,
               config: FinetuneConfig, seed: int, bar: Any) -> tuple[NDArray[np.float64], dict[str, NDArray[np.int64]]]:
    """Test predictions of ``res.model`` fine-tuned on each test subject's calibration windows alone."""
    test, cal = held.scored["test"], held.calibration["test"]
    subj_test = np.array([recordings[r].subject for r in test[:, 0]])
    subj_cal = np.array([recordings[r].subject for r in cal[:, 0]])
    pred = np.empty((len(test), 6))
    drawn = {}
    for i, s in enumerate(sorted(set(subj_test))):
        net, drawn[s] = finetune(res.model, recordings, cal[subj_cal == s], window, res.standardiser, config,
                                 seed=seed * 1000 + i)
        sel = subj_test == s
        pred[sel] = predict(net, WindowDataset(recordings, test[sel], window, res.standardiser))
        bar.update()
    return pred, drawn


def heldout_study(recordings: Sequence[Recording], out_dir: str | Path, *, seed: int = 0, epochs: int = 30,
                  patience: int = 5, windows_per_epoch: int | None = 8192, calibration_s: float = 30.0,
                  window: int = WINDOW, lso_seed: int | None = None,
                  centre: Literal["session", "frame"] = "session", augment: bool = True,
                  augment_invariant: bool = False, finetune_config: FinetuneConfig = FinetuneConfig(),
                  threads: int | None = None, resume: bool = True, progress: bool = True,
                  label: str | None = None) -> HeldoutResult:
    """Every held-out-subject model (beyond the thesis) on the LSO test subjects (see the module note).

    Parameters
    ----------
    recordings : sequence of Recording
        The study (at least 3 subjects; same image shape in all).
    out_dir : str or Path
        Where ``heldout.csv``, the figure and the LSO trainings go.
    seed : int
        Seeds the trainings (initial weights, windows drawn, augmentation) and the fine-tunings.
    epochs, patience, windows_per_epoch : int, int, int or None
        Training of both CNNs (:func:`~psmat.posture.learn.train_posture`).
    calibration_s : float
        A session's calibration phase (s): the protocol's straight-back 30 s.
    window : int
        Frames per window.
    lso_seed : int or None
        LSO subjects (None: Table 4.3's order, as ``train_posture``).
    centre : {"session", "frame"}
        Re-centring of the invariant images (:func:`~psmat.posture.data.invariant_images`).
    augment, augment_invariant : bool
        Augment the training windows of the thesis CNN (as the thesis) and of the invariant CNN
        (off by default: its shift and scale augmentations would undo what the inputs fix — the
        position of the print relative to the straight-back seat).
    finetune_config : FinetuneConfig
        The fine-tuning of (b).
    threads : int, optional
        torch threads (default: one fewer than the usable CPUs, at least 1).
    resume : bool
        Reuse or resume the LSO trainings' checkpoints.
    progress : bool
        Progress bars (stderr).
    label : str, optional
        Figure label; ``"simulation"`` when every recording's ``meta["simulated"]`` is true.

    Returns
    -------
    HeldoutResult

    Raises
    ------
    ValueError
        Fewer than 3 subjects, a held-out session too short for its calibration phase and a
        window after it, or an invalid setting.
    """
    recs = list(recordings)
    if not recs or not all(isinstance(r, Recording) for r in recs):
        raise TypeError("recordings must be a non-empty sequence of psmat.posture.data.Recording")
    calibration_s = positive("calibration_s", calibration_s)
    window = positive_int("window", window)
    split = lso_split(recs, window=window, seed=lso_seed)
    held = heldout_windows(recs, split, calibration_s)
    out = Path(out_dir)
    if label is None and all(bool(r.meta.get("simulated")) for r in recs):
        label = "simulation"
    names = model_names(calibration_s)
    cal = f" calibrated {calibration_s:g} s"

    invariant = [invariant_recording(r, calibration_s, centre=centre) for r in recs]
    _, preds = ridge_variants(recs, invariant, split, held, calibration_s, calibrated_suffix=cal)

    common = dict(split="lso", seed=seed, epochs=epochs, patience=patience, windows_per_epoch=windows_per_epoch,
                  window=window, lso_seed=lso_seed, resume=resume, progress=progress, threads=threads, label=label)
    cnn = train_posture(recs, out, augment=augment, baseline=True, **common)
    cnn_inv = train_posture(invariant, out / "invariant", augment=augment_invariant, baseline=False, **common)

    prev = torch.get_num_threads()
    torch.set_num_threads(positive_int("threads", threads) if threads is not None
                          else max(1, usable_cpus() - 1))
    drawn: dict[str, dict[str, NDArray[np.int64]]] = {}
    n_test_subjects = len(split.subjects["test"])
    try:
        with tqdm(total=2 * n_test_subjects, desc="fine-tuning", unit="subject", disable=not progress) as bar:
            for name, res, data in ((names[0], cnn, recs), (names[1], cnn_inv, invariant)):
                preds[name] = {k: predict(res.model, WindowDataset(data, held.scored[k], window, res.standardiser))
                               for k in ("validation", "test")}
                cal_w = held.calibration["test"]
                cal_pred = predict(res.model, WindowDataset(data, cal_w, window, res.standardiser))
                offsets = offsets_from_calibration(recs, cal_w, WindowTargets(recs, window)(cal_w) - cal_pred)
                preds[f"{name} calibrated {calibration_s:g} s"] = {
                    "test": apply_offsets(recs, held.scored["test"], preds[name]["test"], offsets)}
                ft = f"{name} fine-tuned {calibration_s:g} s"
                ft_pred, drawn[ft] = _finetuned(res, data, held, window, finetune_config, seed, bar)
                preds[ft] = {"test": ft_pred}
    finally:
        torch.set_num_threads(prev)

    targets = {k: WindowTargets(recs, window)(held.scored[k]) for k in ("validation", "test")}
    rows = [table44_row(n, "lso", k, targets[k], preds[n][k]) for n in names for k in ("validation", "test")
            if k in preds[n]]
    table = write_table44(rows, out / TABLE)
    suffix = f" ({label})" if label else ""
    fig = plot_r2_bars([r for r in rows if r["subset"] == "test"], out / "figures" / FIGURE,
                       title=f"Held-out subjects: the test subjects of LSO (Leave Subjects Out), "
                             f"{', '.join(split.subjects['test'])}, windows after the first {calibration_s:g} s{suffix}")
    return HeldoutResult(rows, split, held, targets, preds, drawn, cnn, cnn_inv, table, fig)

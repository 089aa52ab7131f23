"""``train_posture``: the thesis' posture CNN (§4.3) trained and evaluated on one split (Table 4.4).

Writes into ``out_dir``:

* ``table44_<split>.csv``: Table 4.4's rows (validation, test) for the CNN and, beside them,
  the ridge-on-PCA baseline (:func:`psmat.posture.evaluate.ridge_pca_rows`; column ``model``);
* ``figures/<split>_validation.png``, ``figures/<split>_test.png``: Figs. 4.13-4.16;
* ``history_<split>.csv``: losses and seconds per epoch;
* ``model_<split>.pt``: the best weights, the settings and the standardisation;
* ``checkpoints/<split>/last.pt``: rewritten every epoch; a killed training called again with
  the same data and settings resumes from it.
"""

from __future__ import annotations

import csv
import hashlib
import json
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..._checks import positive_int
from ..._cpus import usable_cpus
from ..data import SPLITS, SPLIT_NAMES, WINDOW, Recording, Split, Standardiser, make_split
from ..evaluate import plot_predictions, ridge_pca_rows, table44_row, write_table44
from ._fit import FitConfig, fit, predict
from ._model import POOLS, PostureCNN, n_parameters
from ._torch import torch
from ._torchdata import WindowDataset

__all__ = ["PostureResult", "train_posture"]

#: Figure titles: each split spelled out.
TITLES = SPLIT_NAMES


@dataclass
class PostureResult:
    """What :func:`train_posture` produced.

    Attributes
    ----------
    rows : list of dict
        Table 4.4 rows of the CNN: ``validation`` and ``test`` (see :func:`~psmat.posture.evaluate.table44_row`).
    baseline_rows : list of dict
        The same rows for the ridge-PCA baseline (empty when not asked for).
    split : Split
    history : list of dict
        Per epoch: train and validation MSE (rad²), seconds, windows drawn; epoch 0 is the untrained model.
    best_epoch : int
    resumed_from : int
        Epochs read from a checkpoint (0: trained from the start).
    n_parameters : int
    standardiser : Standardiser
    model : PostureCNN
        With the best weights, in eval mode.
    predictions : dict of str to ndarray
        CNN outputs ``(N, 6)`` on ``validation`` and ``test`` (rad), in the split's window order.
    table_path : Path
    figure_paths : list of Path
    """

    rows: list[dict[str, Any]]
    baseline_rows: list[dict[str, Any]]
    split: Split
    history: list[dict[str, float]]
    best_epoch: int
    resumed_from: int
    n_parameters: int
    standardiser: Standardiser
    model: PostureCNN
    predictions: dict[str, np.ndarray]
    table_path: Path
    figure_paths: list[Path]


def _check_recordings(recordings: Sequence[Recording]) -> tuple[int, int]:
    recs = list(recordings)
    if not recs or not all(isinstance(r, Recording) for r in recs):
        raise TypeError("recordings must be a non-empty sequence of psmat.posture.data.Recording")
    shapes = {r.image.shape[1:] for r in recs}
    if len(shapes) != 1:
        raise ValueError(f"all recordings must have the same image shape (R, C), got {sorted(shapes)}")
    (shape,) = shapes
    return int(shape[0]), int(shape[1])


def _digest(recordings: Sequence[Recording], split: Split, settings: dict[str, Any]) -> str:
    h = hashlib.blake2b(json.dumps(settings, sort_keys=True).encode(), digest_size=16)
    for rec in recordings:
        h.update(f"{rec.subject}|{rec.day}|{rec.image.shape}".encode())
        h.update(np.ascontiguousarray(rec.image).data)
        h.update(np.ascontiguousarray(rec.angles_rad).data)
    for k in sorted(split.windows):
        h.update(k.encode())
        h.update(np.ascontiguousarray(split.windows[k]).data)
    return h.hexdigest()


def train_posture(recordings: Sequence[Recording], out_dir: str | Path, *, split: str = "ksi", seed: int = 0,
                  epochs: int = 30, patience: int = 5, batch_size: int = 64, lr: float = 1e-3,
                  weight_decay: float = 1e-2, windows_per_epoch: int | None = 8192, window: int = WINDOW,
                  augment: bool = True, lso_seed: int | None = None, baseline: bool = True, resume: bool = True,
                  progress: bool = True, threads: int | None = None, channels: Sequence[int] = (32, 64, 64),
                  hidden: Sequence[int] = (512, 256), pools: Sequence[tuple[int, int]] = POOLS,
                  label: str | None = None, on_epoch: Callable[[int, dict[str, float]], None] | None = None
                  ) -> PostureResult:
    """Train the §4.3 CNN on one split and write Table 4.4, Figs. 4.13-4.16 and checkpoints.

    Parameters
    ----------
    recordings : sequence of Recording
        The study (same image shape ``R×C`` in all).
    out_dir : str or Path
        Where the outputs go (see the module note).
    split : {"ksi", "ksi-leaky", "lso"}
        See :func:`psmat.posture.data.make_split`.
    seed : int
        Seeds the split, the initial weights and everything random in training.
    epochs, patience : int
        Most epochs; early stopping after ``patience`` epochs without a lower validation MSE.
    batch_size, lr, weight_decay : int, float, float
        AdamW settings.
    windows_per_epoch : int or None
        Training windows drawn each epoch (None: all).
    window : int
        Frames per window (50 in the thesis).
    augment : bool
        Augment training windows (:func:`psmat.posture.data.augment_window`).
    lso_seed : int or None
        LSO subjects: None takes the sorted ids in order (Table 4.3), an int a seeded choice.
    baseline : bool
        Also fit and report the ridge-PCA baseline on the same split.
    resume : bool
        Resume from ``checkpoints/<split>/last.pt`` when it exists.
    progress : bool
        Progress bars and one line per epoch (stderr).
    threads : int, optional
        torch intra-op threads during training; default one fewer than the CPUs this process may
        use (at least 1), leaving one to the in-process window loading and augmentation: on this
        project's shared 2-core machine one thread trained at 10.5 ms per window against 18 ms
        for two.
    channels, hidden, pools
        Network shape (:class:`~psmat.posture.learn.PostureCNN`).
    label : str, optional
        Shown in the figure titles; ``"simulation"`` by default when every recording's
        ``meta["simulated"]`` is true.
    on_epoch : callable, optional
        ``on_epoch(epoch, record)`` after each epoch's checkpoint.

    Returns
    -------
    PostureResult
    """
    R, C = _check_recordings(recordings)
    window = positive_int("window", window)
    cfg = FitConfig(epochs=positive_int("epochs", epochs), patience=positive_int("patience", patience),
                    batch_size=positive_int("batch_size", batch_size), lr=float(lr), weight_decay=float(weight_decay),
                    windows_per_epoch=None if windows_per_epoch is None else positive_int("windows_per_epoch",
                                                                                          windows_per_epoch),
                    seed=int(seed))
    if split not in SPLITS:
        raise ValueError(f"split must be one of {', '.join(SPLITS)}, got {split!r}")
    sp = make_split(split, recordings, window=window, seed=seed, lso_seed=lso_seed)
    for k, w in sp.windows.items():
        if len(w) == 0:
            raise ValueError(f"the {k} set of the {split} split has no window of {window} frames")
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    if label is None and all(bool(r.meta.get("simulated")) for r in recordings):
        label = "simulation"
    std = Standardiser.fit(recordings, sp.windows["train"], window)
    net = dict(channels=[int(c) for c in channels], hidden=[int(h) for h in hidden],
               pools=[[int(a), int(b)] for a, b in pools])
    settings = {"split": split, "window": window, "augment": bool(augment), "lso_seed": lso_seed, **net,
                **{k: v for k, v in asdict(cfg).items() if k not in ("epochs", "patience")}}

    prev_threads = torch.get_num_threads()
    torch.set_num_threads(positive_int("threads", threads) if threads is not None
                          else max(1, usable_cpus() - 1))
    try:
        torch.manual_seed(seed)  # Kaiming initial weights
        model = PostureCNN(window, R * C, channels=channels, hidden=hidden, pools=pools)
        data = {k: WindowDataset(recordings, w, window, std, augment=augment and k == "train", seed=seed)
                for k, w in sp.windows.items()}
        res = fit(model, data["train"], data["validation"], cfg, out / "checkpoints" / split,
                  fingerprint=_digest(recordings, sp, settings), resume=resume, progress=progress, on_epoch=on_epoch)
        pred = {k: predict(model, data[k]) for k in ("validation", "test")}
    finally:
        torch.set_num_threads(prev_threads)

    rows = [table44_row("cnn", split, k, data[k].targets, pred[k]) for k in ("validation", "test")]
    baseline_rows = ridge_pca_rows(recordings, sp, std)[1] if baseline else []
    table = write_table44(rows + baseline_rows, out / f"table44_{split}.csv")
    from ..._atomic import open_atomic, replacing

    with replacing(out / f"model_{split}.pt") as tmp:  # each output whole or not at all
        torch.save({"state_dict": model.state_dict(), "settings": settings, "R": R, "C": C,
                    "standardiser": {"mean": std.mean, "sd": std.sd}, "best_epoch": res.best_epoch}, tmp)
    with open_atomic(out / f"history_{split}.csv", "w") as f:
        wr = csv.DictWriter(f, fieldnames=["epoch", "train_loss", "val_loss", "train_s", "n_train"])
        wr.writeheader()
        wr.writerows(res.history)
    suffix = f" ({label})" if label else ""
    figs = [plot_predictions(data[k].targets.astype(np.float64), pred[k], out / "figures" / f"{split}_{k}.png",
                             title=f"{TITLES[split]}, {k} set{suffix}") for k in ("validation", "test")]
    return PostureResult(rows, baseline_rows, sp, res.history, res.best_epoch, res.resumed_from, n_parameters(model),
                         std, model, pred,
                         table, figs)

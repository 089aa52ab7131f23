"""Training loop of the posture CNN: AdamW on the MSE, a checkpoint every epoch, early stopping.

Everything random in epoch ``e`` (the random subset of training windows, their order, the
augmentation, dropout) is drawn from seeds made of ``(seed, e)``, so a training killed after
epoch ``e`` and resumed from its checkpoint ends with the same weights as one never stopped.
"""

from __future__ import annotations

import copy
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..._atomic import replacing
from ..._progress import tqdm
from ._torch import nn, torch
from ._torchdata import WindowDataset

__all__ = ["FitConfig", "FitResult", "fit", "predict"]

CHECKPOINT = "last.pt"


@dataclass(frozen=True)
class FitConfig:
    """Optimisation settings (thesis §4.3 where it says; the rest our choice).

    Attributes
    ----------
    epochs : int
        Most epochs.
    patience : int
        Stop after this many epochs without a lower validation loss; the best model is restored.
    batch_size : int
    lr : float
        AdamW learning rate.
    weight_decay : float
        AdamW decoupled weight decay.
    windows_per_epoch : int or None
        Training windows drawn (without replacement) each epoch; None: all. Stride-1 windows
        overlap in 49 of 50 frames, so a random part of them per epoch loses little.
    seed : int
    """

    epochs: int = 30
    patience: int = 5
    batch_size: int = 64
    lr: float = 1e-3
    weight_decay: float = 1e-2
    windows_per_epoch: int | None = 8192
    seed: int = 0


@dataclass
class FitResult:
    """Outcome of :func:`fit`: the history (one dict per epoch; epoch 0 is the untrained model)."""

    history: list[dict[str, float]] = field(default_factory=list)
    best_epoch: int = 0
    best_val_loss: float = float("inf")
    stopped_early: bool = False
    resumed_from: int = 0


def _seed(seed: int, epoch: int) -> int:
    return int(np.random.SeedSequence([seed, epoch]).generate_state(1)[0])


@torch.no_grad()
def predict(model: nn.Module, data: WindowDataset, batch_size: int = 256) -> NDArray[np.float64]:
    """Outputs ``(N, 6)`` (rad) of the model on a dataset, in its order, in eval mode."""
    model.eval()
    loader = torch.utils.data.DataLoader(data, batch_size=batch_size, shuffle=False)
    out = [model(x).numpy() for x, _ in loader]
    return np.concatenate(out).astype(np.float64) if out else np.empty((0, 6))


def _val_loss(model: nn.Module, data: WindowDataset) -> float:
    return float(np.mean(np.square(predict(model, data) - data.targets)))


def _save(path: Path, state: dict[str, Any]) -> None:
    with replacing(path) as tmp:  # whole or not at all: a kill mid-write leaves the previous checkpoint
        torch.save(state, tmp)


def _one_line(exc: BaseException) -> str:
    return " ".join(str(exc).split()) or type(exc).__name__


def _load_checkpoint(path: Path) -> dict[str, Any]:
    """The checkpoint at ``path``; one that cannot be read (truncated, damaged, not a checkpoint) is
    a ValueError naming the file (torch says "[Errno 22] Invalid argument" or "failed finding
    central directory" without it)."""
    try:
        ck = torch.load(path, weights_only=True)
    except Exception as exc:  # noqa: BLE001 - torch raises RuntimeError, OSError, EOFError, UnpicklingError...
        raise ValueError(f"{path}: not a readable checkpoint, truncated or damaged ({type(exc).__name__}: "
                         f"{_one_line(exc)[:200]}); remove it to train from the start") from None
    if not isinstance(ck, dict):
        raise ValueError(f"{path}: not a checkpoint of a posture training (a {type(ck).__name__}); remove it to "
                         "train from the start")
    return ck


def fit(model: nn.Module, train: WindowDataset, validation: WindowDataset, config: FitConfig, checkpoint_dir: Path, *,
        fingerprint: str, resume: bool = True, progress: bool = True,
        on_epoch: Callable[[int, dict[str, float]], None] | None = None) -> FitResult:
    """Train ``model`` in place and restore its best weights (lowest validation MSE).

    Parameters
    ----------
    model : nn.Module
    train, validation : WindowDataset
        Training windows (augmenting or not) and validation windows.
    config : FitConfig
    checkpoint_dir : Path
        ``last.pt`` is written there after every epoch (model, optimiser, best weights, history).
    fingerprint : str
        What the run depends on (a digest of data, split and settings); a checkpoint with another
        one is refused.
    resume : bool
        Continue from ``last.pt`` when present.
    progress : bool
        tqdm bars per epoch.
    on_epoch : callable, optional
        Called as ``on_epoch(epoch, record)`` after each epoch's checkpoint is written.
    """
    checkpoint_dir.mkdir(parents=True, exist_ok=True)
    ckpt_path = checkpoint_dir / CHECKPOINT
    opt = torch.optim.AdamW(model.parameters(), lr=config.lr, weight_decay=config.weight_decay)
    res = FitResult()
    best_state = copy.deepcopy(model.state_dict())
    bad, epoch = 0, 0
    if resume and ckpt_path.exists():
        ck = _load_checkpoint(ckpt_path)
        if ck.get("fingerprint") != fingerprint:
            raise ValueError(f"{ckpt_path} was written by another training (data, split or settings); "
                             "remove it or pass resume=False")
        try:
            model.load_state_dict(ck["model"])
            opt.load_state_dict(ck["optimizer"])
            best_state, bad, epoch = ck["best_state"], int(ck["bad_epochs"]), int(ck["epoch"])
            res.history, res.best_epoch = list(ck["history"]), int(ck["best_epoch"])
            res.best_val_loss = float(ck["best_val"])
            res.stopped_early, res.resumed_from = bool(ck["stopped"]), epoch
        except (KeyError, TypeError, ValueError, RuntimeError) as exc:
            raise ValueError(f"{ckpt_path}: not a checkpoint of this training ({_one_line(exc)}); remove it to train "
                             "from the start, or pass resume=False") from None
    else:
        res.history = [{"epoch": 0, "train_loss": float("nan"), "val_loss": _val_loss(model, validation),
                        "train_s": 0.0, "n_train": 0}]
        res.best_val_loss = res.history[0]["val_loss"]
    loss_fn = nn.MSELoss()
    n_all = len(train)
    while epoch < config.epochs and not res.stopped_early:
        epoch += 1
        rng = np.random.default_rng(_seed(config.seed, epoch))
        n = n_all if config.windows_per_epoch is None else min(n_all, config.windows_per_epoch)
        order = rng.choice(n_all, size=n, replace=False)
        train.epoch = epoch
        torch.manual_seed(_seed(config.seed + 1, epoch))  # dropout
        loader = torch.utils.data.DataLoader(train, batch_size=config.batch_size, sampler=order.tolist())
        model.train()
        t0, total, count = time.perf_counter(), 0.0, 0
        bar = tqdm(loader, desc=f"epoch {epoch}/{config.epochs}", unit="batch", disable=not progress, leave=False)
        for x, y in bar:
            opt.zero_grad(set_to_none=True)
            loss = loss_fn(model(x), y)
            loss.backward()
            opt.step()
            total, count = total + loss.item() * len(y), count + len(y)
            bar.set_postfix(loss=f"{total / count:.4g}")
        train_s = time.perf_counter() - t0
        val = _val_loss(model, validation)
        rec = {"epoch": epoch, "train_loss": total / max(count, 1), "val_loss": val, "train_s": train_s, "n_train": n}
        res.history.append(rec)
        if val < res.best_val_loss:
            res.best_val_loss, res.best_epoch, bad = val, epoch, 0
            best_state = copy.deepcopy(model.state_dict())
        else:
            bad += 1
            res.stopped_early = bad >= config.patience
        if progress:
            tqdm.write(f"epoch {epoch}: train MSE {rec['train_loss']:.4g}, validation MSE {val:.4g} rad^2, "
                       f"{train_s:.1f} s for {n} windows")
        _save(ckpt_path, {"fingerprint": fingerprint, "epoch": epoch, "model": model.state_dict(),
                          "optimizer": opt.state_dict(), "best_state": best_state, "bad_epochs": bad,
                          "best_epoch": res.best_epoch, "best_val": res.best_val_loss, "history": res.history,
                          "stopped": res.stopped_early})
        if on_epoch is not None:
            on_epoch(epoch, rec)
    model.load_state_dict(best_state)
    return res

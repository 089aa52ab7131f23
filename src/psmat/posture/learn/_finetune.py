"""Fine-tuning the posture CNN on a new subject's calibration windows (beyond the thesis, after its §4.4).

The thesis: "if a new volunteer is going to use the system a kind of calibration stage would be
required ... The model should be trained again to adapt to possible variations in the pressure
maps of the new individual." Here a copy of the trained network takes a few epochs of AdamW on
the subject's calibration windows (their first 30 s of each session, sitting straight:
:func:`psmat.posture.evaluate.heldout_windows`), and nothing else.

Those windows all show one posture, so a network free in every layer learns to answer that one
posture everywhere. ``layers`` chooses what moves: ``"last"`` the output layer only (in effect a
learned offset and a small re-weighting of the last features), ``"head"`` the dense layers
(default), ``"all"`` every layer, the batch norms re-estimating their statistics on the new
subject. The frozen parts stay in eval mode (batch-norm statistics and dropout as trained).
No weight decay: it would pull the trained weights towards 0, not towards themselves.

The defaults (dense layers, 5 epochs, lr 1e-3) come from a quick measurement on the tests' tiny
synthetic study with a per-subject angle offset (4 subjects, 8×8, window 20, a 3-epoch LSO
CNN; test MSE after fine-tuning, rad²): last layer 0.062 / 0.046 (lr 1e-4 / 1e-3), dense layers
0.044 / 0.027, all layers 0.087 / 0.038, no fine-tuning 0.072; dense layers at lr 1e-3 for 2, 10,
20 epochs 0.028, 0.025, 0.0235. Not yet measured on a real-sized study: the settings are
arguments of :func:`psmat.posture.learn.heldout_study` and of ``psmat posture heldout``.
"""

from __future__ import annotations

import copy
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from ..._checks import positive, positive_int
from ..data import Recording, Standardiser
from ._model import PostureCNN
from ._torch import nn, torch
from ._torchdata import WindowDataset

__all__ = ["LAYERS", "FinetuneConfig", "finetune"]

LAYERS = ("last", "head", "all")


def _seed(seed: int, epoch: int) -> int:
    return int(np.random.SeedSequence([seed, epoch]).generate_state(1)[0])


@dataclass(frozen=True)
class FinetuneConfig:
    """Settings of :func:`finetune`.

    Attributes
    ----------
    epochs : int
        Passes over the calibration windows.
    lr : float
        AdamW learning rate (the training's).
    layers : {"last", "head", "all"}
        What is trained (see the module note).
    batch_size : int
    augment : bool
        Augment the calibration windows as in training.
    """

    epochs: int = 5
    lr: float = 1e-3
    layers: Literal["last", "head", "all"] = "head"
    batch_size: int = 32
    augment: bool = False


def _trainable(net: PostureCNN, layers: str) -> list[nn.Parameter]:
    if layers == "all":
        return list(net.parameters())
    if layers == "head":
        return list(net.head.parameters())
    return list(net.head[-1].parameters())


def finetune(model: PostureCNN, recordings: Sequence[Recording], windows: NDArray[np.int64], window: int,
             standardiser: Standardiser, config: FinetuneConfig = FinetuneConfig(), *, seed: int = 0
             ) -> tuple[PostureCNN, NDArray[np.int64]]:
    """A copy of ``model`` trained on ``windows`` (one subject's calibration windows).

    Parameters
    ----------
    model : PostureCNN
        Trained network; not modified.
    recordings : sequence of Recording
    windows : ndarray, (N, 2)
        (recording, first frame) rows to train on, and only these.
    window : int
        Frames per window.
    standardiser : Standardiser
        The training's statistics (the input scale the network knows).
    config : FinetuneConfig
    seed : int
        Seeds the order of the windows, the augmentation and dropout.

    Returns
    -------
    model : PostureCNN
        The fine-tuned copy, in eval mode.
    drawn : ndarray, (epochs · N, 2)
        The window rows it trained on, in the order drawn.
    """
    if config.layers not in LAYERS:
        raise ValueError(f"layers must be one of {', '.join(LAYERS)}, got {config.layers!r}")
    epochs, batch = positive_int("epochs", config.epochs), positive_int("batch_size", config.batch_size)
    windows = np.asarray(windows, dtype=np.int64).reshape(-1, 2)
    if len(windows) == 0:
        raise ValueError("no calibration window to fine-tune on")
    net = copy.deepcopy(model)
    params = _trainable(net, config.layers)
    for p in net.parameters():
        p.requires_grad_(False)
    for p in params:
        p.requires_grad_(True)
    opt = torch.optim.AdamW(params, lr=positive("lr", config.lr), weight_decay=0.0)
    data = WindowDataset(recordings, windows, window, standardiser, augment=config.augment, seed=seed)
    loss_fn = nn.MSELoss()
    drawn = []
    for epoch in range(1, epochs + 1):
        order = np.random.default_rng(_seed(seed, epoch)).permutation(len(data))
        drawn.append(data.windows[order])
        data.epoch = epoch
        torch.manual_seed(_seed(seed + 1, epoch))  # dropout
        net.eval()
        (net if config.layers == "all" else net.head).train()
        for x, y in torch.utils.data.DataLoader(data, batch_size=batch, sampler=order.tolist()):
            opt.zero_grad(set_to_none=True)
            loss_fn(net(x), y).backward()
            opt.step()
    net.eval()
    return net, np.concatenate(drawn)

"""The CNN of thesis §4.3 (Fig. 4.12, docs/spec.md §8), flatten size computed from the input.

A window of ``W`` frames of an ``R×C`` image enters as one ``W × (R·C)`` channel (the thesis'
"50x16x16 ... resized as a 50x256 image"). Three blocks conv 3×3 (32, 64, 64 filters,
padding 1) → max-pool → batch norm → ReLU, then dense 512 and 256 with LeakyReLU and dropout
0.2, and 6 linear outputs (5 angles and their sum, rad). Kaiming initialisation [93].

The thesis' pooling (2×2, stride 1, in the first two blocks) keeps the map at about 42×248
and its stated flatten size (7680) follows from no choice of its layers; here each block pools
with kernel = stride (:data:`POOLS`): the time axis (50 frames at 10 Hz) halves in every block,
the cell axis shrinks by 4, 4, 2, so a 50×256 input flattens to 64·6·8 = 3072 and the network
has 1.76 M parameters (16×16 mat). The pool comes straight after the convolution (max-pool
commutes with ReLU, and batch norm then runs on 4-8× fewer values): on 2 CPU cores this was
5-6× faster per window than conv → batch norm → ReLU → pool, whose full-size 32×50×256 maps
dominate the time.
"""

from __future__ import annotations

from collections.abc import Sequence

from ._torch import nn, torch

__all__ = ["POOLS", "PostureCNN", "n_parameters"]

#: Max-pool kernel (= stride) of each conv block, (time, cells): see the module note.
POOLS: tuple[tuple[int, int], ...] = ((2, 4), (2, 4), (2, 2))
N_OUTPUTS = 6


class PostureCNN(nn.Module):
    """Thesis §4.3 regression CNN.

    Parameters
    ----------
    window : int
        Frames per window W (50 in the thesis).
    n_cells : int
        Cells per image R·C (256 for 16×16).
    channels : sequence of 3 int
        Filters of the conv layers (thesis: 32, 64, 64).
    hidden : sequence of int
        Dense layer widths (thesis: 512, 256).
    pools : sequence of (int, int)
        Max-pool kernel = stride per conv block, (time, cells).
    dropout : float
        Dropout after each hidden dense layer (thesis: 0.2).

    Notes
    -----
    Input ``(N, 1, W, R·C)`` standardised; output ``(N, 6)`` rad.
    """

    def __init__(self, window: int, n_cells: int, *, channels: Sequence[int] = (32, 64, 64),
                 hidden: Sequence[int] = (512, 256), pools: Sequence[tuple[int, int]] = POOLS,
                 dropout: float = 0.2) -> None:
        super().__init__()
        if len(channels) != len(pools):
            raise ValueError(f"channels ({len(channels)}) and pools ({len(pools)}) must have one entry per conv block")
        layers: list[nn.Module] = []
        c_in, h, w = 1, int(window), int(n_cells)
        for c_out, (ph, pw) in zip(channels, pools):
            layers += [nn.Conv2d(c_in, int(c_out), 3, padding=1), nn.MaxPool2d((ph, pw), stride=(ph, pw)),
                       nn.BatchNorm2d(int(c_out)), nn.ReLU()]
            c_in, h, w = int(c_out), h // ph, w // pw
            if h < 1 or w < 1:
                raise ValueError(f"input {window}x{n_cells} is too small for pooling {tuple(pools)}")
        self.features = nn.Sequential(*layers)
        #: Flatten size from the input shape (the thesis' 7680 does not follow from its layers).
        self.n_flat = c_in * h * w
        dense: list[nn.Module] = [nn.Flatten()]
        n_in = self.n_flat
        for n_out in hidden:
            dense += [nn.Linear(n_in, int(n_out)), nn.LeakyReLU(), nn.Dropout(dropout)]
            n_in = int(n_out)
        dense.append(nn.Linear(n_in, N_OUTPUTS))
        self.head = nn.Sequential(*dense)
        self.reset_parameters()

    def reset_parameters(self) -> None:
        """Kaiming-normal weights (ReLU gain for conv, LeakyReLU for dense), zero biases."""
        for m in self.modules():
            if isinstance(m, nn.Conv2d):
                nn.init.kaiming_normal_(m.weight, nonlinearity="relu")
                nn.init.zeros_(m.bias)
            elif isinstance(m, nn.Linear):
                nn.init.kaiming_normal_(m.weight, a=0.01, nonlinearity="leaky_relu")
                nn.init.zeros_(m.bias)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.head(self.features(x))


def n_parameters(model: nn.Module) -> int:
    """Number of trainable parameters."""
    return int(sum(p.numel() for p in model.parameters() if p.requires_grad))

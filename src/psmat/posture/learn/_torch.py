"""PyTorch for the posture learning (the optional extra ``psmat[posture]``).

The learning modules import torch from here, so that a missing PyTorch raises one line
naming the extra; ``import psmat`` and ``import psmat.posture`` never import it.
"""

from __future__ import annotations

try:
    import torch
    from torch import nn
except ImportError:  # pragma: no cover - exercised by a subprocess test without torch
    raise ImportError("the posture learning needs PyTorch: pip install 'psmat[posture]'") from None

__all__ = ["torch", "nn"]

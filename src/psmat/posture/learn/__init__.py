"""Learning the spine's angles from the cushion (thesis §4.3): the CNN, its training, held-out subjects.

Needs PyTorch (the optional extra ``psmat[posture]``): importing this package without it raises one
line naming the extra (``_torch``). Private modules:

* ``_model`` — :class:`PostureCNN`, the network of Fig. 4.12;
* ``_torchdata`` — :class:`WindowDataset`, the windows built lazily;
* ``_fit`` — the training loop (AdamW, a checkpoint every epoch, early stopping, resumable);
* ``_train`` — :func:`train_posture`: the CNN trained and scored on one split (Table 4.4);
* ``_finetune`` — fine-tuning on a new subject's calibration windows (beyond the thesis);
* ``_heldout`` — :func:`heldout_study`: every held-out-subject model on the same windows.
"""

from ._finetune import LAYERS, FinetuneConfig, finetune
from ._fit import FitConfig, FitResult, fit, predict
from ._heldout import HeldoutResult, heldout_study, model_names
from ._model import POOLS, PostureCNN, n_parameters
from ._torchdata import WindowDataset
from ._train import PostureResult, train_posture

__all__ = [
    "PostureCNN", "POOLS", "n_parameters", "WindowDataset",
    "FitConfig", "FitResult", "fit", "predict",
    "PostureResult", "train_posture",
    "LAYERS", "FinetuneConfig", "finetune",
    "HeldoutResult", "heldout_study", "model_names",
]

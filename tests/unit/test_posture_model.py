"""The §4.3 CNN (output shape, flatten size from the input, Kaiming init), R² and MSE per
output against hand calculations, and PyTorch as an optional extra (docs/spec.md §8)."""

from __future__ import annotations

import math
import subprocess
import sys

import numpy as np
import pytest

from psmat.posture.evaluate import mse_per_output, r2_per_output, table44_row


def test_r2_and_mse_per_output_by_hand():
    t = np.array([[1.0, 1.0, 1.0, 5.0], [2.0, 2.0, 2.0, 5.0], [3.0, 3.0, 3.0, 5.0], [4.0, 4.0, 4.0, 5.0]])
    p = np.array([[1.0, 2.5, 1.0, 5.0], [2.0, 2.5, 2.0, 4.0], [4.0, 2.5, 3.0, 5.0], [3.0, 2.5, 4.0, 6.0]])
    # column 0: SS_res = 0+0+1+1 = 2, SS_tot about 2.5 = 2.25+0.25+0.25+2.25 = 5 -> 1 - 2/5
    # column 1: the mean predicted -> 0; column 2: exact -> 1; column 3: measured constant -> undefined
    r2 = r2_per_output(t, p)
    np.testing.assert_allclose(r2[:3], [0.6, 0.0, 1.0], atol=1e-15)
    assert math.isnan(r2[3])
    np.testing.assert_allclose(mse_per_output(t, p), [0.5, 1.25, 0.0, 0.5], atol=1e-15)


def test_table44_row_names_and_values():
    rng = np.random.default_rng(0)
    t = rng.normal(size=(40, 6))
    p = t + 0.1 * rng.normal(size=(40, 6))
    row = table44_row("cnn", "ksi", "test", t, p)
    assert row["n_windows"] == 40 and row["subset"] == "test"
    ss_res, ss_tot = np.sum((t[:, 5] - p[:, 5]) ** 2), np.sum((t[:, 5] - t[:, 5].mean()) ** 2)
    assert row["R2_Sum"] == pytest.approx(1 - ss_res / ss_tot)
    assert row["MSE"] == pytest.approx(np.mean((t - p) ** 2))
    with pytest.raises(ValueError, match="same"):
        r2_per_output(t, p[:, :5])


@pytest.mark.parametrize(("R", "C", "flat"), [(16, 16, 64 * 6 * 8), (32, 32, 64 * 6 * 32)])
def test_output_shape_and_flatten_size(R, C, flat):
    torch = pytest.importorskip("torch")
    from psmat.posture.learn import PostureCNN

    # pools (2,4), (2,4), (2,2): time 50 -> 25 -> 12 -> 6, cells R*C -> /4 -> /4 -> /2, 64 channels
    net = PostureCNN(50, R * C)
    assert net.n_flat == flat
    x = torch.randn(3, 1, 50, R * C)
    assert net.features(x).shape[1:].numel() == flat
    net.eval()
    assert net(x).shape == (3, 6)


def test_kaiming_initialisation():
    pytest.importorskip("torch")
    from psmat.posture.learn import PostureCNN

    net = PostureCNN(50, 256)
    dense = net.head[1]
    # Kaiming normal, LeakyReLU slope 0.01: SD = sqrt(2 / (1 + 0.01^2) / fan_in)
    expected = math.sqrt(2.0 / (1 + 0.01**2) / dense.in_features)
    assert dense.weight.detach().std().item() == pytest.approx(expected, rel=0.01)
    assert dense.bias.detach().abs().max().item() == 0.0


def test_input_too_small_for_the_pooling():
    pytest.importorskip("torch")
    from psmat.posture.learn import PostureCNN

    with pytest.raises(ValueError, match="too small"):
        PostureCNN(5, 256)


def test_psmat_posture_does_not_import_torch_and_learning_names_the_extra():
    code = ("import sys; import psmat, psmat.posture, psmat.posture.data, psmat.posture.evaluate, psmat.synth; "
            "assert 'torch' not in sys.modules, 'torch imported'; "
            "sys.modules['torch'] = None\n"
            "try:\n    import psmat.posture.learn\nexcept ImportError as e:\n    print(e)\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.strip()
    assert out == "the posture learning needs PyTorch: pip install 'psmat[posture]'"

"""Forward model and Jacobian against the reference vectors and against circuit physics."""

from __future__ import annotations

import numpy as np
import pytest

import psmat


def test_forward_matches_reference(iecm_reference):
    for name, case in iecm_reference.items():
        g, G = np.array(case["g"]), np.array(case["G"])
        np.testing.assert_allclose(psmat.iecm.forward(g), G, rtol=1e-12, err_msg=name)


def test_forward_2x2_by_hand():
    # Between row 0 and column 0: the cell a in parallel with the path through the other three
    # cells in series (row 0 -> col 1 -> row 1 -> col 0).
    a, b, c, d = 1.0, 2.0, 3.0, 4.0
    g = np.array([[a, b], [c, d]])
    series = lambda *x: 1.0 / sum(1.0 / v for v in x)  # noqa: E731
    expected = np.array(
        [[a + series(b, d, c), b + series(a, c, d)], [c + series(a, b, d), d + series(b, a, c)]]
    )
    np.testing.assert_allclose(psmat.iecm.forward(g), expected, rtol=1e-14)


def test_forward_thesis_fig_2_14():
    # Fig. 2.14: 10 kOhm at (1, A), 100 Ohm elsewhere: R_1A = 10k || 300, others 100 || 10.2k.
    r = np.array([[10e3, 100.0], [100.0, 100.0]])
    R = 1.0 / psmat.iecm.forward(1.0 / r)
    par = lambda x, y: x * y / (x + y)  # noqa: E731
    assert R[0, 0] == pytest.approx(par(10e3, 300.0), rel=1e-12)
    for idx in [(0, 1), (1, 0), (1, 1)]:
        assert R[idx] == pytest.approx(par(100.0, 10.2e3), rel=1e-12)
    # the 10 kOhm cell hides behind 300 Ohm: the measurement barely sees it
    assert R[0, 0] < 300.0


def test_forward_physics(rng):
    g = rng.uniform(1e-4, 1e-2, (5, 7))
    G = psmat.iecm.forward(g)
    assert np.all(G >= g)  # parallel paths only add conductance
    np.testing.assert_allclose(psmat.iecm.forward(3.7 * g), 3.7 * G, rtol=1e-12)  # linear circuit
    np.testing.assert_allclose(psmat.iecm.forward(g.T), G.T, rtol=1e-12)  # rows <-> columns
    # permuting rows (or columns) permutes G the same way: no node is special, not even ground
    perm = rng.permutation(5)
    np.testing.assert_allclose(psmat.iecm.forward(g[perm]), G[perm], rtol=1e-11)


def test_forward_stack_matches_frames(rng):
    g = rng.uniform(1e-5, 1e-2, (4, 3, 6))
    G = psmat.iecm.forward(g)
    assert G.shape == g.shape
    for t in range(4):
        np.testing.assert_allclose(G[t], psmat.iecm.forward(g[t]), rtol=1e-15)


def test_jacobian_reference_rows(iecm_reference):
    for name, case in iecm_reference.items():
        J = psmat.iecm.jacobian(np.array(case["g"]))
        np.testing.assert_allclose(J[0], case["jacobian_row0"], rtol=1e-10, atol=1e-14, err_msg=name)
        np.testing.assert_allclose(J[:, -1], case["jacobian_col_last"], rtol=1e-10, atol=1e-14, err_msg=name)


def test_jacobian_diagonal_is_one_and_finite_differences(rng):
    for shape in [(4, 4), (3, 5), (2, 7)]:
        g = rng.uniform(1e-4, 1e-2, shape)
        J = psmat.iecm.jacobian(g)
        np.testing.assert_allclose(np.diag(J), 1.0, rtol=1e-12)  # dG_ip/dg_ip = 1
        n = g.size
        Jfd = np.empty((n, n))
        for b in range(n):
            h = 1e-4 * g.flat[b]  # central differences: O(h^2) truncation, small round-off
            gp, gm = g.copy(), g.copy()
            gp.flat[b] += h
            gm.flat[b] -= h
            Jfd[:, b] = (psmat.iecm.forward(gp) - psmat.iecm.forward(gm)).ravel() / (2 * h)
        np.testing.assert_allclose(J, Jfd, rtol=1e-5, atol=1e-8)


def test_matrix_free_product_matches_dense(rng):
    g = rng.uniform(1e-5, 1e-2, (6, 9))
    v = rng.standard_normal(g.shape)
    G = psmat.iecm.forward(g).ravel()
    J = psmat.iecm.jacobian(g)
    dense = (J / G[:, None] ** 2) @ v.ravel()  # (T∘T) v with J = diag(G)^2 (T∘T)
    np.testing.assert_allclose(psmat.iecm.hadamard_product(g, v).ravel(), dense, rtol=1e-9)


def test_hadamard_square_is_positive_definite(rng):
    g = rng.uniform(1e-5, 1e-2, (5, 5))
    G = psmat.iecm.forward(g).ravel()
    TT = psmat.iecm.jacobian(g) / G[:, None] ** 2
    np.testing.assert_allclose(TT, TT.T, rtol=1e-10, atol=0)
    assert np.linalg.eigvalsh(0.5 * (TT + TT.T)).min() > 0


def test_disconnected_network_is_an_error():
    g = np.full((3, 3), 1e-3)
    g[1] = 0.0  # row 1 touches nothing
    with pytest.raises(ValueError, match="disconnected"):
        psmat.iecm.forward(g)

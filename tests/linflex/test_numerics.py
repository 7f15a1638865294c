"""The shared numerical helpers of linflex.system._numerics against LAPACK directly."""

import numpy as np
import pytest
import scipy.linalg
from hypothesis import given, settings
from hypothesis import strategies as st

from linflex.system._numerics import complex_schur, diagonal_balance, schur_eigenvalues


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_schur_eigenvalues_are_the_eigenvalues(seed):
    # Reference: numpy's eigvals of the same matrix; a random real matrix has both 1x1 and 2x2 blocks
    A = np.random.default_rng(seed).standard_normal((40, 40))
    S = scipy.linalg.schur(A, output="real")[0]
    ev = schur_eigenvalues(S)
    assert np.any(ev.imag != 0) and np.any(ev.imag == 0)
    ref = np.linalg.eigvals(A)
    # every eigenvalue matched to 1e-10 of ||A|| (both backward stable), conjugate pairs adjacent
    assert np.max(np.min(np.abs(ev[:, None] - ref[None, :]), axis=1)) <= 1e-10 * np.linalg.norm(A, 2)
    pairs = np.flatnonzero(np.diag(S, -1) != 0)
    np.testing.assert_array_equal(ev[pairs], np.conj(ev[pairs + 1]))


def test_diagonal_balance_keeps_the_transfer_function():
    # states scaled 1e-4 .. 1e5: the balanced system has a far smaller norm and the same G(s)
    rng = np.random.default_rng(3)
    A0, B0, C0 = rng.standard_normal((12, 12)) - 5 * np.eye(12), rng.standard_normal((12, 2)), rng.standard_normal((3, 12))
    s = np.logspace(-4, 5, 12)
    A, B, C = A0 * (s[:, None] / s[None, :]), B0 * s[:, None], C0 / s[None, :]
    Ab, Bb, Cb, scale = diagonal_balance(A, B, C)
    assert np.linalg.norm(Ab, 1) < 1e-6 * np.linalg.norm(A, 1)
    for w in (0.1, 1.0, 10.0):
        G0 = C0 @ np.linalg.solve(1j * w * np.eye(12) - A0, B0)
        Gb = Cb @ np.linalg.solve(1j * w * np.eye(12) - Ab, Bb)
        assert np.linalg.norm(Gb - G0) <= 1e-12 * np.linalg.norm(G0)  # exact similarity by powers of 2
    assert np.all(np.log2(scale) == np.round(np.log2(scale)))


@settings(derandomize=True, max_examples=30, deadline=None)
@given(seed=st.integers(0, 10_000), n=st.integers(1, 40), pairs=st.integers(0, 10), ordered=st.booleans())
def test_complex_schur_is_a_unitary_triangularization(seed, n, pairs, ordered):
    # reference: the definition (A = Z T Z^H, Z unitary, T upper triangular) and numpy's
    # eigenvalues; with a selection, the selected eigenvalues first (a conjugate pair together)
    rng = np.random.default_rng(seed)
    blocks = [np.array([[a, w], [-w, a]]) for a, w in zip(-rng.uniform(0, 2, pairs), rng.uniform(0.1, 10, pairs))]
    D = scipy.linalg.block_diag(*blocks, np.diag(rng.standard_normal(n))) if pairs else np.diag(rng.standard_normal(n))
    Q = np.linalg.qr(rng.standard_normal(D.shape))[0]
    A = Q @ (D + np.triu(rng.standard_normal(D.shape), 2)) @ Q.T
    select = (lambda z: z.real < -0.5) if ordered else None
    T, Z, k = complex_schur(A, sort=select)
    scale = np.linalg.norm(A)
    assert np.abs(np.tril(T, -1)).max(initial=0.0) == 0.0
    assert np.abs(Z.conj().T @ Z - np.eye(len(A))).max() < 1e-13
    assert np.abs(Z @ T @ Z.conj().T - A).max() < 1e-13 * max(scale, 1.0)
    ev = np.sort_complex(np.linalg.eigvals(A))
    assert np.abs(np.sort_complex(np.diag(T)) - ev).max() < 1e-9 * max(scale, 1.0)
    if ordered:
        assert k == np.count_nonzero(ev.real < -0.5)
        assert np.all(np.diag(T)[:k].real < -0.5) and np.all(np.diag(T)[k:].real >= -0.5)

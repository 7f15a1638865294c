"""Reduction on structured models: the block-diagonal evaluator inside the error norms, the
Lyapunov solver chosen by order, and the split on the Schur blocks (issue 20, target 5).

References: the same quantities computed on the same system in dense coordinates (a random
orthogonal similarity removes every structure and leaves the transfer function unchanged), and
SLICOT's SB03OD against linflex's own Hammarling recursion.
"""

import numpy as np
import pytest
import scipy.linalg
from hypothesis import given, settings
from hypothesis import strategies as st

from linflex import LinearSystem
from linflex.frequency._evaluate import TransferEvaluator
from linflex.frequency._hinf import hinf_norm_stable
from linflex.frequency._modal_forms import _BlockModal
from linflex.linearize import balanced_truncation
from linflex.linearize._balanced import SB03OD_LARGEST
from linflex.linearize._reduction_split import split_stable


def modal_system(seed, n_modes, m, p, *, rigid=False, zeta=(1e-3, 0.2)):
    """Modal 2x2 blocks (frequencies 0.1..50 rad/s) under a random permutation of the states."""
    rng = np.random.default_rng(seed)
    w = np.exp(rng.uniform(np.log(0.1), np.log(50.0), n_modes))
    z = np.exp(rng.uniform(np.log(zeta[0]), np.log(zeta[1]), n_modes))
    blocks = [np.array([[0.0, 1.0], [-wi * wi, -2 * zi * wi]]) for wi, zi in zip(w, z)]
    if rigid:
        blocks.insert(0, np.array([[0.0, 1.0], [0.0, 0.0]]))
    A = scipy.linalg.block_diag(*blocks)
    n = A.shape[0]
    perm = rng.permutation(n)
    return LinearSystem(A[np.ix_(perm, perm)], rng.normal(size=(n, m)), rng.normal(size=(p, n)))


def dense_copy(sys, seed):
    """The same transfer function in random orthogonal coordinates (no structure left)."""
    Q, _ = np.linalg.qr(np.random.default_rng(seed).normal(size=(sys.n_states,) * 2))
    return LinearSystem(Q.T @ sys.A @ Q, Q.T @ sys.B, sys.C @ Q, sys.D)


@settings(derandomize=True, max_examples=10, deadline=None)
@given(seed=st.integers(0, 10_000), n_modes=st.integers(3, 25), m=st.integers(1, 2), p=st.integers(1, 2))
def test_hinf_norm_of_a_modal_system_matches_its_dense_copy(seed, n_modes, m, p):
    sys = modal_system(seed, n_modes, m, p)
    assert isinstance(TransferEvaluator(sys).modal, _BlockModal)
    dense = dense_copy(sys, seed + 1)
    assert not isinstance(TransferEvaluator(dense).modal, _BlockModal)
    a = hinf_norm_stable(sys.A, sys.B, sys.C, sys.D)
    b = hinf_norm_stable(dense.A, dense.B, dense.C, dense.D)
    # both are within their rtol (1e-6) of the true norm
    assert abs(a.value - b.value) <= 2.5e-6 * max(a.value, b.value)


@settings(derandomize=True, max_examples=8, deadline=None)
@given(seed=st.integers(0, 10_000), n_modes=st.integers(4, 30), rigid=st.booleans())
def test_split_on_the_schur_blocks_decouples_exactly(seed, n_modes, rigid):
    # trsyl on the already quasi-triangular blocks: T^-1 A T is block diagonal to round-off
    sys = modal_system(seed, n_modes, 1, 1, rigid=rigid)
    sp = split_stable(sys)
    assert sp.n_unstable == (2 if rigid else 0)
    M = sp.T_inv @ sys.A @ sp.T
    k = sp.n_unstable
    scale = np.linalg.norm(sys.A, 1) * np.linalg.norm(sp.T, 1) * np.linalg.norm(sp.T_inv, 1)
    assert np.max(np.abs(M[:k, k:]), initial=0.0) <= 1e-13 * scale
    assert np.max(np.abs(M[k:, :k]), initial=0.0) <= 1e-13 * scale


def test_auto_lyapunov_solver_follows_the_order_and_agrees_with_sb03od():
    pytest.importorskip("slycot")
    small = modal_system(3, 20, 2, 2)
    assert balanced_truncation(small, order=6).lyapunov_solver == "SB03OD"
    large = modal_system(4, SB03OD_LARGEST // 2 + 5, 2, 2)
    auto = balanced_truncation(large, order=10)
    assert auto.lyapunov_solver == "hammarling"
    slicot = balanced_truncation(large, order=10, lyapunov_solver="SB03OD")
    keep = auto.hsv > 1e-6 * auto.hsv[0]
    # two backward-stable implementations of Hammarling's method on one Schur form
    np.testing.assert_allclose(auto.hsv[keep], slicot.hsv[keep], rtol=1e-9)
    assert auto.error_bound == pytest.approx(slicot.error_bound, rel=1e-6)


@settings(derandomize=True, max_examples=12, deadline=None)
@given(seed=st.integers(0, 10_000), n_modes=st.integers(2, 40), n_real=st.integers(0, 3), m=st.integers(1, 3))
def test_paired_hammarling_recursion_matches_the_dense_one(seed, n_modes, n_real, m):
    # a modal model's Schur form is block diagonal: the recursion that solves the 2x2 pairs at
    # once gives the same gramian as the one with full triangular solves
    from linflex.linearize._balanced import (
        _lyapunov_factor,
        _lyapunov_factor_dense,
        _lyapunov_factor_paired,
    )
    from linflex.system._numerics import complex_schur_from_real

    rng = np.random.default_rng(seed)
    w = np.exp(rng.uniform(np.log(0.1), np.log(50.0), n_modes))
    blocks = [np.array([[0.0, 1.0], [-wi * wi, -2e-3 * wi]]) for wi in w]
    blocks += [np.array([[-np.exp(rng.uniform(-2, 2))]]) for _ in range(n_real)]
    S = scipy.linalg.schur(scipy.linalg.block_diag(*blocks), output="real")[0]
    T, _ = complex_schur_from_real(S)
    B = rng.normal(size=(T.shape[0], m)).astype(complex)
    R = _lyapunov_factor(T, B)
    np.testing.assert_array_equal(R, _lyapunov_factor_paired(T, B))  # the structure was recognized
    Rd = _lyapunov_factor_dense(T, B)
    P, Pd = R @ R.conj().T, Rd @ Rd.conj().T
    assert np.max(np.abs(P - Pd)) <= 1e-12 * np.max(np.abs(Pd))

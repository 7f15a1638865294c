"""Tests of minimal_realization."""


import numpy as np
import pytest
import scipy.io
import scipy.linalg
import scipy.sparse

from linflex import LinearSystem, ModelError
from linflex.linearize import minimal_realization


def response(sys, s):
    """Reference: direct complex solve C (sI - A)^-1 B + D."""
    return sys.C @ np.linalg.solve(s * np.eye(sys.A.shape[0]) - sys.A, sys.B) + sys.D


def hidden_modes_system(seed=0, n_co=5, n_c_only=3, n_o_only=2, n_none=2, rigid=True):
    """Kalman decomposition with known block sizes, hidden by a random similarity.

    Blocks: controllable+observable (with a rigid-body double integrator when rigid=True),
    controllable-only, observable-only, neither; the minimal order is n_co.
    """
    rng = np.random.default_rng(seed)
    sizes = [n_co, n_c_only, n_o_only, n_none]
    n = sum(sizes)
    A = np.zeros((n, n))
    e = np.cumsum([0] + sizes)
    for i in range(4):
        A[e[i]:e[i + 1], e[i]:e[i + 1]] = rng.normal(size=(sizes[i],) * 2) - 3 * np.eye(sizes[i])
    if rigid:
        A[:2, :2] = [[0.0, 1.0], [0.0, 0.0]]
        A[:2, 2:n_co] = 0.0
        A[2:n_co, :2] = rng.normal(size=(n_co - 2, 2))
    # Kalman structure: (co, c_only) controllable, (co, o_only) observable
    A[e[0]:e[1], e[2]:e[3]] = rng.normal(size=(n_co, n_o_only))
    A[e[1]:e[2], e[0]:e[1]] = rng.normal(size=(n_c_only, n_co))
    A[e[1]:e[2], e[2]:e[4]] = rng.normal(size=(n_c_only, n_o_only + n_none))
    A[e[3]:e[4], e[2]:e[3]] = rng.normal(size=(n_none, n_o_only))
    B = np.zeros((n, 2))
    B[: e[2]] = rng.normal(size=(e[2], 2))
    C = np.zeros((2, n))
    C[:, : e[1]] = rng.normal(size=(2, n_co))
    C[:, e[2]:e[3]] = rng.normal(size=(2, n_o_only))
    T = rng.normal(size=(n, n)) + 3 * np.eye(n)
    Ti = np.linalg.inv(T)
    return LinearSystem(Ti @ A @ T, Ti @ B, C @ T, [[0.1, 0.0], [0.0, 0.2]])


@pytest.mark.parametrize("rigid", [False, True])
def test_minimal_order_and_same_transfer_function(rigid):
    sys = hidden_modes_system(rigid=rigid)
    res = minimal_realization(sys)
    assert res.order == 5  # by construction (Kalman blocks)
    assert res.n_uncontrollable + res.n_unobservable == 7
    # every rank decision is clear: discarded values are round-off (cond(T) ~ 1e2 times eps ||A||),
    # kept ones are O(0.01) or more, and the default tolerance sits in between
    assert res.largest_discarded < res.tol < 1e-6 * res.smallest_kept
    # same transfer function: direct complex solves, 1e-9 relative (the similarity T has
    # condition ~1e2, the hidden blocks couple)
    for s in (0.7j, 1.0 + 3.0j, 10.0j):
        np.testing.assert_allclose(response(res.sys, s), response(sys, s), rtol=1e-9)
    # V is orthonormal and the reduced matrices are its projections
    np.testing.assert_allclose(res.V.T @ res.V, np.eye(5), atol=1e-13)


def test_agrees_with_python_control_minreal():
    control = pytest.importorskip("control")
    pytest.importorskip("slycot")
    sys = hidden_modes_system(seed=4, rigid=False)
    ref = control.minreal(sys.to_control(), verbose=False)  # SLICOT TB01PD
    assert minimal_realization(sys).order == ref.nstates == 5


def test_minimal_system_is_unchanged():
    # two-mass oscillator with force input and position output is minimal: nothing removed
    A = [[0, 0, 1, 0], [0, 0, 0, 1], [-2.5, 2.5, -0.2, 0.2], [5 / 3, -5 / 3, 2 / 15, -2 / 15]]
    sys = LinearSystem(A, [[0], [0], [0.5], [0]], [[0, 1, 0, 0]])
    res = minimal_realization(sys)
    assert res.order == 4 and res.n_uncontrollable == res.n_unobservable == 0


def test_tolerance_decides_near_cancellation():
    # a mode whose input coupling is 1e-9: uncontrollable at tol 1e-6, kept at the default
    sys = LinearSystem(np.diag([-1.0, -2.0]), [[1.0], [1e-9]], [[1.0, 1.0]])
    assert minimal_realization(sys).order == 2
    res = minimal_realization(sys, tol=1e-6)
    assert res.order == 1 and res.tol == 1e-6
    # after rotating B onto e1, the coupling block is u2^T A u1 = 1e-9 * (1 - 2) (hand
    # computation): that is the largest discarded value; the smallest kept is ||B|| = 1
    assert res.largest_discarded == pytest.approx(1e-9, rel=1e-6)
    assert res.smallest_kept == pytest.approx(1.0, rel=1e-12)


def test_balanced_method_finds_exactly_uncontrollable_copy():
    # two identical copies of the building model driven by the same input, only the first one
    # observed: the second is uncontrollable relative to the first (x1 - x2 stays 0) and
    # unobservable, so the minimal order is 48 (construction). The staircase (like SLICOT TB01PD
    # behind python-control's minreal) keeps all 96 on this 48-step single-input Krylov chain;
    # balancing decides on Hankel singular values and finds 48.
    from ..mor import load_mor

    build = load_mor("build")
    A, B, C = build.A, build.B, build.C
    dup = LinearSystem(scipy.linalg.block_diag(A, A), np.vstack([B, B]), np.hstack([C, np.zeros_like(C)]))
    res = minimal_realization(dup, method="balanced")
    assert res.order == 48 and res.n_removed == 48 and res.n_uncontrollable is None
    # a clear decision: the smallest kept Hankel singular value (2.6e-6 of the largest) is more
    # than 1e8 times the largest discarded one (round-off, 8e-17 of the largest)
    assert res.largest_discarded < 1e-8 * res.smallest_kept and res.largest_discarded < res.tol
    single = LinearSystem(A, B, C)
    for w in (3.0, 5.0, 20.0):  # same transfer function as the single copy (direct solves), 1e-8
        np.testing.assert_allclose(response(res.sys, 1j * w), response(single, 1j * w), rtol=1e-8)


def test_balanced_method_keeps_rigid_part():
    sys = hidden_modes_system(rigid=True)
    res = minimal_realization(sys, method="balanced")
    # 2 rigid states kept whole, 3 stable controllable+observable states found (construction)
    assert res.order == 5 and res.method == "balanced"
    for s in (0.7j, 1.0 + 3.0j):
        np.testing.assert_allclose(response(res.sys, s), response(sys, s), rtol=1e-8)


@pytest.mark.parametrize("tol", [-1.0, np.inf, "a"])
def test_bad_tol(tol):
    with pytest.raises(ModelError, match="tol"):
        minimal_realization(LinearSystem([[-1.0]], [[1.0]], [[1.0]]), tol=tol)
    with pytest.raises(ModelError, match="method"):
        minimal_realization(LinearSystem([[-1.0]], [[1.0]], [[1.0]]), method="svd")

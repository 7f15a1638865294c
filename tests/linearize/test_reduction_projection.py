"""The one projection base of the reductions (linearize/_projection.py) and the common result shape."""

import warnings

import numpy as np
import pytest
import scipy.linalg
from hypothesis import given, settings
from hypothesis import strategies as st

from linflex import LinearSystem, SecondOrderSystem, craig_bampton, guyan
from linflex.frequency import HinfNorm
from linflex.frequency._spectrum import classify
from linflex.linearize import (
    balanced_truncation,
    minimal_realization,
    modal_truncation,
    projected_modes_reduction,
    split_stable,
)
from linflex.linearize._projection import (
    ReductionResult,
    project,
    project_second_order,
    project_split,
    second_order_bases,
)

from .models import spacecraft

SO = spacecraft(n_modes=12)  # one rigid-body dof (double integrator) and 12 lightly damped modes
SS = SO.to_state_space()
HALF = {"a": [f"q{i}" for i in range(6)], "b": [f"q{i}" for i in range(6, 13)]}


def component_matrices():
    return np.array(SO.K), np.array(SO.M)


REDUCTIONS = {
    "balanced": lambda: balanced_truncation(SS, order=11, measure_error=True),
    "modal first order": lambda: modal_truncation(SS, keep=4, measure_error=True),
    "modal second order": lambda: modal_truncation(SO, keep=4, measure_error=True),
    "minimal staircase": lambda: minimal_realization(SS, measure_error=True),
    "minimal balanced": lambda: minimal_realization(SS, method="balanced", measure_error=True),
    "projected modes": lambda: projected_modes_reduction(SO, HALF, n_modes=5, measure_error=True),
    "craig-bampton": lambda: craig_bampton(*component_matrices(), [0], 4, mtv=True),
    "guyan": lambda: guyan(*component_matrices(), [0, 1, 2]),
}
HAS_BOUND = {"balanced", "minimal balanced"}
COMPONENT = {"craig-bampton", "guyan"}


@pytest.mark.parametrize("name", list(REDUCTIONS))
def test_every_result_has_the_common_shape(name):
    with warnings.catch_warnings():
        # round-off-level errors (minimal realizations) are honestly not certified; the shape is tested here
        warnings.simplefilter("ignore")
        res = REDUCTIONS[name]()
    assert isinstance(res, ReductionResult)
    red = res.sys
    n_coords = red.n_states if isinstance(red, LinearSystem) else red.n_dofs
    assert res.order == n_coords
    assert res.V.shape[1] == res.W.shape[1] == res.order
    assert np.isfinite(res.seconds) and res.seconds > 0
    if name in HAS_BOUND:
        assert isinstance(res.error_bound, float) and res.error_bound >= 0
    else:
        assert res.error_bound is None
    if name in COMPONENT:
        assert res.measured_error is None
        K, M = component_matrices()
        # independent dense Ritz projection of the full matrices, to round-off
        np.testing.assert_allclose(red.M, res.V.T @ M @ res.V, atol=1e-12 * np.abs(M).max() * np.abs(res.V).max() ** 2)
        np.testing.assert_allclose(red.K, res.V.T @ K @ res.V, atol=1e-12 * np.abs(K).max() * np.abs(res.V).max() ** 2)
        return
    err = res.measured_error
    assert isinstance(err, HinfNorm)
    assert err.value >= 0 and np.isfinite(err.evaluation_error) and err.evaluation_error >= 0
    assert "direct check of G - G_r" in err.method  # the one honest check of every reduction
    if isinstance(red, LinearSystem):
        # W^T V = I and the reduced matrices are the dense Petrov-Galerkin projection of the full
        # system to round-off (1e-12 relative to ||A|| ||V|| ||W||, the size of the product's round-off;
        # the split keeps the coupling blocks exactly zero where the dense product leaves round-off)
        V, W = res.V, res.W
        size = np.linalg.norm(V, 2) * np.linalg.norm(W, 2)
        np.testing.assert_allclose(W.T @ V, np.eye(res.order), atol=1e-12 * size)
        scale = np.linalg.norm(SS.A, 2) * size
        np.testing.assert_allclose(red.A, W.T @ SS.A @ V, atol=1e-12 * scale)
        np.testing.assert_allclose(red.B, W.T @ SS.B, atol=1e-12 * size * np.linalg.norm(SS.B, 2))
        np.testing.assert_allclose(red.C, SS.C @ V, atol=1e-12 * size * np.linalg.norm(SS.C, 2))
    else:
        # Galerkin on the dofs: q ~ V qr
        V = res.V
        size = np.linalg.norm(V, 2) ** 2
        for full, reduced in ((SO.M, red.M), (SO.K, red.K), (SO.D, red.D)):
            np.testing.assert_allclose(reduced, V.T @ full @ V, atol=1e-12 * size * np.abs(full).max())
        np.testing.assert_allclose(red.B, V.T @ SO.B, atol=1e-12 * size * np.abs(SO.B).max())


def test_measured_error_is_a_lower_bound_of_direct_evaluations():
    # modal truncation's measured error goes through the same check as balanced truncation's: at
    # any frequency, sigma_max(G - G_r) evaluated directly (dense solves) is below the value
    # (1e-6: the certificate's rtol), and the value is attained at omega
    res = modal_truncation(SS, keep=4, measure_error=True)
    err = res.measured_error

    def g(s, w):
        return s.C @ np.linalg.solve(1j * w * np.eye(s.n_states) - s.A, s.B) + s.D

    for w in np.geomspace(0.1, 200.0, 40):
        diff = np.linalg.norm(g(SS, w) - g(res.sys, w), 2)
        assert diff <= err.value * (1 + 1e-6) + err.evaluation_error
    peak = np.linalg.norm(g(SS, err.omega) - g(res.sys, err.omega), 2)
    assert peak == pytest.approx(err.value, rel=1e-8)


def test_split_projection_equals_projection_of_the_full_system():
    # project_split keeps the unstable part and projects the stable one; a dense projection of
    # the full system on the reassembled bases gives the same matrices (Sylvester residual level)
    split = split_stable(SS)
    rng = np.random.default_rng(3)
    Vs = np.linalg.qr(rng.standard_normal((split.stable.n_states, 6)))[0]
    out = project_split(split, Vs, prefix="z")
    dense = project(SS, out.V, out.W, states=[f"d{i}" for i in range(out.V.shape[1])])
    scale = np.linalg.norm(SS.A, 2) * np.linalg.norm(out.V, 2) * np.linalg.norm(out.W, 2)
    np.testing.assert_allclose(out.sys.A, dense.A, atol=1e-10 * scale)
    np.testing.assert_allclose(out.sys.B, dense.B, atol=1e-10 * scale)
    np.testing.assert_allclose(out.sys.C, dense.C, atol=1e-10 * scale)
    assert out.sys.states[:2] == ("xu0", "xu1") and out.sys.states[2] == "z0"


@settings(derandomize=True, max_examples=15, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(2, 7), r=st.integers(1, 4))
def test_second_order_projection_is_first_order_projection(seed, n, r):
    # project_second_order(so, T).to_state_space() == project(so.to_state_space(), V, W) with
    # V = blockdiag(T, T), W = blockdiag(T (T^T T)^-1, M T (T^T M T)^-1): the Ritz projection is
    # a Petrov-Galerkin projection of the first-order form (independent dense computation)
    rng = np.random.default_rng(seed)
    r = min(r, n)
    G = rng.standard_normal((n, n))
    M = G @ G.T + n * np.eye(n)
    H = rng.standard_normal((n, n))
    K = H @ H.T
    D = 0.1 * rng.standard_normal((n, n))
    so = SecondOrderSystem(M, D, K, rng.standard_normal((n, 2)), Cq=rng.standard_normal((3, n)),
                           Cv=rng.standard_normal((3, n)), Du=rng.standard_normal((3, 2)))
    T = rng.standard_normal((n, r))
    second = project_second_order(so, T, dofs=[f"r{i}" for i in range(r)]).to_state_space()
    V, W = second_order_bases(so, T)
    first = project(so.to_state_space(), V, W, states=[f"x{i}" for i in range(2 * r)])
    np.testing.assert_allclose(W.T @ V, np.eye(2 * r), atol=1e-9)
    for name in "ABCD":
        a, b = getattr(second, name), getattr(first, name)
        np.testing.assert_allclose(a, b, atol=1e-9 * max(1.0, np.abs(a).max()))


@settings(derandomize=True, max_examples=12, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(3, 9), r=st.integers(1, 2))
def test_glover_bound_holds_with_a_rigid_part(seed, n, r):
    # random stable system joined to a double integrator (kept exactly by the split): Glover's
    # hsv[r] <= ||G - G_r||_inf <= 2 sum(hsv[r:]) (1e-6: the certificate's rtol)
    rng = np.random.default_rng(seed)
    X = rng.standard_normal((n, n))
    As = X - (np.max(np.linalg.eigvals(X).real) + rng.uniform(0.1, 2.0)) * np.eye(n)
    A = scipy.linalg.block_diag([[0.0, 1.0], [0.0, 0.0]], As)
    sys = LinearSystem(A, rng.standard_normal((n + 2, 1)), rng.standard_normal((1, n + 2)))
    res = balanced_truncation(sys, order=2 + r, measure_error=True)
    assert res.n_unstable == 2
    assert res.hsv[r] * (1 - 1e-6) <= res.measured_error.value <= res.error_bound * (1 + 1e-6)


def test_second_order_rigid_modes_follow_the_spectrum_policy():
    # two free masses (one rigid mode) plus a clamped slow mode at 1e-3 rad/s: by default the
    # spectrum policy counts exactly the rigid poles of the first-order system (classify), and
    # rigid_tol = 1e-2 rad/s also takes the slow mode as rigid (|lambda| = w <= rigid_tol)
    K = np.array([[1.0, -1.0, 0.0], [-1.0, 1.0, 0.0], [0.0, 0.0, 1e-6]])
    so = SecondOrderSystem(np.eye(3), 0.01 * K, K, np.eye(3)[:, :1], Cq=np.eye(3)[:1])
    n_rigid_poles = int(np.count_nonzero(classify(so.to_state_space().A).rigid))
    default = modal_truncation(so, keep=1)
    assert 2 * default.n_rigid == n_rigid_poles == 2
    assert modal_truncation(so, keep=1, rigid_tol=1e-2).n_rigid == 2
    # the same name on every reduction: the first-order split takes the same keyword
    ss = so.to_state_space()
    n_split = split_stable(ss, rigid_tol=1e-2).n_unstable
    assert n_split == 4  # the rigid pair and the slow pair (poles +-1e-3 j)
    assert modal_truncation(ss, keep=1, rigid_tol=1e-2).n_rigid == n_split
    assert balanced_truncation(ss, order=n_split + 1, rigid_tol=1e-2).n_unstable == n_split


def test_static_peak_beside_a_rigid_body_is_checked_like_a_peak_at_zero():
    # the error of this balanced truncation peaks at DC (refined to omega ~ 1e-16 rad/s), where G
    # and G_r are both dominated by the double integrator they share exactly: the direct check
    # treats that peak like omega = 0 (it used to evaluate G there, found it unknown to 1e16 and
    # refused to certify). Glover's bounds hold for the certified value (independent: the hsv).
    res = balanced_truncation(SS, order=11, measure_error=True)  # a warning would fail (pyproject)
    err = res.measured_error
    assert err.omega < 1e-6 and err.certified
    assert res.hsv[10] * (1 - 1e-6) <= err.value <= res.error_bound * (1 + 1e-6)

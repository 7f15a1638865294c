"""Low-rank ADI gramian factors of sparse stable systems, and balanced truncation from them.

References: ``scipy.linalg.solve_continuous_lyapunov`` (Bartels-Stewart, dense, independent of
linflex) for the gramians and Hankel singular values; dense solves of ``sI - A`` for the
reduced model's error on a frequency grid.
"""

import numpy as np
import pytest
import scipy.linalg
import scipy.sparse
from hypothesis import given, settings
from hypothesis import strategies as st

from linflex import ConvergenceError, LinearSystem, ModelError
from linflex.linearize import balanced_truncation
from linflex.linearize._adi import adi_gramian_factor
from tests.mor import sparse_chain as chain


def hankel_singular_values(A, B, C):
    P = scipy.linalg.solve_continuous_lyapunov(A, -B @ B.T)
    Q = scipy.linalg.solve_continuous_lyapunov(A.T, -C.T @ C)
    return np.sqrt(np.sort(np.abs(np.linalg.eigvals(P @ Q)))[::-1])


@st.composite
def stable_sparse(draw):
    """Random sparse stable A (Gershgorin discs left of -margin), some lightly damped pairs."""
    n = draw(st.integers(4, 50))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    R = scipy.sparse.random(n, n, density=draw(st.floats(0.02, 0.3)), random_state=rng,
                            data_rvs=rng.standard_normal, format="csr")
    A = (R - scipy.sparse.diags(np.asarray(abs(R).sum(axis=1)).ravel() + draw(st.floats(0.05, 3.0)))).tolil()
    for k in range(draw(st.integers(0, n // 4))):      # oscillators of damping ratio 0.5 % to 20 %
        w, zeta = 10.0 ** rng.uniform(-1, 1.5), 10.0 ** rng.uniform(-2.3, -0.7)
        i = 2 * k
        A[i:i + 2, :] = 0.0
        A[i, i], A[i, i + 1], A[i + 1, i], A[i + 1, i + 1] = -zeta * w, w, -w, -zeta * w
    return scipy.sparse.csr_matrix(A), rng.standard_normal((n, draw(st.integers(1, 3))))


@settings(max_examples=40, deadline=None)
@given(stable_sparse())
def test_adi_factor_against_bartels_stewart(system):
    A, B = system
    f = adi_gramian_factor(A, B, rtol=1e-11)
    Ad = A.toarray()
    P = scipy.linalg.solve_continuous_lyapunov(Ad, -B @ B.T)
    Pz = f.Z @ f.Z.T
    # the reported residual is the true one (the residual form's identity), and it is small
    res = np.linalg.norm(Ad @ Pz + Pz @ Ad.T + B @ B.T, 2) / np.linalg.norm(B @ B.T, 2)
    assert f.residual <= 1e-11
    assert res <= 1e-11 + 1e-13 * np.linalg.norm(Ad, 2) * np.linalg.norm(Pz, 2) / np.linalg.norm(B @ B.T, 2)
    assert np.linalg.norm(P - Pz, 2) <= 1e-7 * np.linalg.norm(P, 2)


def test_adi_refuses_a_rigid_body_mode_and_an_unstable_one():
    A, B, _ = chain(20)
    rigid = scipy.sparse.bmat([[scipy.sparse.csr_matrix((1, 1)), None], [None, A]], format="csr")
    with pytest.raises(ConvergenceError, match="singular"):
        adi_gramian_factor(rigid, np.ones((41, 1)))
    with pytest.raises(ConvergenceError, match="not stable|imaginary axis"):
        adi_gramian_factor(scipy.sparse.diags([-1.0, 0.5, -2.0]), np.ones((3, 1)))


def test_balanced_truncation_adi_against_dense_gramians():
    """A chain of 150 masses (300 states): the low-rank path's Hankel singular values against
    Bartels-Stewart's, and its reduced model within the bound on a frequency grid."""
    A, B, C = chain(150, damping=1e-2)
    sys = LinearSystem(A, B, C)
    res = balanced_truncation(sys, order=12, lyapunov_solver="adi")
    ref = hankel_singular_values(A.toarray(), B, C)
    assert res.lyapunov_solver == "adi" and res.split is None and res.order == 12
    assert np.max(np.abs(res.hsv[:20] - ref[:20])) <= 1e-9 * ref[0]
    assert max(res.lyapunov_residuals) <= 1e-10
    omega = np.logspace(-2, 2.5, 400)
    Ad = A.toarray()
    G = np.array([C @ np.linalg.solve(1j * w * np.eye(Ad.shape[0]) - Ad, B) for w in omega])[:, 0, 0]
    Ar, Br, Cr = res.sys.A, res.sys.B, res.sys.C
    Gr = np.array([Cr @ np.linalg.solve(1j * w * np.eye(12) - Ar, Br) for w in omega])[:, 0, 0]
    err = np.max(np.abs(G - Gr))
    assert err <= res.error_bound
    assert err >= 0.5 * res.hsv[12]          # the lower bound hsv[r], less the grid's miss
    assert res.error_bound == pytest.approx(2 * np.sum(res.hsv[12:]), rel=1e-12)
    # the basis: W^T V = I, and the reduced A is W^T A V
    np.testing.assert_allclose(res.W.T @ res.V, np.eye(12), atol=1e-9)


def test_balanced_truncation_adi_input_errors():
    A, B, C = chain(10)
    with pytest.raises(ModelError, match="scipy.sparse"):
        balanced_truncation(LinearSystem(A.toarray(), B, C), order=4, lyapunov_solver="adi")
    A, B, C = chain(60, damping=0.2)
    resolved = balanced_truncation(LinearSystem(A, B, C), order=2, lyapunov_solver="adi").hsv.size
    assert resolved < 120
    with pytest.raises(ModelError, match=f"order={resolved + 1} is above the {resolved} Hankel"):
        balanced_truncation(LinearSystem(A, B, C), order=resolved + 1, lyapunov_solver="adi")


def test_auto_takes_the_dense_path_where_adi_refuses(monkeypatch):
    """A sparse system with a rigid-body mode: "auto" from ADI_STATES_MIN (lowered to 10 here)
    tries the ADI, which refuses the singular A, and reduces it by the dense path with the rigid
    mode split off; "adi" asked for explicitly raises."""
    import linflex.linearize._balanced as balanced_module

    monkeypatch.setattr(balanced_module, "ADI_STATES_MIN", 10)
    A, B, C = chain(20, damping=1e-2)
    free = scipy.sparse.bmat([[scipy.sparse.csr_matrix((1, 1)), None], [None, A]], format="csr")
    sys = LinearSystem(free, np.ones((41, 1)), np.ones((1, 41)))
    res = balanced_truncation(sys, order=6)
    assert res.lyapunov_solver != "adi" and res.n_unstable == 1
    with pytest.raises(ConvergenceError, match="singular"):
        balanced_truncation(sys, order=6, lyapunov_solver="adi")
    assert balanced_truncation(LinearSystem(A, B, C), order=6).lyapunov_solver == "adi"


def test_measured_error_of_a_sparse_reduction():
    """measure_error=True on the ADI path: a sweep of G - G_r over the reduced poles, refined; the
    value is attained, so below the true norm, and at least the largest difference on a dense
    400-point grid of dense solves (the reference) less 1e-6; within the bound; not certified.
    The same for a sparse modal truncation, against the whole-matrix path's certified value on
    the dense copy."""
    from linflex.linearize import modal_truncation

    A, B, C = chain(150, damping=1e-2)
    sys = LinearSystem(A, B, C)
    res = balanced_truncation(sys, order=12, lyapunov_solver="adi", measure_error=True)
    m = res.measured_error
    Ad = A.toarray()
    omega = np.logspace(-2, 2.5, 400)
    G = np.array([C @ np.linalg.solve(1j * w * np.eye(300) - Ad, B) for w in omega])[:, 0, 0]
    Gr = np.array([res.sys.C @ np.linalg.solve(1j * w * np.eye(12) - res.sys.A, res.sys.B) for w in omega])[:, 0, 0]
    assert not m.certified and m.value <= res.error_bound
    assert m.value >= np.max(np.abs(G - Gr)) * (1 - 1e-6)
    assert m.evaluation_error <= 1e-6 * m.value
    sparse = modal_truncation(sys, keep=6, measure_error=True)
    dense = modal_truncation(LinearSystem(Ad, B, C), keep=6, measure_error=True)
    assert dense.measured_error.certified and not sparse.measured_error.certified
    assert sparse.measured_error.value == pytest.approx(dense.measured_error.value, rel=1e-6)

"""Systems given a ``scipy.sparse`` state matrix keep it, and the frequency engine evaluates them
from it: block-diagonal patterns by the block-modal path, others by one sparse LU per point.

References: dense complex solves of ``sI - A`` per point (``numpy.linalg.solve``, independent of
the engine), and the dense system through the engine's own paths.
"""

import numpy as np
import pytest
import scipy.sparse
from hypothesis import given, settings
from hypothesis import strategies as st

import linflex.system._linear as linear_module
from linflex import LinearSystem, ModelError, ShapeError
from linflex.frequency import frequency_response
from linflex.frequency._evaluate import TransferEvaluator
from linflex.frequency._modal_forms import block_components
from linflex.stability import stability_margins
from tests.mor import load_mor
from tests.mor import sparse_chain as chain


def dense_reference(A, B, C, D, omega):
    n = A.shape[0]
    return np.array([C @ np.linalg.solve(1j * w * np.eye(n) - A, B) + D for w in omega])


@st.composite
def sparse_systems(draw):
    """Random stable sparse systems: a random sparse pattern (density 2 to 20 %) shifted left of
    its Gershgorin discs' real parts, 1 to 3 inputs and outputs."""
    n = draw(st.integers(6, 60))
    seed = draw(st.integers(0, 2**32 - 1))
    density = draw(st.floats(0.02, 0.2))
    rng = np.random.default_rng(seed)
    R = scipy.sparse.random(n, n, density=density, random_state=rng, data_rvs=rng.standard_normal, format="csr")
    margin = draw(st.floats(0.01, 2.0))
    A = R - scipy.sparse.diags(np.asarray(abs(R).sum(axis=1)).ravel() + margin)
    m, p = draw(st.integers(1, 3)), draw(st.integers(1, 3))
    return A.tocsr(), rng.standard_normal((n, m)), rng.standard_normal((p, n)), rng.standard_normal((p, m))


@settings(max_examples=40, deadline=None)
@given(sparse_systems(), st.floats(-2.0, 2.0))
def test_sparse_path_against_dense_solves(system, log_w):
    A, B, C, D = system
    sys = LinearSystem(A, B, C, D)
    omega = np.array([10.0**log_w, 10.0 ** (log_w + 0.5)])
    ref = dense_reference(A.toarray(), B, C, D, omega)
    # the sparse LU path, and whatever "auto" takes (block-modal where the pattern splits)
    for method in ("sparse", "auto"):
        ev = TransferEvaluator(sys, method)
        G = ev(omega)
        err = np.max(np.abs(G - ref), axis=(1, 2)) / np.max(np.abs(ref), axis=(1, 2))
        assert ev.label in (("sparse",) if method == "sparse" else ("sparse", "modal", "modal+schur"))
        # the estimate bounds the difference (the reference's own rounding allowed for)
        assert np.all(err <= ev.last_error + 1e-13)
        assert np.all(err <= 1e-9)


def test_chain_sparse_path_agrees_with_the_dense_engine():
    A, B, C = chain(150)
    sparse, dense = LinearSystem(A, B, C), LinearSystem(A.toarray(), B, C)
    assert block_components(A) is None            # banded: no block structure
    omega = np.logspace(-1, 1.7, 60)
    r = frequency_response(sparse, omega)
    ref = frequency_response(dense, omega, method="direct")
    assert r.method == "sparse"
    err = np.max(np.abs(r.response - ref.response)) / np.max(np.abs(ref.response))
    assert err <= 1e-10
    assert err <= r.error_estimate + ref.error_estimate


def test_block_diagonal_sparse_takes_the_block_modal_path():
    """ISS 12A (706 modal blocks of order 2) stored sparse: the same blocks, the same values as
    the dense system (to round-off of the block extraction: exactly here). (Margins of sparse
    loops: the chain test below.)"""
    S, Dn = load_mor("ISS12A", sparse=True), load_mor("ISS12A")
    assert S.is_sparse and not Dn.is_sparse
    assert block_components(S.A_sparse)[0] == block_components(Dn.A)[0]
    omega = np.logspace(-1, 2, 200)
    rs, rd = frequency_response(S, omega), frequency_response(Dn, omega)
    assert rs.method == rd.method == "modal"
    assert np.max(np.abs(rs.response - rd.response)) <= 1e-14 * np.max(np.abs(rd.response))


def test_block_components_same_on_dense_and_sparse_patterns():
    """The rewrite on the non-zero pattern: a hub of 3 states fed by 12 blocks of order 2 (the
    blocks feed the hub), found alike from the dense and the sparse matrix."""
    rng = np.random.default_rng(3)
    n_b = 12
    A = np.zeros((2 * n_b + 3, 2 * n_b + 3))
    for k in range(n_b):
        A[2 * k:2 * k + 2, 2 * k:2 * k + 2] = [[0, 1], [-(k + 1.0) ** 2, -0.02]]
    A[2 * n_b:, :2 * n_b] = rng.standard_normal((3, 2 * n_b))
    A[2 * n_b:, 2 * n_b:] = -np.eye(3)
    dense, sparse = block_components(A), block_components(scipy.sparse.csr_matrix(A))
    assert dense[0] == sparse[0] == n_b
    assert np.array_equal(dense[1], sparse[1])
    assert np.array_equal(dense[2][0], sparse[2][0]) and dense[2][1] is sparse[2][1] is False


def test_sparse_system_keeps_its_matrix_and_forms_the_dense_one_on_demand(monkeypatch):
    A, B, C = chain(20)
    sys = LinearSystem(A, B, C)
    assert sys.is_sparse and sys.n_states == 40 and sys.A_sparse.nnz == A.nnz
    assert sys.with_(outputs=["tip"]).is_sparse and sys.subsystem().is_sparse
    np.testing.assert_array_equal(sys.A, A.toarray())
    assert not sys.A.flags.writeable
    monkeypatch.setattr(linear_module, "DENSE_STATES_MAX", 30)
    big = LinearSystem(A, B, C)
    with pytest.raises(ModelError, match="sparse with 40 states"):
        big.A
    # the structure-aware paths never ask for it
    assert frequency_response(big, [1.0, 2.0]).method == "sparse"


def test_sparse_input_types():
    """COO, CSC, integer and sparse-array inputs; sparse B, C and D are taken dense. Reference:
    the diagonal system's closed form sum_k 1 / (j + k) at 1 rad/s."""
    A = np.diag([-1.0, -2.0, -3.0, -4.0])
    expected = sum(1.0 / (1j + k) for k in (1, 2, 3, 4))
    for matrix in (scipy.sparse.coo_array(A), scipy.sparse.csc_matrix(A), scipy.sparse.csr_matrix(A.astype(int))):
        sys = LinearSystem(matrix, scipy.sparse.csr_matrix(np.ones((4, 1))), scipy.sparse.coo_matrix(np.ones((1, 4))),
                           scipy.sparse.csr_matrix(np.zeros((1, 1))))
        assert sys.is_sparse and isinstance(sys.B, np.ndarray)
        assert frequency_response(sys, [1.0]).response[0, 0, 0] == pytest.approx(expected, rel=1e-14)


def test_sparse_input_errors():
    with pytest.raises(ShapeError, match="square"):
        LinearSystem(scipy.sparse.csr_matrix(np.ones((3, 2))), np.ones((3, 1)))
    bad = scipy.sparse.csr_matrix(np.diag([1.0, np.nan, 2.0]))
    with pytest.raises(ShapeError, match=r"A\[1, 1\] is not finite"):
        LinearSystem(bad, np.ones((3, 1)))
    with pytest.raises(ShapeError, match="real"):
        LinearSystem(scipy.sparse.csr_matrix(np.diag([1j, 1.0])), np.ones((2, 1)))
    with pytest.raises(ModelError, match="method='sparse'"):
        TransferEvaluator(LinearSystem(np.eye(2), np.ones((2, 1)), np.ones((1, 2))), "sparse")


def test_pole_on_a_point_is_infinite_not_a_crash():
    A = scipy.sparse.csr_matrix(np.array([[0.0, 1.0], [-4.0, 0.0]]))   # undamped, 2 rad/s
    ev = TransferEvaluator(LinearSystem(A, [[0.0], [1.0]], [[1.0, 0.0]]), "sparse")
    G = ev([2.0, 1.0])
    assert np.isinf(ev.last_error[0]) and ev.last_error[1] < 1e-14
    assert G[1, 0, 0] == pytest.approx(1.0 / 3.0, rel=1e-14)


def test_margins_and_nyquist_of_a_sparse_loop_equal_the_dense_ones():
    """A chain loop with no block structure (the sparse LU path): the same crossings and margins
    as the dense system (the engine's dense paths, an independent evaluation), and the same
    Nyquist count."""
    from linflex.frequency import nyquist_response

    A, B, C = chain(60, damping=1e-2)
    sparse, dense = LinearSystem(A, B, 300.0 * C), LinearSystem(A.toarray(), B, 300.0 * C)
    ms, md = stability_margins(sparse), stability_margins(dense)
    assert ms.closed_loop_stable and md.closed_loop_stable
    assert ms.min_phase_margin == pytest.approx(md.min_phase_margin, rel=1e-8)
    assert ms.min_gain_margin == pytest.approx(md.min_gain_margin, rel=1e-8)
    assert ms.delay_margin == pytest.approx(md.delay_margin, rel=1e-8)
    assert nyquist_response(sparse).encirclements == nyquist_response(dense).encirclements == 0


def test_poles_of_a_large_sparse_system_are_refused_with_the_way_out(monkeypatch):
    import linflex.frequency._evaluate as evaluate_module

    monkeypatch.setattr(evaluate_module, "SPARSE_POLES_MAX", 50)
    A, B, C = chain(40)
    sys = LinearSystem(A, B, C)
    with pytest.raises(ModelError, match="give frequency_response the frequencies"):
        stability_margins(sys)
    assert frequency_response(sys, [1.0]).method == "sparse"
    # an inaccurate point's warning names a cause without the poles
    ev = TransferEvaluator(sys)
    assert "ill conditioned" in ev.cause(1j)

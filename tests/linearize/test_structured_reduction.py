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
from linflex.linearize._reduction_split import split_stable


def modal_system(seed, n_modes, m, p, *, rigid=False, zeta=(1e-3, 0.2), undamped=0):
    """Modal 2x2 blocks (frequencies 0.1..50 rad/s) under a random permutation of the states;
    the first ``undamped`` modes without damping."""
    rng = np.random.default_rng(seed)
    w = np.exp(rng.uniform(np.log(0.1), np.log(50.0), n_modes))
    z = np.exp(rng.uniform(np.log(zeta[0]), np.log(zeta[1]), n_modes))
    z[:undamped] = 0.0
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


def test_auto_lyapunov_solver_follows_the_shape_and_agrees_with_sb03od():
    pytest.importorskip("slycot")
    from linflex.linearize._balanced import MODAL_STATES_MIN

    small = modal_system(4, 60, 2, 2)
    assert balanced_truncation(small, order=10).lyapunov_solver == "SB03OD"     # below MODAL_STATES_MIN
    modal = modal_system(4, MODAL_STATES_MIN // 2 + 3, 2, 2)
    auto = balanced_truncation(modal, order=10)
    assert auto.lyapunov_solver == "modal"
    dense = balanced_truncation(dense_copy(modal, 5), order=10)
    assert dense.lyapunov_solver == "SB03OD"
    own = balanced_truncation(modal, order=10, lyapunov_solver="hammarling")
    keep = auto.hsv > 1e-6 * auto.hsv[0]
    # three backward-stable implementations of Hammarling's method, two Schur forms
    for other in (dense, own):
        np.testing.assert_allclose(auto.hsv[keep], other.hsv[keep], rtol=1e-9)
        assert auto.error_bound == pytest.approx(other.error_bound, rel=1e-6)


def series_system(seed, n_modes, hub, *, feeds, rigid=False, m=1, p=1, zeta=(1e-3, 0.2), undamped=0):
    """A modal plant and a random stable controller of ``hub`` states in series, coupled one way
    (the controller drives the plant when ``feeds``), under a random permutation of the states."""
    plant = modal_system(seed, n_modes, m, p, rigid=rigid, zeta=zeta, undamped=undamped)
    rng = np.random.default_rng(seed + 1)
    Ak = rng.normal(size=(hub, hub))
    Ak -= (np.max(np.linalg.eigvals(Ak).real) + rng.uniform(0.5, 5.0)) * np.eye(hub)   # stable
    n = plant.n_states
    A = np.zeros((n + hub, n + hub))
    A[:n, :n], A[n:, n:] = plant.A, Ak
    if feeds:
        A[:n, n:] = plant.B @ rng.normal(size=(m, hub))
    else:
        A[n:, :n] = rng.normal(size=(hub, p)) @ plant.C
    B = np.vstack([plant.B, rng.normal(size=(hub, m))])
    C = np.hstack([plant.C, rng.normal(size=(p, hub))])
    perm = rng.permutation(n + hub)
    return LinearSystem(A[np.ix_(perm, perm)], B[perm], C[:, perm])


def _response(sys, w):
    return sys.C @ np.linalg.solve(1j * w * np.eye(sys.n_states) - sys.A, sys.B) + sys.D


@settings(derandomize=True, max_examples=30, deadline=None)
@given(seed=st.integers(0, 10_000), n_modes=st.integers(2, 30), hub=st.integers(0, 4), feeds=st.booleans(),
       rigid=st.booleans(), sparse=st.booleans(), overdamped=st.booleans(), undamped=st.booleans())
def test_block_split_matches_the_dense_split(seed, n_modes, hub, feeds, rigid, sparse, overdamped, undamped):
    # the split block by block (a modal plant, a controller in series decoupled by one Sylvester
    # equation) against the dense path's on the same system in random orthogonal coordinates:
    # the same eigenvalues in each part, the parts' transfer functions equal, T^-1 A T block
    # diagonal to rounding, the stable part block diagonal beyond a leading block of the hub's
    # size (the modal shape of _block_lyapunov)
    import scipy.sparse

    from linflex.linearize._block_lyapunov import modal_extent

    # (overdamped: damping up to 3, blocks of two real eigenvalues, which join the leading block;
    # undamped: the first mode without damping, split to the stable part as modal_truncation asks)
    zeta = (1e-3, 3.0) if overdamped else (1e-3, 0.2)
    if hub:
        sys = series_system(seed, n_modes, hub, feeds=feeds, rigid=rigid, zeta=zeta, undamped=int(undamped))
    else:
        sys = modal_system(seed, n_modes, 1, 1, rigid=rigid, zeta=zeta, undamped=int(undamped))
    mode = "stable" if undamped else "unstable"
    if sparse:
        sys = LinearSystem(scipy.sparse.csr_matrix(sys.A), sys.B, sys.C, sys.D)
    sp = split_stable(sys, undamped=mode)
    ref = split_stable(dense_copy(LinearSystem(sys.A, sys.B, sys.C, sys.D), seed + 2), undamped=mode)
    assert sp.n_unstable == ref.n_unstable == (2 if rigid else 0)
    if n_modes >= 5 and not overdamped:   # a hub: more than HUB_DEGREE couplings (smaller ones: dense path)
        assert modal_extent(sp.stable.A) <= hub
    # (the rigid double integrator is a Jordan block: the dense copy's eigenvalues are
    # sqrt(eps ||A||) off the exact 0 the block keeps)
    jordan = 10.0 * np.sqrt(np.finfo(float).eps * np.linalg.norm(sys.A, 1))
    for part, other, atol in ((sp.stable, ref.stable, 0.0), (sp.unstable, ref.unstable, jordan)):
        ev = np.sort_complex(np.linalg.eigvals(part.A))
        ev_ref = np.sort_complex(np.linalg.eigvals(other.A))
        np.testing.assert_allclose(ev, ev_ref, atol=atol + 1e-9 * max(1.0, np.max(np.abs(ev_ref), initial=0.0)))
        for w in (0.05, 1.0, 7.0):
            if part.n_states:
                G, Gr = _response(part, w), _response(other, w)
                assert np.max(np.abs(G - Gr)) <= 1e-8 * max(1.0, np.max(np.abs(Gr)))
    M = sp.T_inv @ sys.A @ sp.T
    k = sp.n_unstable
    scale = np.linalg.norm(sys.A, 1) * np.linalg.norm(sp.T, 1) * np.linalg.norm(sp.T_inv, 1)
    np.testing.assert_allclose(M[:k, :k], sp.unstable.A, atol=1e-13 * scale)
    np.testing.assert_allclose(M[k:, k:], sp.stable.A, atol=1e-13 * scale)
    assert np.max(np.abs(M[:k, k:]), initial=0.0) <= 1e-13 * scale
    assert np.max(np.abs(M[k:, :k]), initial=0.0) <= 1e-13 * scale
    assert np.max(np.abs(sp.T_inv @ sp.T - np.eye(sys.n_states))) <= 1e-12 * sp.condition


@pytest.mark.parametrize("feeds", [False, True])
def test_block_split_with_a_hub_larger_than_the_blocks(feeds):
    # 12 controller states in series with 3 modes (6 states): the decoupling's X is taller than
    # wide or wider than tall the other way round; reference: the dense split of the same system
    from linflex.frequency._modal_forms import block_components

    rng = np.random.default_rng(11)
    plant = modal_system(11, 3, 1, 1)
    Ak = rng.normal(size=(12, 12))
    Ak -= (np.max(np.linalg.eigvals(Ak).real) + 1.0) * np.eye(12)
    A = scipy.linalg.block_diag(plant.A, Ak)
    # controller state i coupled to plant state i mod 6 alone (a plant state with more than
    # HUB_DEGREE couplings would join the hub)
    i = np.arange(12)
    if feeds:
        A[i % 6, 6 + i] = rng.normal(size=12)
    else:
        A[6 + i, i % 6] = rng.normal(size=12)
    sys = LinearSystem(A, rng.normal(size=(18, 2)), rng.normal(size=(2, 18)))
    found = block_components(sys.A)
    assert found is not None and found[2] is not None and found[2][0].size > 18 - found[2][0].size
    sp = split_stable(sys)
    ref = split_stable(dense_copy(sys, 12))
    M = sp.T_inv @ sys.A @ sp.T
    scale = np.linalg.norm(sys.A, 1) * np.linalg.norm(sp.T, 1) * np.linalg.norm(sp.T_inv, 1)
    np.testing.assert_allclose(M, scipy.linalg.block_diag(sp.unstable.A, sp.stable.A), atol=1e-13 * scale)
    for w in (0.1, 3.0):
        np.testing.assert_allclose(_response(sp.stable, w), _response(ref.stable, w), atol=1e-10)


def test_block_split_of_a_block_with_eigenvalues_on_both_sides():
    # a 2x2 block with eigenvalues 0 and -3 (a rigid mode with a first-order lag) beside modal
    # blocks: split inside the block; reference: the dense split of the same system
    blocks = [np.array([[0.0, 1.0], [0.0, -3.0]])] + [np.array([[0.0, 1.0], [-w * w, -0.02 * w]])
                                                      for w in (1.0, 2.0, 5.0)]
    A = scipy.linalg.block_diag(*blocks)
    n = A.shape[0]
    sys = LinearSystem(A, np.ones((n, 1)), np.ones((1, n)))
    sp = split_stable(sys)
    ref = split_stable(dense_copy(sys, 3))
    assert sp.n_unstable == ref.n_unstable == 1
    np.testing.assert_allclose(np.sort(np.linalg.eigvals(sp.stable.A).real), np.sort(np.linalg.eigvals(ref.stable.A).real),
                               atol=1e-12)
    for w in (0.3, 2.0):
        np.testing.assert_allclose(_response(sp.stable, w), _response(ref.stable, w), atol=1e-12)


@settings(derandomize=True, max_examples=30, deadline=None)
@given(seed=st.integers(0, 10_000), n_pairs=st.integers(0, 12), n_real=st.integers(0, 4), h=st.integers(0, 5),
       m=st.integers(1, 3), zero_rows=st.booleans())
def test_block_lyapunov_factors_solve_both_equations(seed, n_pairs, n_real, h, m, zero_rows):
    # the real block recursion against Bartels-Stewart (scipy.linalg.solve_continuous_lyapunov,
    # an independent method forming the gramians) on S = blockdiag(H, modal blocks) with a dense
    # quasi-triangular H, 1x1 and 2x2 blocks (in Schur form), and modes the inputs do not reach
    from linflex.linearize._block_lyapunov import block_lyapunov_factors, modal_extent

    rng = np.random.default_rng(seed)
    blocks = []
    if h:
        blocks.append(scipy.linalg.schur(rng.normal(size=(h, h)) - 3.0 * np.sqrt(h) * np.eye(h), output="real")[0])
    for _ in range(n_pairs):
        w = np.exp(rng.uniform(np.log(0.1), np.log(50.0)))
        z = np.exp(rng.uniform(np.log(1e-4), np.log(0.5)))
        blocks.append(scipy.linalg.schur(np.array([[0.0, 1.0], [-w * w, -2 * z * w]]), output="real")[0])
    blocks += [np.array([[-np.exp(rng.uniform(-2, 3))]]) for _ in range(n_real)]
    if not blocks:
        return
    S = scipy.linalg.block_diag(*blocks)
    n = S.shape[0]
    B, C = rng.normal(size=(n, m)), rng.normal(size=(m, n))
    if zero_rows and n > h + 2:
        B[h:h + 2], C[:, -1] = 0.0, 0.0
    assert modal_extent(S) <= h
    Zc, Zo = block_lyapunov_factors(S, B, C)
    P = scipy.linalg.solve_continuous_lyapunov(S, -B @ B.T)
    Q = scipy.linalg.solve_continuous_lyapunov(S.T, -C.T @ C)
    # both backward stable: agreement to the conditioning of the equation, 1e-10 of the norm here
    assert np.max(np.abs(Zc @ Zc.T - P)) <= 1e-10 * np.max(np.abs(P))
    assert np.max(np.abs(Zo @ Zo.T - Q)) <= 1e-10 * np.max(np.abs(Q))


def test_modal_extent_reads_the_leading_block():
    from linflex.linearize._block_lyapunov import modal_extent

    pair = np.array([[-1.0, 2.0], [-3.0, -1.0]])
    S = scipy.linalg.block_diag(np.array([[-1.0, 5.0], [0.0, -2.0]]), pair, [[-4.0]], pair)
    assert modal_extent(S) == 2
    S[1, 3] = 1.0            # the leading block reaches into the first pair's second state: takes the pair
    assert modal_extent(S) == 4
    assert modal_extent(scipy.linalg.block_diag(pair, pair)) == 0
    assert modal_extent(np.triu(np.ones((3, 3)))) == 3
    S[0, 4] = 1.0            # and into the real block after it
    assert modal_extent(S) == 5


@settings(derandomize=True, max_examples=30, deadline=None)
@given(seed=st.integers(0, 10_000), n=st.integers(8, 60), r=st.integers(1, 15), decay=st.floats(0.0, 1.5),
       gap=st.sampled_from([1.0, 1.0 + 1e-6, 2.0]))
def test_leading_singular_vectors_against_the_full_svd(seed, n, r, decay, gap):
    # singular values 10^(-decay i) with the r-th and (r+1)-th a factor `gap` apart: the triplets
    # are exact for their subspace (U1^T M V1 = diag(S1)), S1 equals the SVD's values, and the
    # subspace is the SVD's to the accuracy the gap allows (reference: LAPACK gesdd of M)
    from linflex.linearize._balanced import leading_singular_vectors

    r = min(r, n - 1)
    rng = np.random.default_rng(seed)
    s = 10.0 ** (-decay * np.arange(n))
    s[r:] /= gap
    U0, _ = np.linalg.qr(rng.normal(size=(n, n)))
    V0, _ = np.linalg.qr(rng.normal(size=(n, n)))
    M = (U0 * s) @ V0.T
    hsv = scipy.linalg.svdvals(M)
    U1, S1, V1 = leading_singular_vectors(M, hsv, r)
    assert U1.shape == V1.shape == (n, r)
    np.testing.assert_allclose(U1.T @ M @ V1, np.diag(S1), atol=1e-13 * hsv[0])
    # (values at rounding level, n eps hsv[0], differ by rounding between any two methods)
    np.testing.assert_allclose(S1, hsv[:r], rtol=1e-8, atol=n * np.finfo(float).eps * hsv[0])
    U, S, Vt = scipy.linalg.svd(M)
    if hsv[r - 1] > hsv[r] * (1.0 + 1e-3):
        # sin of the largest angle between the subspaces: eps hsv[0]^2 / (hsv[r-1]^2 - hsv[r]^2)
        # for the squared path (used only while hsv[r-1] >= 1e-3 hsv[0]), times a margin
        sep = (hsv[r - 1] ** 2 - hsv[r] ** 2) / hsv[0] ** 2
        sin = np.linalg.norm(V1 - Vt[:r].T @ (Vt[:r] @ V1), 2)
        assert sin <= 1e-13 / sep


@settings(derandomize=True, max_examples=15, deadline=None)
@given(seed=st.integers(0, 10_000), n_modes=st.integers(5, 40), hub=st.integers(0, 3), feeds=st.booleans(),
       rigid=st.booleans(), overdamped=st.booleans(), m=st.integers(1, 2))
def test_balanced_truncation_of_a_modal_model_matches_its_dense_copy(seed, n_modes, hub, feeds, rigid, overdamped, m):
    # the modal path (block split, real block recursion, leading singular vectors) against the
    # dense one (Schur form, the complex recursion, a full SVD) on the same transfer function in
    # random orthogonal coordinates: the same Hankel singular values and reduced responses
    zeta = (1e-3, 3.0) if overdamped else (1e-3, 0.2)
    if hub:
        sys = series_system(seed, n_modes, hub, feeds=feeds, rigid=rigid, zeta=zeta, m=m, p=m)
    else:
        sys = modal_system(seed, n_modes, m, m, rigid=rigid, zeta=zeta)
    order = (2 if rigid else 0) + 6
    fast = balanced_truncation(sys, order=order, lyapunov_solver="modal")
    ref = balanced_truncation(dense_copy(sys, seed + 3), order=order, lyapunov_solver="hammarling")
    keep = ref.hsv > 1e-6 * ref.hsv[0]
    np.testing.assert_allclose(fast.hsv[keep], ref.hsv[keep], rtol=1e-8)
    for w in (0.05, 0.7, 9.0):
        G, Gr = _response(fast.sys, w), _response(ref.sys, w)
        assert np.max(np.abs(G - Gr)) <= 1e-7 * max(ref.hsv[0], np.max(np.abs(Gr)))

"""Structured evaluation paths of frequency/_evaluate.py against dense solves (hypothesis, seeded).

The block-diagonal modal form (``_BlockModal``: blocks found from A's sparsity, eigendecomposed
block by block, block-wise Schur re-evaluation) and the residual check of the dense modal form
(``_Modal.residual_checked``) are compared with an independent reference: one dense complex solve
``numpy.linalg.solve(s I - A, B)`` per point, in the original (unpermuted, unbalanced)
coordinates. Each computed error estimate must bound the difference, up to the reference's own
error (the backward-stable bound of ``_direct_eval`` at the same point).
"""

import numpy as np
import pytest
import scipy.linalg
from hypothesis import given, settings
from hypothesis import strategies as st

from linflex import LinearSystem
from linflex.frequency import frequency_response
from linflex.frequency._evaluate import TransferEvaluator, _direct_eval
from linflex.frequency._modal_forms import _BlockModal, _Modal, block_components


def block_system(seed, n_blocks, m, p, *, rigid=False, zeta_min=1e-4, real_blocks=True):
    """Block-diagonal system under a random state permutation: 2x2 modes (damping from zeta_min
    to 0.5, frequencies 0.1..100 rad/s), some 1x1 and 3x3 stable blocks, an optional rigid-body
    double integrator; B and C dense."""
    rng = np.random.default_rng(seed)
    blocks = []
    for _ in range(n_blocks):
        kind = rng.integers(0, 4) if real_blocks else 0
        if kind <= 1:
            w = np.exp(rng.uniform(np.log(0.1), np.log(100.0)))
            z = np.exp(rng.uniform(np.log(zeta_min), np.log(0.5)))
            blocks.append(np.array([[0.0, 1.0], [-w * w, -2 * z * w]]))
        elif kind == 2:
            blocks.append(np.array([[-np.exp(rng.uniform(-2, 3))]]))
        else:
            M = rng.normal(size=(3, 3))
            blocks.append(M - (np.max(np.linalg.eigvals(M).real) + rng.uniform(0.1, 2.0)) * np.eye(3))
    if rigid:
        blocks.insert(0, np.array([[0.0, 1.0], [0.0, 0.0]]))
    A = scipy.linalg.block_diag(*blocks)
    n = A.shape[0]
    perm = rng.permutation(n)
    A = A[np.ix_(perm, perm)]
    return LinearSystem(A, rng.normal(size=(n, m)), rng.normal(size=(p, n)))


def check_points(sys, extra=()):
    lam = np.linalg.eigvals(sys.A)
    lam = lam[lam.imag > 0]
    w = np.concatenate([np.logspace(-2, 3, 9), lam.imag, lam.imag + 0.3 * np.abs(lam.real), list(extra)])
    return 1j * np.unique(w[w > 0])


def assert_bounded(G, est, sys, s):
    ref, ref_est = _direct_eval(sys, s)
    scale = np.max(np.abs(ref), axis=(1, 2))
    err = np.max(np.abs(G - ref), axis=(1, 2)) / scale
    assert np.all(err <= est + 2 * ref_est + 1e-15), (err, est)
    return err


def test_block_components_finds_permuted_blocks_and_rejects_coupled_matrices():
    sys = block_system(1, 12, 1, 1)
    found = block_components(sys.A)
    assert found is not None
    n_blocks, label, hub = found
    assert n_blocks == 12 and hub is None
    # every non-zero of A joins two states of the same block
    i, j = np.nonzero(sys.A)
    assert np.all(label[i] == label[j])
    # one coupling entry between two blocks joins them
    A = sys.A.copy()
    a, b = np.flatnonzero(label == label[0])[0], np.flatnonzero(label != label[0])[0]
    A[a, b] = 1.0
    assert block_components(A)[0] == 11
    # a dense or irreducible matrix has no blocks
    assert block_components(np.random.default_rng(0).normal(size=(20, 20))) is None
    assert block_components(np.diag(np.ones(19), 1) - np.eye(20)) is None


@settings(derandomize=True, max_examples=15, deadline=None)
@given(seed=st.integers(0, 10_000), n_blocks=st.integers(3, 30), m=st.integers(1, 3), p=st.integers(1, 3),
       rigid=st.booleans(), zeta_min=st.sampled_from([1e-5, 1e-3, 0.05]))
def test_block_modal_agrees_with_dense_solves(seed, n_blocks, m, p, rigid, zeta_min):
    sys = block_system(seed, n_blocks, m, p, rigid=rigid, zeta_min=zeta_min)
    ev = TransferEvaluator(sys)
    assert isinstance(ev.modal, _BlockModal)
    assert ev.modal.k == (2 if rigid else 0)  # the defective rigid block is the only dense one
    s = check_points(sys)
    G = ev.at(s)
    err = assert_bounded(G, ev.last_error, sys, s)
    assert np.max(err) < 1e-9
    # the same numbers as the dense modal form of the whole matrix (no structure used)
    dense = _Modal(sys)
    Gd, rd, idd = dense.evaluate(s)
    assert np.all(np.max(np.abs(G - Gd), axis=(1, 2)) / np.max(np.abs(Gd), axis=(1, 2)) <= ev.last_error + rd + idd)


@settings(derandomize=True, max_examples=15, deadline=None)
@given(seed=st.integers(0, 10_000), n_blocks=st.integers(3, 20), m=st.integers(1, 2), p=st.integers(1, 2),
       rigid=st.booleans())
def test_block_schur_reevaluation_agrees_with_dense_solves(seed, n_blocks, m, p, rigid):
    # an impossible tolerance sends every point to the block-wise Schur solves
    sys = block_system(seed, n_blocks, m, p, rigid=rigid)
    ev = TransferEvaluator(sys, rtol=1e-30)
    s = check_points(sys)
    G, est = ev.modal.stable(s)
    err = assert_bounded(G, est, sys, s)
    assert np.max(err) < 1e-9
    ev.at(s)
    assert "schur" in ev.label


def test_block_modal_speaks_for_iss12a_at_round_off():
    from tests.mor import MOR_DIR, load_mor

    if not MOR_DIR.exists():
        pytest.skip("benchmark models not available")
    sys = load_mor("ISS12A.mat")
    ev = TransferEvaluator(sys)
    assert isinstance(ev.modal, _BlockModal) and ev.modal.n_blocks == 706
    omega = np.array([0.3, 12.0])  # two dense 1412-state solves as the reference
    fr = frequency_response(sys, omega)
    ref = np.array([sys.C @ np.linalg.solve(1j * w * np.eye(sys.n_states) - sys.A, sys.B) for w in omega])
    err = np.max(np.abs(fr.response - ref), axis=(1, 2)) / np.max(np.abs(ref), axis=(1, 2))
    assert np.max(err) <= fr.error_estimate < 1e-9


def dense_system(seed, n, m, p, cond):
    """Stable modes in random coordinates of condition ``cond``: a dense, non-normal A."""
    rng = np.random.default_rng(seed)
    k = n // 2
    w = np.exp(rng.uniform(np.log(0.1), np.log(100.0), k))
    z = np.exp(rng.uniform(np.log(1e-3), np.log(0.7), k))
    J = scipy.linalg.block_diag(*[np.array([[-zi * wi, wi], [-wi, -zi * wi]]) for wi, zi in zip(w, z)],
                                *([np.array([[-1.0]])] if n % 2 else []))
    Q, _ = np.linalg.qr(rng.normal(size=(n, n)))
    T = Q * np.exp(rng.uniform(0, np.log(cond), n))[None, :]
    return LinearSystem(T @ J @ np.linalg.inv(T), rng.normal(size=(n, m)), rng.normal(size=(p, n)))


@settings(derandomize=True, max_examples=12, deadline=None)
@given(seed=st.integers(0, 10_000), n=st.integers(4, 60), m=st.integers(1, 3), p=st.integers(1, 3),
       cond=st.sampled_from([1.0, 10.0, 1e3]))
def test_residual_checked_modal_values_are_bounded(seed, n, m, p, cond):
    sys = dense_system(seed, n, m, p, cond)
    modal = _Modal(sys)
    s = check_points(sys)
    checked = modal.residual_checked(s, chunk=7)  # several chunks
    assert checked is not None
    G, est = checked
    err = assert_bounded(G, est, sys, s)
    assert np.max(err) < 1e-8
    # the residual bound is never looser than the modal estimate by more than the rounding it adds
    Gm, r, i = modal.evaluate(s)
    assert np.all(np.max(np.abs(G - Gm), axis=(1, 2)) / np.max(np.abs(Gm), axis=(1, 2)) <= est + r + i)


@settings(derandomize=True, max_examples=10, deadline=None)
@given(seed=st.integers(0, 10_000), n=st.integers(20, 80))
def test_auto_on_dense_systems_reports_a_bound(seed, n):
    # the automatic path (modal, points re-checked by residual where the rounding dominates)
    sys = dense_system(seed, n, 2, 2, 10.0)
    ev = TransferEvaluator(sys)
    s = check_points(sys, extra=np.logspace(3, 5, 5))
    G = ev.at(s)
    assert_bounded(G, ev.last_error, sys, s)
    assert "schur" not in ev.label and "hessenberg" not in ev.label

"""Structured loops with hub states (issue 20, target 7): a controller in series with a modal plant.

``block_components`` finds the hub states coupled one way to the blocks, ``_BlockModal``
decouples them (Sylvester equation diagonal in the blocks' eigenvectors), and
``frequency/_modal_roots.py`` finds the roots of ``c + G(s)`` from that form by the Aberth
iteration. References, all independent of the structured code: one dense complex solve
``numpy.linalg.solve(s I - A, B)`` per point (with its own backward-stable bound,
``_direct_eval``), the dense pencil zeros (``_invariant_zeros``) and ``numpy.linalg.eigvals`` of
the closed-loop matrix.
"""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from linflex import LinearSystem
from linflex.frequency import root_locus
from linflex.frequency._evaluate import TransferEvaluator
from linflex.frequency._modal_forms import _BlockModal, block_components
from linflex.frequency._modal_roots import modal_roots
from linflex.frequency._zeros import _invariant_zeros
from tests.frequency.test_structured import assert_bounded, block_system, check_points
from tests.hard.corpus import flexible_pd_loop


def hub_system(seed, n_blocks, r, m, p, *, feeds=False, rigid=False):
    """The blocks of ``block_system`` and ``r`` stable hub states driven by every block state
    (``feeds=False``: ``A = [[A_b, 0], [A_hb, A_h]]``) or driving them (``feeds=True``), the
    hub states at random places among the others; B and C dense."""
    body = block_system(seed, n_blocks, m, p, rigid=rigid)
    rng = np.random.default_rng(seed + 1)
    nb = body.n_states
    n = nb + r
    H = rng.normal(size=(r, r))
    H -= (np.max(np.linalg.eigvals(H).real) + rng.uniform(1.0, 5.0)) * np.eye(r)
    A = np.zeros((n, n))
    A[:nb, :nb] = body.A
    A[nb:, nb:] = H
    coupling = rng.normal(size=(r, nb))
    if feeds:
        A[:nb, nb:] = coupling.T
    else:
        A[nb:, :nb] = coupling
    B = np.vstack([body.B, rng.normal(size=(r, m))])
    C = np.hstack([body.C, rng.normal(size=(p, r))])
    perm = rng.permutation(n)
    return LinearSystem(A[np.ix_(perm, perm)], B[perm], C[:, perm]), perm


def closest(a, b):
    """Largest distance from an entry of ``a`` to the nearest entry of ``b``, relative to max(1, |b|)."""
    if not a.size:
        return 0.0
    d = np.abs(a[:, None] - b[None, :])
    j = np.argmin(d, axis=1)
    return float(np.max(d[np.arange(a.size), j] / np.maximum(1.0, np.abs(b[j]))))


def test_block_components_finds_a_one_way_hub_and_rejects_a_closed_loop():
    sys, perm = hub_system(3, 12, 2, 1, 1)
    n_blocks, label, hub = block_components(sys.A)
    states, feeds = hub
    assert not feeds and sorted(states) == sorted(np.flatnonzero(perm >= sys.n_states - 2))
    up, _ = hub_system(3, 12, 2, 1, 1, feeds=True)
    assert block_components(up.A)[2][1] is True
    # a two-way coupling (the closed loop A - B C of a hub loop) moves the eigenvalues: no structure
    L = flexible_pd_loop(41)
    assert block_components(L.A)[2] is not None
    assert block_components(L.A - L.B @ L.C) is None


@settings(derandomize=True, max_examples=15, deadline=None)
@given(seed=st.integers(0, 10_000), n_blocks=st.integers(6, 30), r=st.integers(1, 3), m=st.integers(1, 2),
       p=st.integers(1, 2), feeds=st.booleans(), rigid=st.booleans())
def test_hub_modal_form_and_its_reevaluation_agree_with_dense_solves(seed, n_blocks, r, m, p, feeds, rigid):
    sys, _ = hub_system(seed, n_blocks, r, m, p, feeds=feeds, rigid=rigid)
    ev = TransferEvaluator(sys)
    assert isinstance(ev.modal, _BlockModal) and ev.modal._hub is not None
    assert ev.modal.k == r + (2 if rigid else 0)
    s = check_points(sys)
    G = ev.at(s)
    err = assert_bounded(G, ev.last_error, sys, s)
    assert np.max(err) < 1e-8
    # the backward-stable path through the blocks and the hub (forward substitution)
    Gs, est = ev.modal.stable(s)
    err = assert_bounded(Gs, est, sys, s)
    assert np.max(err) < 1e-8
    # the poles: the blocks' and the hub's eigenvalues, within their estimates of numpy's
    ref = np.linalg.eigvals(sys.A)
    assert closest(ev.modal.poles, ref) < 1e-8 and closest(ref, ev.modal.poles) < 1e-8


@settings(derandomize=True, max_examples=12, deadline=None)
@given(seed=st.integers(0, 10_000), n_blocks=st.integers(6, 25), r=st.integers(1, 2), feeds=st.booleans(),
       k=st.sampled_from([0.1, 1.0, 10.0]))
def test_aberth_roots_equal_the_pencil_zeros_and_the_closed_loop_poles(seed, n_blocks, r, feeds, k):
    sys, _ = hub_system(seed, n_blocks, r, 1, 1, feeds=feeds)
    modal = TransferEvaluator(sys).modal
    z = modal_roots(modal, sys, 0.0)
    ref = _invariant_zeros(sys.A, sys.B, sys.C, sys.D)
    assert z.size == ref.size == sys.n_states - 1       # relative degree 1 (C B != 0)
    assert closest(z, ref) < 1e-7 and closest(ref, z) < 1e-7
    poles = modal_roots(modal, sys, 1.0 / k)             # roots of 1 + k G: eig(A - k B C)
    ref = np.linalg.eigvals(sys.A - k * sys.B @ sys.C)
    assert poles.size == sys.n_states
    assert closest(poles, ref) < 1e-7 and closest(ref, poles) < 1e-7


def test_growth_loop_is_structured_and_exact():
    # the benchmark's loop (issue 20, target 7): a rigid body, 99 modes and a PD filter state fed
    # by every plant position; relative degree 2, so n - 2 zeros
    L = flexible_pd_loop(201)
    ev = TransferEvaluator(L)
    assert isinstance(ev.modal, _BlockModal) and ev.modal.k == 3       # rigid body + the filter
    z = modal_roots(ev.modal, L, 0.0)
    ref = _invariant_zeros(L.A, L.B, L.C, L.D)
    assert z.size == ref.size == 199
    assert closest(z, ref) < 1e-9 and closest(ref, z) < 1e-9
    lam = np.linalg.eigvals(L.A)
    w = np.r_[np.logspace(-2, 3, 20), lam.imag[lam.imag > 0]]
    s = 1j * w
    G = ev.at(s)
    err = assert_bounded(G, ev.last_error, L, s)
    assert np.max(err) < 1e-9


def test_root_locus_of_the_growth_loop_needs_no_dense_eigenproblem():
    L = flexible_pd_loop(101)
    gains = np.geomspace(1e-3, 1e2, 40)
    rl = root_locus(L, gains=gains)
    scale = max(1.0, float(np.max(np.abs(rl.roots))))
    for i in range(0, 40, 6):
        ref = np.linalg.eigvals(L.A - gains[i] * L.B @ L.C)
        d = np.abs(rl.roots[i][:, None] - ref[None, :]).min(axis=1)
        # numpy's eigenvalues carry n eps ||A_cl|| cond themselves: 1e-9 of the spectral scale
        assert np.all(d <= rl.error_estimate[i] + 1e-9 * scale), gains[i]
    # the same locus from the loop in dense coordinates (no structure): the same roots
    Q, _ = np.linalg.qr(np.random.default_rng(0).normal(size=(101, 101)))
    dense = LinearSystem(Q.T @ L.A @ Q, Q.T @ L.B, L.C @ Q, L.D)
    rd = root_locus(dense, gains=gains)
    for i in range(0, 40, 6):
        d = np.abs(rl.roots[i][:, None] - rd.roots[i][None, :]).min(axis=1)
        assert np.all(d <= rl.error_estimate[i] + rd.error_estimate[i] + 1e-9 * scale)


@pytest.mark.parametrize("order", [101, 401])
def test_structured_zeros_place_the_same_grid_as_the_pencil(order):
    # the automatic grid with the zeros from the Aberth iteration (the structured form passed)
    # against the same grid policy fed with the dense pencil's zeros: the same points
    from linflex.frequency import frequency_grid

    L = flexible_pd_loop(order)
    ev = TransferEvaluator(L)
    w_structured = frequency_grid(L, _poles=ev.poles, _modal=ev.modal)
    w_pencil = frequency_grid(L, _poles=ev.poles)
    assert w_structured.size == w_pencil.size
    assert np.allclose(w_structured, w_pencil, rtol=1e-9, atol=0)

"""Root locus (frequency/_locus.py)."""

import control
import numpy as np
import pytest
from scipy.optimize import linear_sum_assignment

from linflex import LinearSystem, ModelError, ShapeError
from linflex.frequency import Loop, root_locus

from .conftest import flexible_modal, two_mass


def tf(num, den):
    return LinearSystem.from_control(control.ss(control.tf(num, den)))


def same_set(a, b):
    cost = np.abs(np.asarray(a)[:, None] - np.asarray(b)[None, :])
    r, c = linear_sum_assignment(cost)
    return float(np.max(cost[r, c]))


def test_textbook_third_order():
    # K/(s(s+1)(s+2)) (e.g. Ogata, Modern Control Engineering, root-locus example):
    # breakaway at s = -1 + 1/sqrt(3) = -0.4226 with K = 2/(3 sqrt 3) = 0.3849;
    # imaginary-axis crossing at w = sqrt(2) with K = 6 (Routh).
    L = tf([1], np.polymul([1, 1, 0], [1, 2]))
    rl = root_locus(L)
    assert rl.breakaway_points.real == pytest.approx([-1 + 1 / np.sqrt(3)], abs=1e-9)
    assert rl.breakaway_gains == pytest.approx([2 / (3 * np.sqrt(3))], rel=1e-9)
    assert rl.gains[0] == 0.0 and np.all(np.diff(rl.gains) > 0)
    # the breakaway gain is in the sequence, exactly
    assert np.min(np.abs(rl.gains - 2 / (3 * np.sqrt(3)))) < 1e-12
    # the crossing: the largest real part changes sign between consecutive gains bracketing K = 6
    re = rl.roots.real.max(axis=1)
    i = int(np.argmax(re > 0))
    assert rl.gains[i - 1] <= 6.0 <= rl.gains[i]
    # at the crossing gain the closed loop has eigenvalues +-j sqrt(2) (independent eig)
    at6 = root_locus(L, gains=[6.0]).roots[0]
    assert np.min(np.abs(at6 - 1j * np.sqrt(2))) < 1e-9
    # branches start at the open-loop poles and are continuous (displacement bound honoured)
    assert same_set(rl.roots[0], [0, -1, -2]) < 1e-12
    assert rl.max_step_displacement <= 0.25 + 1e-12
    # three asymptotes at +-60 deg and 180 deg from the centroid -1 (closed form)
    far = rl.roots[-1]
    ang = np.sort(np.degrees(np.angle(far + 1)))
    assert ang == pytest.approx([-60, 60, 180], abs=1.0)


def test_roots_equal_eigenvalues_at_each_gain():
    # notes 14.5: roots of the locus = eig(A - k b c) (independent numpy eig) at every gain
    L = tf([1, 3], np.polymul([1, 1, 0], [1, 4, 20]))
    rl = root_locus(L)
    for k, row in list(zip(rl.gains, rl.roots))[:: max(1, len(rl.gains) // 25)]:
        ref = np.linalg.eigvals(L.A - k * L.B @ L.C)
        assert same_set(row, ref) < 1e-7 * max(1, np.max(np.abs(ref)))


def test_branches_are_continuous_through_breakaway():
    L = tf([1], [1, 3, 2])   # 1/((s+1)(s+2)): breakaway at -1.5, K = 0.25 (closed form)
    rl = root_locus(L)
    assert rl.breakaway_points.real == pytest.approx([-1.5], abs=1e-9)
    assert rl.breakaway_gains == pytest.approx([0.25], rel=1e-9)
    after = rl.roots[rl.gains > 0.3]
    # after breakaway both branches have real part -1.5 (closed form: s = -1.5 +- j sqrt(K - 0.25))
    assert after.real == pytest.approx(np.full_like(after.real, -1.5), abs=1e-9)
    # one branch stays in the upper half plane (matching did not swap the conjugates)
    assert np.all(np.sign(after[:, 0].imag) == np.sign(after[0, 0].imag))


def test_negative_gain_complementary_locus():
    # 1/(s(s+1)) with k < 0: one root goes right along the real axis: s^2 + s + k = 0
    L = tf([1], [1, 1, 0])
    rl = root_locus(L, negative=True)
    assert np.all(rl.gains <= 0)
    k = rl.gains[-1]
    ref = np.roots([1, 1, k])  # order 2: the closed form
    assert same_set(rl.roots[-1], ref) < 1e-9 * max(1, np.max(np.abs(ref)))


def test_given_gains_and_loop_input():
    K = LinearSystem([[-10.0]], [[1.0]], [[-300.0]], [[32.0]], inputs=["e"], outputs=["u"])
    loop = Loop(two_mass(), K, sensors="x1", actuators="F1")
    gains = [0.0, 0.5, 1.0, 2.0]
    rl = root_locus(loop, gains=gains)
    assert rl.gains.tolist() == gains
    L = loop.open_loop()
    for k, row in zip(gains, rl.roots):
        ref = np.linalg.eigvals(L.A - k * L.B @ np.linalg.solve(np.eye(1) + k * L.D, L.C))
        assert same_set(row, ref) < 1e-8


def test_order_400_flexible_loop():
    # flexible spacecraft loop of order 402 (rigid body + 200 modes, zeta 1e-3), collocated
    # rate+position feedback: eigenvalues at the reported gains equal the direct eig
    P = flexible_modal(200, 1e-3, seed=8, rigid=True)
    L = P.with_(C=P.C + 0.5 * np.roll(P.C, 1, axis=1))
    rl = root_locus(L, gains=[0.0, 1e-3, 3e-3])
    assert rl.roots.shape == (3, 402)
    for k, row in zip(rl.gains, rl.roots):
        ref = np.linalg.eigvals(L.A - k * L.B @ L.C)
        assert same_set(row, ref) < 1e-8 * max(1, np.max(np.abs(ref)))


def test_validation():
    L = tf([1], [1, 1, 0])
    with pytest.raises(ShapeError, match="1-D"):
        root_locus(L, gains=[[1.0, 2.0]])
    with pytest.raises(ShapeError, match="not finite"):
        root_locus(L, gains=[1.0, np.inf])
    with pytest.raises(ModelError, match="square"):
        root_locus(LinearSystem(-np.eye(2), np.ones((2, 2)), np.ones((1, 2))))
    with pytest.raises(ModelError, match="max_displacement"):
        root_locus(L, max_displacement=2.0)


def test_continuation_agrees_with_dense_eigenvalues_on_flexible_loop():
    # order 61 flexible loop (rigid body + 29 modes, zeta 1e-3, collocated PD with a filter):
    # the Newton continuation path and the dense-eig path are independent algorithms
    P = flexible_modal(29, 1e-3, seed=6, rigid=True)
    K = LinearSystem([[-50.0]], [[1.0]], [[-1250.0]], [[25.2]])
    L = Loop(P.with_(inputs=["u"], outputs=["y"]), K.with_(inputs=["e"], outputs=["v"]),
             sensors="y", actuators="u").open_loop()
    gains = np.r_[0.0, np.logspace(-3, 1, 80)]
    fast = root_locus(L, gains=gains)
    slow = root_locus(L, gains=gains, continuation=False)
    assert fast.n_continuation_steps > 50 and slow.n_continuation_steps == 0
    scale = max(1.0, float(np.max(np.abs(slow.roots))))
    for a, b, k in zip(fast.roots, slow.roots, gains):
        assert same_set(a, b) < 1e-9 * scale, k
        # and both equal numpy's eigenvalues of the closed-loop matrix (third, independent check)
        ref = np.linalg.eigvals(L.A - k * L.B @ np.linalg.solve(np.eye(1) + k * L.D, L.C))
        assert same_set(a, ref) < 1e-9 * scale
    # branches are continuous: consecutive roots of each branch move less than the spacing bound
    assert fast.max_step_displacement <= 0.25 + 1e-12


def test_mimo_loop_scalar_gain():
    # 2x2 loop, scalar gain on both channels: dense-eig path (no SISO continuation); roots equal
    # numpy's eigenvalues of A - k B (I + k D)^-1 C at every reported gain
    rng = np.random.default_rng(4)
    n = 8
    L = LinearSystem(rng.normal(size=(n, n)) - 2 * np.eye(n), rng.normal(size=(n, 2)), rng.normal(size=(2, n)),
                     0.1 * rng.normal(size=(2, 2)))
    rl = root_locus(L, k_max=5.0)
    assert rl.n_continuation_steps == 0 and rl.breakaway_points.size == 0
    assert rl.gains[-1] == pytest.approx(5.0)
    for k, row in list(zip(rl.gains, rl.roots))[:: max(1, len(rl.gains) // 20)]:
        ref = np.linalg.eigvals(L.A - k * L.B @ np.linalg.solve(np.eye(2) + k * L.D, L.C))
        assert same_set(row, ref) < 1e-9 * max(1, np.max(np.abs(ref)))


def test_repeated_roots_do_not_stall_the_automatic_sequence():
    # two identical axes (append(G, G), G = 1/(s(s+1)(s+2))): every closed-loop root is double.
    # Reported by the stability report (commit 88b7460): the automatic sequence stalled because
    # coincident roots were counted as each other's nearest neighbours.
    G = control.ss(control.tf([1], np.polymul([1, 1, 0], [1, 2])))
    L = LinearSystem.from_control(control.append(G, G))
    rl = root_locus(L, k_max=100.0)
    assert rl.gains[-1] == pytest.approx(100.0)
    assert rl.n_eigenvalue_solves < 1000
    for k, row in list(zip(rl.gains, rl.roots))[:: max(1, len(rl.gains) // 20)]:
        # each root of the SISO locus (numpy eig of the 3x3 closed loop), twice
        single = np.linalg.eigvals(LinearSystem.from_control(G).A - k * np.outer(G.B[:, 0], G.C[0]))
        assert same_set(row, np.r_[single, single]) < 1e-6 * max(1, np.max(np.abs(single)))
    # the crossing of the imaginary axis at K = 6 (Routh) is still bracketed
    re = rl.roots.real.max(axis=1)
    i = int(np.argmax(re > 1e-9))
    assert rl.gains[i - 1] <= 6.0 + 1e-9 and rl.gains[i] >= 6.0 - 1e-9


def test_continuation_through_breakaway_and_break_in():
    # (s + 2)/(s (s + 1)): the real roots 0 and -1 break away at s = -2 + sqrt 2 (K = 3 - 2 sqrt 2)
    # and the conjugate pair breaks in at s = -2 - sqrt 2 (K = 3 + 2 sqrt 2), both closed form
    # (dK/ds = 0 of K = -s (s + 1)/(s + 2)). Given gains across both: the continuation tracks
    # the conjugate pair as one root, approaches and leaves each breakaway by hidden substeps.
    L = tf([1, 2], [1, 1, 0])
    gains = np.r_[0.0, np.logspace(-3, 2, 300)]
    rl = root_locus(L, gains=gains)
    assert np.sort(rl.breakaway_points.real) == pytest.approx([-2 - np.sqrt(2), -2 + np.sqrt(2)], abs=1e-9)
    assert np.sort(rl.breakaway_gains) == pytest.approx([3 - 2 * np.sqrt(2), 3 + 2 * np.sqrt(2)], rel=1e-9)
    # dense solves only at the start from the open loop and at the two crossings (plus margin)
    assert rl.n_continuation_steps > 290 and rl.n_eigenvalue_solves <= 8
    for k, row in zip(gains, rl.roots):
        ref = np.roots([1, 1 + k, 2 * k])  # s^2 + (1 + k) s + 2k = 0, order 2: the closed form
        # a root next to a double root is sensitive like sqrt(eps): 1e-7 covers the gains
        # nearest the breakaways, 1e-12 holds elsewhere
        tol = 1e-7 if np.min(np.abs(k - rl.breakaway_gains)) < 1e-2 else 1e-12
        assert same_set(row, ref) < tol * max(1, np.max(np.abs(ref))), k
        # the set is closed under conjugation (a real loop)
        assert same_set(row, np.conj(row)) < tol * max(1, np.max(np.abs(ref)))
    assert rl.max_step_displacement <= 0.25 + 1e-12
    # between the two breakaways the branches are one conjugate pair: each branch stays in its
    # half plane (no swap of the conjugates by the matching)
    mid = rl.roots[(rl.gains > 0.3) & (rl.gains < 5.0)]
    assert np.all(np.sign(mid[:, 0].imag) == np.sign(mid[0, 0].imag))


def test_flexible_loop_with_breakaways_matches_dense_eigenvalues():
    # flexible loop of order 41 (rigid body + 19 modes, zeta 1e-3, collocated PD with a filter)
    # at 400 gains: the batched continuation, the conjugate-pair tracking and the breakaway
    # substeps all run; every row equals numpy's eigenvalues of the closed loop (independent)
    P = flexible_modal(19, 1e-3, seed=3, rigid=True)
    K = LinearSystem([[-50.0]], [[1.0]], [[-1250.0]], [[25.2]])
    L = Loop(P.with_(inputs=["u"], outputs=["y"]), K.with_(inputs=["e"], outputs=["v"]),
             sensors="y", actuators="u").open_loop()
    gains = np.r_[0.0, np.logspace(-3, 2, 399)]
    rl = root_locus(L, gains=gains)
    assert rl.breakaway_gains.size >= 1 and np.any((rl.breakaway_gains > 1e-3) & (rl.breakaway_gains < 1e2))
    assert rl.n_continuation_steps >= 390 and rl.n_eigenvalue_solves <= 20
    for k, row in zip(gains, rl.roots):
        ref = np.linalg.eigvals(L.A - k * L.B @ np.linalg.solve(np.eye(1) + k * L.D, L.C))
        scale = max(1.0, float(np.max(np.abs(ref))))
        # 1e-9 of the spectral scale: eig's own backward error is ~1e-15 |A - k b c|; the
        # tolerance leaves room for the sqrt(eps) sensitivity next to a double root
        assert same_set(row, ref) < 1e-9 * scale, k
    assert rl.max_step_displacement <= 0.25 + 1e-12
    # the batched continuation agrees with the dense-eig path to round-off (branch by branch)
    slow = root_locus(L, gains=gains[::20], continuation=False)
    for a, b in zip(rl.roots[::20], slow.roots):
        assert same_set(a, b) < 1e-9 * max(1.0, float(np.max(np.abs(b))))


def test_newton_step_rejects_two_iterates_on_one_root():
    # the checks of a continuation step are not relaxed by the batch: a row whose guesses put
    # two iterates on one root fails (distinct roots), the other rows pass
    from linflex.frequency._locus import _NewtonTracker

    L = tf([1, 3], np.polymul([1, 1, 0], [1, 4, 20]))
    tr = _NewtonTracker(L)
    ks = np.array([0.5, 0.6])
    good = [np.linalg.eigvals(L.A - k * L.B @ L.C) for k in ks]
    R0 = np.array([good[0] * (1 + 1e-6), good[1]])
    R0[1, 1] = R0[1, 0]   # both iterates start at one root
    S, dS, spacing, coincident, ok = tr.step_many(R0, ks)
    assert ok.tolist() == [True, False]
    assert same_set(S[0], good[0]) < 1e-12 * max(1, np.max(np.abs(good[0])))
    # ds/dk is the branch tangent: compare with a central difference of the dense eigenvalues
    h = 1e-6
    plus = np.linalg.eigvals(L.A - (ks[0] + h) * L.B @ L.C)
    minus = np.linalg.eigvals(L.A - (ks[0] - h) * L.B @ L.C)
    # second central difference with its own step 1e-4 (truncation ~1e-8, round-off
    # eps |s| / h^2 ~ 1e-7 of a unit curvature)
    h2 = 1e-4
    p2, m2, mid = (np.linalg.eigvals(L.A - k * L.B @ L.C) for k in (ks[0] + h2, ks[0] - h2, ks[0]))
    for s, (d, d2) in zip(S[0], dS[0]):
        fd = (plus[np.argmin(np.abs(plus - s))] - minus[np.argmin(np.abs(minus - s))]) / (2 * h)
        assert abs(d - fd) < 1e-5 * max(1.0, abs(fd))
        # and d2s/dk2 (for the quintic predictor)
        sp, sm, s0 = (r[np.argmin(np.abs(r - s))] for r in (p2, m2, mid))
        fd2 = (sp - 2 * s0 + sm) / (h2 * h2)
        assert abs(d2 - fd2) < 1e-5 * max(1.0, abs(fd2))


def test_breakaway_found_locally_without_the_pencil():
    # breakaway=False (the default above 200 states): no pencil, the continuation locates the
    # double roots itself (Newton on L'(s) = 0 next to the roots that jumped) and still avoids
    # the bisection with dense solves; the roots equal the closed form at every gain, and the
    # located breakaways are reported: s = -2 -+ sqrt 2 at K = 3 -+ 2 sqrt 2 (closed form)
    L = tf([1, 2], [1, 1, 0])
    gains = np.r_[0.0, np.logspace(-3, 2, 300)]
    rl = root_locus(L, gains=gains, breakaway=False)
    assert np.sort(rl.breakaway_points.real) == pytest.approx([-2 - np.sqrt(2), -2 + np.sqrt(2)], abs=1e-9)
    assert np.sort(rl.breakaway_gains) == pytest.approx([3 - 2 * np.sqrt(2), 3 + 2 * np.sqrt(2)], rel=1e-9)
    assert rl.n_eigenvalue_solves <= 10
    for k, row in zip(gains, rl.roots):
        ref = np.roots([1, 1 + k, 2 * k])   # s^2 + (1 + k) s + 2k = 0: closed form
        tol = 1e-7 if min(abs(k - 3 + 2 * np.sqrt(2)), abs(k - 3 - 2 * np.sqrt(2))) < 1e-2 else 1e-12
        assert same_set(row, ref) < tol * max(1, np.max(np.abs(ref))), k
    assert rl.max_step_displacement <= 0.25 + 1e-12
    # L'' of the modal evaluator (used by that Newton) against a central difference of L'
    from linflex.frequency._locus import _NewtonTracker

    P = flexible_modal(6, 1e-2, seed=2, rigid=True)   # with the defective rigid-body block
    tr = _NewtonTracker(P)
    s = np.array([0.3 + 1.1j, -2.0 + 0.1j])
    h = 1e-6
    d1, d2 = tr.derivatives(s)
    fd = (tr.derivatives(s + h)[0] - tr.derivatives(s - h)[0]) / (2 * h)
    assert np.max(np.abs(d2 - fd) / np.abs(d2)) < 1e-6
    assert np.max(np.abs(d1 - tr.values(s)[1]) / np.abs(d1)) < 1e-12

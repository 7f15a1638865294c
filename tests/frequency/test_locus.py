"""Root locus (frequency/_locus.py and its modules frequency/_locus_*.py)."""

import control
import numpy as np
import pytest
from scipy.optimize import linear_sum_assignment

from linflex import LinearSystem, ModelError, ShapeError
from linflex.frequency import Loop, root_locus

from ..hard.corpus import flexible_pd_loop as benchmark_loop
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
    assert rl.n_evaluations < 1000
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
    assert rl.n_continuation_steps > 290 and rl.n_evaluations <= 8
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
    assert rl.n_continuation_steps >= 390 and rl.n_evaluations <= 20
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
    from linflex.frequency._locus_tracker import _NewtonTracker

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
    assert rl.n_evaluations <= 10
    for k, row in zip(gains, rl.roots):
        ref = np.roots([1, 1 + k, 2 * k])   # s^2 + (1 + k) s + 2k = 0: closed form
        tol = 1e-7 if min(abs(k - 3 + 2 * np.sqrt(2)), abs(k - 3 - 2 * np.sqrt(2))) < 1e-2 else 1e-12
        assert same_set(row, ref) < tol * max(1, np.max(np.abs(ref))), k
    assert rl.max_step_displacement <= 0.25 + 1e-12
    # L'' of the modal evaluator (used by that Newton) against a central difference of L'
    from linflex.frequency._locus_tracker import _NewtonTracker

    P = flexible_modal(6, 1e-2, seed=2, rigid=True)   # with the defective rigid-body block
    tr = _NewtonTracker(P)
    s = np.array([0.3 + 1.1j, -2.0 + 0.1j])
    h = 1e-6
    d1, d2 = tr.derivatives(s)
    fd = (tr.derivatives(s + h)[0] - tr.derivatives(s - h)[0]) / (2 * h)
    assert np.max(np.abs(d2 - fd) / np.abs(d2)) < 1e-6
    assert np.max(np.abs(d1 - tr.values(s)[1]) / np.abs(d1)) < 1e-12


def eig_closed_loop(L, k):
    return np.linalg.eigvals(L.A - k * L.B @ np.linalg.solve(np.eye(L.n_inputs) + k * L.D, L.C))


def test_gain_exactly_on_a_breakaway_does_not_hang():
    # regression (commit f98d07b): a requested gain equal to a known breakaway gain made the
    # substeps propose the same gain forever. (s + 2)/(s (s + 1)): breakaways at
    # K = 3 -+ 2 sqrt 2 (closed form, dK/ds = 0 of K = -s (s + 1)/(s + 2)), both in the gains,
    # exactly as the pencil gives them, with the pencil (known from the start) and without
    # (located by the continuation)
    L = tf([1, 2], [1, 1, 0])
    k_b = root_locus(L, breakaway=True).breakaway_gains
    gains = np.sort(np.r_[0.0, np.logspace(-2, 1.5, 40), k_b])
    for breakaway in (True, False):
        rl = root_locus(L, gains=gains, breakaway=breakaway, max_steps=400)
        # a loop would exhaust max_steps; 40 gains take well under 200 steps
        assert rl.n_evaluations + rl.n_continuation_steps < 200
        assert rl.gains.tolist() == gains.tolist()
        for k, row in zip(gains, rl.roots):
            ref = np.roots([1, 1 + k, 2 * k])   # s^2 + (1 + k) s + 2k = 0, closed form
            # at a double root the roots are sensitive like sqrt(eps): 1e-7
            assert same_set(row, ref) < 1e-7 * max(1, np.max(np.abs(ref))), k


def test_feedthrough_loop_with_a_root_through_infinity():
    # a random loop of order 30 with feedthrough d = -5.09: at k = -1/d = 0.196 the loop is
    # ill-posed and one root passes through infinity. Before, the continuation failed at most
    # gains near it and every failure cost a bisection with dense solves (about 140 dense
    # solves and 1.3-2x the time of the older tracker); now that root is exempt from the
    # displacement test near k = -1/d (the others keep their identities) and guessed from the
    # trace, and repeated failures hand over to dense solves for a while
    rng = np.random.default_rng(0)
    n = 30
    L = LinearSystem(rng.normal(size=(n, n)), rng.normal(size=(n, 1)), rng.normal(size=(1, n)),
                     [[2 * rng.normal()]])
    assert L.D[0, 0] == pytest.approx(-5.0918, abs=1e-4)
    gains = np.r_[0.0, np.logspace(-2, 1.5, 200)]
    rl = root_locus(L, gains=gains)
    assert rl.n_evaluations <= 20 and rl.n_rejected_continuation_steps <= 30
    assert rl.max_step_displacement <= 0.25 + 1e-12
    for k, row in zip(gains, rl.roots):
        ref = eig_closed_loop(L, k)
        # against numpy's eig (independent): round-off of the largest root, which near
        # k = -1/d is huge (eig's own error is eps times the norm of the closed-loop matrix)
        assert same_set(row, ref) < 1e-10 * max(1, np.max(np.abs(ref))), k
    # the branch of the largest root just below k = -1/d continues through infinity: real,
    # from the far left half plane to the right half plane at the next gain
    i = int(np.searchsorted(gains, -1 / L.D[0, 0]))
    b = int(np.argmax(np.abs(rl.roots[i - 1])))
    before, after = rl.roots[i - 1, b], rl.roots[i, b]
    assert before.real < -20 and after.real > 5 and abs(before.imag) + abs(after.imag) < 1e-9


def test_benchmark_loop_without_dense_solves():
    # the order-101 loop of the benchmark at its 500 gains: one dense eigendecomposition (the
    # modal form's, which gives the open-loop poles), none in the tracking. Issue 6 found one
    # unexplained fallback at k = 0.199: an avoided crossing of two roots between the modes at
    # 0.971 and 0.988 rad/s (they pass within 0.008 while moving 0.01 per gain), where the
    # predictor put both iterates into one root's basin; the step is now retried from half the
    # step before a dense solve. The two breakaways (k = 0.6156, 1.3049) are located by the
    # continuation and crossed by it.
    L = benchmark_loop(101)
    gains = np.r_[0.0, np.logspace(-3, 2, 499)]
    rl = root_locus(L, gains=gains)
    assert rl.n_evaluations == 1 and rl.n_continuation_steps >= 499
    assert rl.breakaway_gains == pytest.approx([0.615612, 1.304927], rel=1e-5)
    assert rl.max_step_displacement <= 0.25 + 1e-12
    scale = max(1.0, float(np.max(np.abs(rl.roots))))
    near = np.flatnonzero((gains > 0.19) & (gains < 0.21))
    for i in np.r_[near, np.arange(0, 500, 25)]:
        # against numpy's eig at the gains around the avoided crossing and every 25th: 1e-12
        # of the spectral scale (the continuation converges to round-off)
        assert same_set(rl.roots[i], eig_closed_loop(L, gains[i])) < 1e-12 * scale, gains[i]


def test_siso_zeros_equal_the_pencil_reduction():
    # the standard eigenproblem of the zero dynamics (_siso_zeros) against the Emami-Naeini /
    # Van Dooren pencil reduction (_invariant_zeros) at relative degree 0 (d != 0) to 3, on
    # random systems of order 12: equal sets to 1e-11 of the largest zero
    from linflex.frequency._locus import _siso_zeros
    from linflex.frequency._zeros import _invariant_zeros

    rng = np.random.default_rng(11)
    for rho in range(4):
        for _ in range(3):
            n = 12
            A, b, c = rng.normal(size=(n, n)), rng.normal(size=(n, 1)), rng.normal(size=(1, n))
            if rho > 1:
                K = np.hstack([np.linalg.matrix_power(A, j) @ b for j in range(rho - 1)])
                c = c - (c @ K) @ np.linalg.pinv(K)   # c A^j b = 0 for j < rho - 1
            L = LinearSystem(A, b, c, [[0.0 if rho else 1.3]])
            ref = _invariant_zeros(L.A, L.B, L.C, L.D)
            got = _siso_zeros(L)
            assert len(got) == len(ref) == n - rho   # n - (relative degree) finite zeros
            assert same_set(got, ref) < 1e-11 * max(1.0, float(np.max(np.abs(ref))))


def test_modal_evaluation_with_folded_rigid_body_block():
    # the rigid-body double pole of the modal form folded into partial fractions (simple poles
    # in the Cauchy sums, 1/s^2 as an extra term): L and its first three derivatives against
    # dense solves and central differences, on a loop with a rigid body, 12 modes and a filter
    from linflex.frequency._locus_tracker import _NewtonTracker

    L = benchmark_loop(29)
    tr = _NewtonTracker(L)
    assert tr.k_block == 0 and len(tr._multi) == 1   # the double pole at 0, folded
    s = np.array([0.3 + 1.1j, -2.0 + 0.1j, 0.02 + 0.5j, 7j])
    vals = tr.values(s, third=True)
    ref = np.array([(L.C @ np.linalg.solve(x * np.eye(L.n_states) - L.A, L.B))[0, 0] for x in s])
    assert np.max(np.abs(vals[0] - ref) / np.abs(ref)) < 1e-12     # round-off of the sums
    h = 1e-5
    for j in (1, 2, 3):
        # central difference of the (j-1)-th derivative: truncation h^2 ~ 1e-10 relative
        fd = (tr.values(s + h, third=True)[j - 1] - tr.values(s - h, third=True)[j - 1]) / (2 * h)
        assert np.max(np.abs(vals[j] - fd) / np.abs(vals[j])) < 1e-6, j


def test_nearest_distances_of_conjugate_root_sets():
    # the nearest-root distances from the upper half plane only equal the brute force over
    # all roots (every root, random conjugate-closed sets with real roots)
    from linflex.frequency._locus_tracker import _nearest_conjugate, _nearest_many

    rng = np.random.default_rng(5)
    for _ in range(50):
        nu, ns = int(rng.integers(1, 6)), int(rng.integers(0, 4))
        up = rng.normal(size=(3, nu)) + 1j * np.abs(rng.normal(size=(3, nu)))
        Su = np.concatenate([up, rng.normal(size=(3, ns)) + 0j], axis=1)
        S = np.concatenate([Su, np.conj(up)], axis=1)
        same = np.full(3, 1e-9)
        got = _nearest_conjugate(Su, nu, same)
        ref = _nearest_many(S, same, np.arange(nu + ns))
        assert np.allclose(got[0], ref[0], rtol=1e-13) and np.allclose(got[1], ref[1], rtol=1e-13)


def _folded_reference(tr, s):
    """``L, L', L'', L'''`` from the complex partial fractions of the tracker's modal form (the
    Cauchy sums, as evaluated before the pairs were folded), with each foldable pair made
    exactly conjugate (mean of the two, as the fold does), plus the multiple-pole terms.

    Also the scale of its round-off, per derivative j: ``j! sum_i |r_i| / |s - lambda_i|^(j+1)``
    times ``1 + (j + 1) (|s| + |lambda_i|) / |s - lambda_i|`` (a relative perturbation eps of
    every pole, at the distance ``|s - lambda|``, is what computing ``q(s)`` costs)."""
    from math import factorial

    from linflex.frequency._locus_sums import _cauchy_sums

    lam, r = tr.lam.copy(), tr.r.copy()
    for i in np.flatnonzero((lam.imag > 0) & (lam.imag >= np.abs(lam.real))):
        j = int(np.argmin(np.abs(lam - np.conj(lam[i]))))
        lam[i], r[i] = 0.5 * (lam[i] + np.conj(lam[j])), 0.5 * (r[i] + np.conj(r[j]))
        lam[j], r[j] = np.conj(lam[i]), np.conj(r[i])
    real = (np.abs(lam.imag) <= 1e-12 * np.abs(lam)) & (np.abs(r.imag) <= 1e-10 * np.abs(r))
    lam[real], r[real] = lam[real].real, r[real].real
    ref = _cauchy_sums(s, lam, r, 3)
    ref[0] += tr.d
    dist = np.abs(s[:, None] - lam[None, :])
    scale = np.array([factorial(j) * (np.abs(r) / dist ** (j + 1) * (1 + (j + 1) * (np.abs(s)[:, None] + np.abs(lam)) / dist)).sum(axis=1)
                      for j in range(4)])
    for mu, _, mats in tr._multi:
        wp = 1.0 / (s - mu)
        w = wp.copy()
        for row in mats[3]:
            wp = wp * w
            ref += row[:, None] * wp
            scale += np.abs(row)[:, None] * np.abs(wp) * (1 + 4 * (np.abs(s) + abs(mu)) * np.abs(w))
    return ref, scale


@pytest.mark.parametrize("case", ["benchmark", "mixed"])
def test_folded_conjugate_pairs_match_partial_fractions(case):
    # the modal sums evaluated per conjugate pair as real second-order terms (one complex
    # reciprocal per pair, real coefficients) against the complex partial fractions (the
    # Cauchy sums) and, away from the poles, against dense solves C (sI - A)^-1 B + D.
    # "mixed": lightly damped modes, a zeta = 0.9 pair (better damped than 1/sqrt 2: kept in
    # the complex sums), real poles and a feedthrough; "benchmark": the benchmark's loop with
    # the rigid-body double pole folded into the real terms
    from linflex.frequency._locus_tracker import _NewtonTracker

    if case == "benchmark":
        L = benchmark_loop(29)
    else:
        P = flexible_modal(5, 0.02, seed=3)
        F = control.tf([1.0, 1.0], np.polymul([1.0, 5.0], [1.0, 2 * 0.9 * 3.0, 9.0])) + 0.1
        F = F * control.tf([49.0], [1.0, 2 * 0.7 * 7.0, 49.0])   # zeta 0.7: folded
        L = LinearSystem.from_control(control.ss(F * P.to_control() + 0.05))
    tr = _NewtonTracker(L)
    # folded terms: 13 pairs, the filter pole and the rigid body's simple pole at 0 (with its
    # 1/s^2 term); 6 pairs and the pole at -5, with the zeta = 0.9 pair left complex
    n_rest = 2 if case == "mixed" else 0
    assert (tr._nf, len(tr._lam_rest)) == ((15, 0) if case == "benchmark" else (7, 2))
    rng = np.random.default_rng(7)
    scale = max(1.0, float(np.max(np.abs(tr.lam))))
    s_far = rng.uniform(-1.2, 0.2, 200) * scale + 1j * rng.uniform(-1.2, 1.2, 200) * scale
    near = tr.lam[rng.integers(0, len(tr.lam), 300)]
    rel = np.repeat([1e-2, 1e-5, 1e-8], 100)
    s_near = near + rel * np.maximum(1.0, np.abs(near)) * np.exp(2j * np.pi * rng.uniform(size=300))
    s = np.r_[s_far, s_near, rng.uniform(-60, 0, 20)]
    vals = tr.values(s, third=True)
    ref, sc = _folded_reference(tr, s)
    # 8 eps of the round-off scale (measured below 1 eps on both loops, near the poles too,
    # where the value differs relatively by ~eps |lambda| / |s - lambda|: 1e-8 at 1e-8)
    assert np.max(np.abs(vals - ref) / sc) < 8 * np.finfo(float).eps
    # a few points at a time (one stacked product instead of one per power of w): the same
    few = np.concatenate([tr.values(s[i:i + 3], third=True) for i in range(0, len(s), 3)], axis=1)
    assert np.max(np.abs(few - ref) / sc) < 8 * np.finfo(float).eps
    assert np.max(np.abs(few[:2, :3] - tr.values(s[:3])) / sc[:2, :3]) < 8 * np.finfo(float).eps
    # and in chunks of 7 points (the work arrays hold more)
    tr._fchunk = 7
    assert np.max(np.abs(tr.values(s, third=True) - ref) / sc) < 8 * np.finfo(float).eps
    # L and L' (those of the Cauchy sums before) agree relatively at 1e-13 away from the poles
    far = np.abs(vals[:, :200] - ref[:, :200]) / np.abs(ref[:, :200])
    assert np.max(far[:2]) < 1e-13
    # and L against dense solves, at points 1e-2 and further from every pole
    x = s[np.min(np.abs(s[:, None] - tr.lam[None, :]), axis=1) > 1e-2 * np.maximum(1.0, np.abs(s))][:40]
    dense = np.array([(L.C @ np.linalg.solve(xi * np.eye(L.n_states) - L.A, L.B) + L.D)[0, 0] for xi in x])
    got = tr.values(x)[0]
    assert np.max(np.abs(got - dense) / np.abs(dense)) < 1e-11   # modal form: cond(V) eps
    # the conjugate of a point gives the conjugate values (the folded terms are real)
    if not n_rest:
        assert np.max(np.abs(tr.values(np.conj(s), third=True) - np.conj(vals)) / sc) < 4 * np.finfo(float).eps


@pytest.mark.parametrize("zeta", [1e-6, 1e-3, 0.1, 0.7])
def test_folded_single_pair_against_extended_precision(zeta):
    # one mode (w0 = 3 rad/s) with residues of every phase: the folded pair term and its
    # first three derivatives against the partial fractions r/(s - lambda)^(j+1) + conj in
    # long double (80-bit on x86; plain double elsewhere, still below the tolerance), at points
    # from 1e-2 to 1e2 |lambda| in every direction, on the real axis and 1e-6 from the pole
    from math import factorial

    from linflex.frequency._locus_tracker import _NewtonTracker

    w0 = 3.0
    rng = np.random.default_rng(11)
    s = (rng.uniform(-4, 4, 3000) + 1j * rng.uniform(-4, 4, 3000)) * w0 * np.exp(rng.uniform(-5, 5, 3000))
    for phase in np.linspace(0.0, 2 * np.pi, 9)[:-1]:
        c = [np.cos(phase), np.sin(phase) / w0]
        L = LinearSystem([[0.0, 1.0], [-w0**2, -2 * zeta * w0]], [[0.0], [1.0]], [c])
        tr = _NewtonTracker(L)
        assert tr._nf == 1 and len(tr._lam_rest) == 0
        lam = tr.lam[np.argmax(tr.lam.imag)]
        r = tr.r[np.argmax(tr.lam.imag)]
        x = np.r_[s, lam + 1e-6 * w0 * np.exp(2j * np.pi * rng.uniform(size=50)), np.linspace(-30.0, 30.0, 61)]
        vals = tr.values(x, third=True)   # one stacked product (few terms)
        tr._fsmall = 0
        vals_pp = tr.values(x, third=True)   # one product per power of w
        xl, ll, rl = x.astype(np.clongdouble), np.clongdouble(lam), np.clongdouble(r)
        d1, d2 = np.abs(x - lam), np.abs(x - np.conj(lam))
        for j in range(4):
            ref = (-1) ** j * factorial(j) * (rl / (xl - ll) ** (j + 1) + np.conj(rl) / (xl - np.conj(ll)) ** (j + 1))
            # round-off scale: the two terms' magnitudes, each with the sensitivity to a
            # relative perturbation eps of the pole (what rounding q costs)
            sc = factorial(j) * abs(r) * (1 / d1 ** (j + 1) + 1 / d2 ** (j + 1)) * (1 + (j + 1) * (np.abs(x) + abs(lam)) / np.minimum(d1, d2))
            for v in (vals, vals_pp):
                err = np.abs(v[j] - ref.astype(complex)) / sc
                # 16 eps: measured up to 8 eps (third derivative, 1e-3 damping), 1-2 eps for L
                assert np.max(err) < 16 * np.finfo(float).eps, (phase, j, np.max(err) / np.finfo(float).eps)


def test_roots_polished_at_high_gain_and_bounded_by_their_estimate():
    # issue 16 (property corpus): a rigid body, an unstable pair and five modes under PD (kd =
    # 9.99, roll-off 0.0597 s) behind a random similarity of condition up to 30, gain 1.17e6 *
    # 0.2154: ||A - k b c|| is 1e3 times ||A||, and the dense eigenvalues of the closed-loop
    # matrix are 1.6e-7 relative off (its norm times their condition). Reference: every simple
    # root refined by Newton's method on 1 + k L(s) with extended-precision residuals
    # (tests/hard/loops.py refined_roots, its own error ~1e-13 relative). The locus polishes
    # (Newton on det(I + k G) with G from the Schur form of A) to 1e-9 relative, within its
    # error_estimate.
    from ..hard.loops import assemble, refined_roots, scale_output, similarity

    def mode(w, z, g):
        return ("mode", w, z, 2, np.array([g]), np.ones(1))

    parts = [("rigid", 0.0, 0.0, 2, np.ones(1), np.ones(1)), mode(0.48, -0.126, 1.0), mode(10.2, 0.0, 0.56),
             mode(1.0, 0.26, -0.43), mode(31.6, 0.04, -0.8), mode(10.8, 0.009, 0.4), mode(420, 0.43, -0.3)]
    L = scale_output(similarity(assemble(parts, m=1, kp=1.0, kd=9.99, tau=0.0597, dp=0.0),
                                np.random.default_rng(0)), 1.17e6)
    k = 0.2154
    lam = np.linalg.eigvals(L.A - k * L.B @ L.C)
    truth, ok, ref_err = refined_roots(L, k, lam)
    assert np.count_nonzero(ok) >= 13
    scale = np.maximum(1.0, np.abs(truth))
    assert np.max(np.abs(lam - truth)[ok] / scale[ok]) > 1e-8   # what a dense solve gives
    rl = root_locus(L, [k])
    got, est = rl.roots[0], rl.error_estimate[0]
    D = np.abs(truth[:, None] - got[None, :])
    r, c = linear_sum_assignment(D)
    err = D[r, c]
    assert np.all((err / scale[r])[ok[r]] <= 1e-9)
    assert np.all((err <= est[c] + ref_err[r])[ok[r]])
    assert np.all(np.isfinite(est)) and np.all(est > 0)

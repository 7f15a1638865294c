"""Root locus on every proper loop (issue 16): first order, integrator chains, unstable poles,
PID with roll-off, zeros at the origin, feedthrough, rigid bodies under PD; each against a
closed form, and random loops against the dense eigenvalues of the closed loop."""

from pathlib import Path

import control
import numpy as np
import pytest
import scipy.linalg
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.optimize import linear_sum_assignment

from linflex import LinearSystem, LinflexError, ModelError
from linflex.cli import main
from linflex.frequency import root_locus

EPS = np.finfo(float).eps


def tf(num, den):
    return LinearSystem.from_control(control.ss(control.tf(num, den)))


def same_set(a, b):
    cost = np.abs(np.asarray(a)[:, None] - np.asarray(b)[None, :])
    r, c = linear_sum_assignment(cost)
    return float(np.max(cost[r, c]))


GAINS = np.r_[0.0, np.logspace(-3, 3, 61)]


def check_closed_form(L, roots_of, tol, gains=GAINS):
    """Every row of the locus at ``gains`` (and of the automatic sequence) equals the closed
    form ``roots_of(k)`` to ``tol`` times ``max(1, |roots|)``, plus what the eigenvalues of
    the realization can hold (:func:`reference_tolerances`: a multiple pole, such as the open
    loop's at k = 0, is determined only to about ``eps^(1/m)``)."""
    b, c, d = L.B[:, 0], L.C[0], float(L.D[0, 0])
    for rl in (root_locus(L, gains=gains), root_locus(L)):
        assert rl.roots.shape == (len(rl.gains), L.n_states)
        assert np.all(np.isfinite(rl.roots))
        for k, row in zip(rl.gains, rl.roots):
            ref = np.asarray(roots_of(k), dtype=complex)
            M = L.A - k * np.outer(b, c) / (1.0 + k * d)
            held = np.max(reference_tolerances(M, 1 + (1 + abs(k * d)) / abs(1 + k * d))[1])
            assert same_set(row, ref) <= tol * max(1.0, float(np.max(np.abs(ref)))) + held, k
    return rl


def test_first_order_loop():
    # the reproducer of issue 16 (empty breakaway candidates crashed the evaluator):
    # L = 1/(s + 1), closed form s = -1 - k
    check_closed_form(LinearSystem([[-1.0]], [[1.0]], [[1.0]]), lambda k: [-1.0 - k], 1e-13)


@pytest.mark.parametrize("num, den, roots_of", [
    ([1], [1, 0], lambda k: [-k]),                      # 1/s
    ([1], [1, -1], lambda k: [1 - k]),                  # 1/(s - 1), unstable
    ([1, 2], [1, 1], lambda k: [-(1 + 2 * k) / (1 + k)]),   # 1 + 1/(s + 1): feedthrough d = 1
])
def test_first_order_forms(num, den, roots_of):
    # closed forms of (s - p) + k n(s) = 0
    check_closed_form(tf(num, den), roots_of, 1e-13)


def quadratic(a, b, c):
    """Roots of a s^2 + b s + c (closed form, both signs of the discriminant)."""
    disc = np.sqrt(complex(b * b - 4 * a * c))
    return [(-b + disc) / (2 * a), (-b - disc) / (2 * a)]


@pytest.mark.parametrize("num, den, roots_of", [
    ([1], [1, 0, 0], lambda k: quadratic(1, 0, k)),                 # 1/s^2: +-j sqrt(k)
    ([1, 1], [1, 0, 0], lambda k: quadratic(1, k, k)),              # (s + 1)/s^2
    ([1], [1, 2, 1], lambda k: quadratic(1, 2, 1 + k)),             # 1/(s + 1)^2
    ([40, 25], [100, 0, 0], lambda k: quadratic(100, 40 * k, 25 * k)),   # rigid body under PD
    ([1, 0], [1, 3, 2], lambda k: quadratic(1, 3 + k, 2)),          # zero at the origin
    ([1], [1, 1, -2], lambda k: quadratic(1, 1, k - 2)),            # 1/((s - 1)(s + 2))
])
def test_second_order_forms(num, den, roots_of):
    # double poles (no separable modal form: issue 16 raised a private exception), unstable
    # poles and a zero at the origin, against the closed form of den + k num = 0; near a
    # double root the roots are sensitive like sqrt(eps): 1e-7
    check_closed_form(tf(num, den), roots_of, 1e-7)


@pytest.mark.parametrize("order", [3, 6, 10])
def test_integrator_chain(order):
    # 1/s^n: s^n = -k, the n-th roots of -k (closed form), n up to 10 (issue 16)
    L = tf([1], [1] + [0] * order)

    def roots_of(k):
        return abs(k) ** (1 / order) * np.exp(1j * (np.pi * (k > 0) + 2 * np.pi * np.arange(order)) / order)

    # n roots on a circle of radius k^(1/n), well separated (for k > 0): round-off of the
    # companion matrix, 1e-10 of the radius at k = 1e3
    rl = check_closed_form(L, roots_of, 1e-10, gains=np.logspace(-3, 3, 41))
    assert np.all(rl.open_loop_poles == 0)


def test_pid_with_roll_off_on_a_double_integrator():
    # C(s) = kp + ki/s + kd s/(tf s + 1) on 1/s^2 (issue 16): den + k num = 0 with
    # num = (kp s + ki)(tf s + 1) + kd s^2, den = s^3 (tf s + 1); the reference is numpy's
    # companion-matrix roots of that quartic (well separated away from the breakaways)
    kp, ki, kd, tf_ = 3.0, 0.5, 2.0, 0.05
    C = control.tf([kp], [1]) + control.tf([ki], [1, 0]) + control.tf([kd, 0], [tf_, 1])
    L = LinearSystem.from_control(control.ss(C * control.tf([1], [1, 0, 0])))
    num = np.polyadd(np.polymul([kp, ki], [tf_, 1]), [kd, 0, 0])
    den = np.polymul([1, 0, 0, 0], [tf_, 1])
    check_closed_form(L, lambda k: np.roots(np.polyadd(den, k * num)), 1e-7)


def test_automatic_sequence_passes_through_the_breakaways():
    # the pencil's breakaway gains are put in the automatic sequence (before, a gain step
    # that failed the displacement test dropped the next breakaway gain for good); 1/(s (s + 2)):
    # breakaway at s = -1, K = 1 (closed form: double root of s^2 + 2 s + K), where the row is
    # the double root to sqrt(eps)
    rl = root_locus(tf([1], [1, 2, 0]))
    assert rl.breakaway_gains.tolist() == pytest.approx([1.0], rel=1e-12)
    i = int(np.flatnonzero(rl.gains == rl.breakaway_gains[0])[0])
    assert np.max(np.abs(rl.roots[i] + 1.0)) < 1e-7


def test_ill_posed_gain_is_a_clear_error():
    # L = 1 + 1/(s + 1): 1 + k d = 0 at k = -1, where the closed loop does not exist; a
    # ModelError (a LinflexError) that names the gain and the reason
    L = tf([1, 2], [1, 1])
    with pytest.raises(ModelError, match="ill-posed at gain -1"):
        root_locus(L, gains=[-2.0, -1.0])
    assert issubclass(ModelError, LinflexError)
    with pytest.raises(ModelError, match="max_steps must be a positive integer, got 0"):
        root_locus(L, max_steps=0)


SCENE = """
name = "one_pd"
effects = ["control"]

[[bodies]]
name = "hub"
mass = 1500.0
inertia = [100.0, 120.0, 80.0]

[[joints]]
name = "attitude"
type = "spherical"
child = "hub"

[[sensors]]
name = "roll"
type = "attitude"
body = "hub"
axis = [1.0, 0.0, 0.0]

[[sensors]]
name = "p"
type = "rate"
body = "hub"
axis = [1.0, 0.0, 0.0]

[[actuators]]
name = "tx"
type = "torque"
body = "hub"
axis = [1.0, 0.0, 0.0]

[[controllers]]
name = "roll_pd"
type = "pid"
inputs = ["roll"]
rate_inputs = ["p"]
outputs = ["tx"]
reference = [0.05]
kp = [25.0]
kd = [70.0]
"""


def test_report_on_one_pd_channel(tmp_path: Path):
    # issue 16: `linflex report` on a hub with a spherical joint and one PD channel (a rigid
    # body double pole under PD: a loop with no separable modal form) exited with a traceback
    scene = tmp_path / "one_pd.toml"
    scene.write_text(SCENE)
    assert main(["report", str(scene), "-o", str(tmp_path / "out"), "--no-pdf"]) == 0
    html = (tmp_path / "out" / "report.html").read_text()
    assert html.count("data:image/png;base64,") >= 4 and "root locus" in html.lower()


# ----------------------------------------------------------------------------------------------
# Random proper loops against the dense eigenvalues of the closed loop


def reference_tolerances(M, cg, C=1e4):
    """numpy's eigenvalues of ``M`` (the reference) and a tolerance per eigenvalue.

    A backward-stable eigensolver returns the eigenvalues of ``M + E``, ``||E|| ~ eps ||M||``,
    and ``M`` itself carries the relative error ``eps cg`` of its gain factor ``k / (1 + k d)``
    (``cg = 1 + (1 + |k d|) / |1 + k d|``). An eigenvalue then moves by up to ``kappa eps cg
    ||M||`` (``kappa``: its condition number from the left and right eigenvectors); within a
    cluster whose disks of that radius overlap, the eigenvalues may exchange, so each gets the
    sum over its cluster. Near a multiple eigenvalue the computed ``kappa`` grows like
    ``eps^(1/m - 1)``, which turns the first-order bound into the Hoelder one, ``eps^(1/m)``.
    A cluster of ``m`` eigenvalues (a Jordan block) is also bounded by Hoelder's
    ``10 (C eps cg)^(1/m) ||M||``, which holds where ``kappa`` is infinite (an exact multiple
    eigenvalue). ``C = 1e4``: the continuation stops at a relative residual of about 1e-13
    (450 eps); the largest ratio measured over 200 random loops of this kind was 1.2e3."""
    ref = np.linalg.eigvals(M)
    lam, yl, xr = scipy.linalg.eig(M, left=True, right=True)
    with np.errstate(divide="ignore"):
        kappa = np.linalg.norm(yl, axis=0) * np.linalg.norm(xr, axis=0) / np.abs(np.sum(yl.conj() * xr, axis=0))
    kappa = np.minimum(kappa, 1e16)[np.argmin(np.abs(ref[:, None] - lam[None, :]), axis=1)]
    norm = max(np.linalg.norm(M, 2), 1.0)
    rad = C * EPS * cg * norm * kappa
    n = len(ref)
    label = np.arange(n)
    for _ in range(n):   # clusters: connected components of the overlapping disks
        for i in range(n):
            for j in range(n):
                if abs(ref[i] - ref[j]) <= rad[i] + rad[j]:
                    label[i] = label[j] = min(label[i], label[j])
    size = np.array([np.sum(label == label[i]) for i in range(n)])
    holder = 10.0 * (C * EPS * cg) ** (1.0 / size) * norm
    return ref, np.minimum([rad[label == label[i]].sum() for i in range(n)], holder)


@st.composite
def proper_loops(draw):
    """``(A, b, c, d)``: block-diagonal ``A`` of at most one integrator chain (1/s^m, m <= 10),
    real poles, lightly damped pairs and unstable real poles, order 1 to 12; random ``b, c``,
    ``d`` zero or not; ``A`` perturbed by 1e-16 (splits the chain's Jordan block) or not."""
    blocks = []
    n_target = draw(st.integers(1, 12))
    if draw(st.booleans()):
        m = draw(st.integers(1, min(10, n_target)))
        blocks.append(np.diag(np.ones(m - 1), 1))
    while sum(len(b) for b in blocks) < n_target:
        kind = draw(st.sampled_from(["real", "pair", "unstable"]))
        if kind == "pair" and sum(len(b) for b in blocks) + 2 <= 12:
            w = draw(st.floats(0.3, 50.0))
            zeta = draw(st.floats(1e-4, 0.1))
            blocks.append(np.array([[0.0, 1.0], [-w * w, -2 * zeta * w]]))
        else:
            p = draw(st.floats(0.1, 10.0))
            blocks.append(np.array([[p if kind == "unstable" else -p]]))
    A = scipy.linalg.block_diag(*blocks)
    n = len(A)
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    b, c = rng.normal(size=n), rng.normal(size=n)
    d = draw(st.sampled_from([0.0, rng.normal()]))
    if draw(st.booleans()):
        A = A + 1e-16 * rng.normal(size=A.shape)
    return A, b, c, d


@settings(derandomize=True, max_examples=40, deadline=None)
@given(loop=proper_loops(), exps=st.lists(st.floats(-3.0, 3.0), min_size=1, max_size=25),
       negative=st.booleans())
def test_random_proper_loops_against_dense_eigenvalues(loop, exps, negative):
    # every row of the locus equals numpy.linalg.eigvals(A - k b c / (1 + k d)) (the
    # reference, an independent dense computation) as sets, to the tolerance of
    # reference_tolerances (matched by linear assignment)
    A, b, c, d = loop
    gains = (-1.0 if negative else 1.0) * 10.0 ** np.array(exps)
    gains = gains[np.abs(1 + gains * d) > 1e-6]   # away from the ill-posed gain -1/d
    if not gains.size:
        return
    L = LinearSystem(A, b[:, None], c[None, :], [[d]])
    rl = root_locus(L, gains=gains)
    for k, row in zip(rl.gains, rl.roots):
        M = A - k * np.outer(b, c) / (1.0 + k * d)
        ref, tol = reference_tolerances(M, 1 + (1 + abs(k * d)) / abs(1 + k * d))
        cost = np.abs(row[:, None] - ref[None, :])
        r, j = linear_sum_assignment(cost)
        assert np.all(cost[r, j] <= tol[j]), (k, row, ref)


@settings(max_examples=25, deadline=None)
@given(k=st.floats(1e-3, 1e3), order=st.sampled_from([2, 3]))
def test_rigid_body_loop_gains_reach_the_loops_frequencies(k, order):
    """``k / s^n``: every pole at the origin, so the default gain range cannot come from the
    poles' modulus. The locus must reach the frequencies at which the loop acts (the unit-gain
    closed loop's, ``k^(1/n)`` rad/s), not a rounding-level neighbourhood of the origin (it
    stopped at a gain of 7e-9, roots of 8e-5 rad/s, for ``1 / s^2``), and its roots are the closed
    form ``s^n = -g k`` at every gain: ``+-j sqrt(g k)`` for the double integrator."""
    L = control.tf([k], [1.0] + [0.0] * order)
    r = root_locus(L)
    w_loop = k ** (1.0 / order)
    reach = float(np.max(np.abs(r.roots[-1])))
    assert 10 * w_loop <= reach <= 1e3 * w_loop
    expected = (r.gains[:, None] * k) ** (1.0 / order) * np.abs(np.exp(1j * np.pi * (2 * np.arange(order) + 1) / order))
    assert np.allclose(np.sort(np.abs(r.roots), axis=1), expected, rtol=1e-6, atol=1e-9 * w_loop)
    if order == 2:
        assert np.max(np.abs(r.roots.real)) <= 1e-9 * reach

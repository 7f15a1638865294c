"""Invariant zeros by the Householder reduction and one standard eigenvalue problem
(frequency/_zeros.py ``_invariant_zeros``), against SLICOT AB08ND (slycot, through
python-control), the generalized (QZ) path of the same reduction, and closed forms."""

import numpy as np
import pytest
import scipy.linalg
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.optimize import linear_sum_assignment

import linflex.frequency._zeros as zeros_module
from linflex import LinearSystem
from linflex.frequency import zeros

slycot = pytest.importorskip("slycot")


def matched(a, b) -> float:
    """Largest distance of optimally paired roots, relative to max(1, |root|)."""
    a, b = np.asarray(a, dtype=complex), np.asarray(b, dtype=complex)
    assert a.shape == b.shape, (a, b)
    if a.size == 0:
        return 0.0
    cost = np.abs(a[:, None] - b[None, :])
    r, c = linear_sum_assignment(cost)
    return float(np.max(cost[r, c] / np.maximum(1.0, np.abs(b[c]))))


def slicot_zeros(A, B, C, D):
    """Independent reference: SLICOT AB08ND's regular pencil and its generalized eigenvalues, as
    python-control's ``StateSpace.zeros`` uses it (called directly with a workspace that also
    fits systems with more inputs than states, which python-control's default does not)."""
    (n, m), p = B.shape, C.shape[0]
    out = slycot.ab08nd(n, m, p, A, B, C, D, ldwork=max(1, 8 * (n + m + p) ** 2))
    nu = out[0]
    return scipy.linalg.eigvals(out[8][:nu, :nu], out[9][:nu, :nu]) if nu else np.zeros(0, complex)


def random_system(seed, n, m, p, degree):
    """A random system of relative degree ``degree`` (exactly, no round-off): ``D != 0`` for
    degree 0; else ``D = 0`` and, for degree ``r >= 2``, states in blocks ``x_1 .. x_r`` of size
    ``m`` plus the rest ``x_0``, the output reading ``x_1`` only, the input driving ``x_r`` only,
    ``x_i`` (``i < r``) driven by ``x_1 .. x_(i+1)`` only and ``x_0`` driving ``x_r`` only: the
    zero pattern makes ``C A^j B = 0`` exactly for ``j < r - 1``; the states are then permuted."""
    rng = np.random.default_rng(seed)
    A, B, C = rng.normal(size=(n, n)), rng.normal(size=(n, m)), rng.normal(size=(p, n))
    if degree == 0:
        return A, B, C, rng.normal(size=(p, m))
    if degree > 1:
        block = np.repeat(np.arange(1, degree + 1), m).tolist() + [0] * (n - m * degree)
        block = np.array(block)
        for i in range(n):
            for j in range(n):
                bi, bj = block[i], block[j]
                if bi and bi < degree and (bj == 0 or bj > bi + 1):
                    A[i, j] = 0.0
        B[block != degree] = 0.0
        C[:, block != 1] = 0.0
        perm = rng.permutation(n)
        A, B, C = A[np.ix_(perm, perm)], B[perm], C[:, perm]
    return A, B, C, np.zeros((p, m))


@settings(derandomize=True, max_examples=80, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(1, 14), m=st.integers(1, 3), p=st.integers(1, 3),
       square=st.booleans(), degree=st.integers(0, 3))
def test_zeros_equal_slicot_and_the_qz_path(seed, n, m, p, square, degree):
    # square and non-square, relative degree 0 (D != 0) to 3: the same number of zeros as
    # AB08ND and the same values to 1e-9 of max(1, |z|) (round-off of well-conditioned random
    # systems is 1e-13; the margin covers zeros that approach each other); the QZ path of the
    # same reduction (the previous implementation's final step) agrees as well
    if square:
        p = m
    if degree > 1 and n <= m * degree:
        degree = 1
    A, B, C, D = random_system(seed, n, m, p, degree)
    got = zeros(LinearSystem(A, B, C, D))
    ref = slicot_zeros(A, B, C, D)
    assert len(got) == len(ref)
    assert matched(got, ref) < 1e-9
    saved = zeros_module._STANDARD_GROWTH
    try:
        zeros_module._STANDARD_GROWTH = -1.0   # always the generalized eigenvalue problem
        qz = zeros_module._invariant_zeros(A, B, C, D)
    finally:
        zeros_module._STANDARD_GROWTH = saved
    assert matched(got, qz) < 1e-9
    if square and degree and n >= m * degree:
        # a square system with C A^(r-1) B invertible has exactly n - m r finite zeros
        assert len(got) == n - m * degree


def companion(num, den):
    """Controllable canonical form of ``num(s) / den(s)`` (monic ``den``, ``deg num < deg den``)."""
    den = np.asarray(den, dtype=float)
    n = den.size - 1
    A = np.zeros((n, n))
    A[:-1, 1:] = np.eye(n - 1)
    A[-1] = -den[::-1][:-1]
    b = np.zeros((n, 1))
    b[-1] = 1.0
    c = np.zeros((1, n))
    num = np.asarray(num, dtype=float)
    c[0, :num.size] = num[::-1]
    return A, b, c


@pytest.mark.parametrize("degree", [0, 1, 2, 3])
def test_zeros_of_a_companion_form_are_the_chosen_roots(degree):
    # closed form: G(s) = prod(s - z_i) / prod(s - p_i) (degree >= 1), or
    # 2 prod(s - z_i) / prod(s - p_i) with as many zeros as poles (degree 0, D = 2)
    poles_ = [-0.5, -1.0 + 2.0j, -1.0 - 2.0j, -3.0, -4.0 + 1.0j, -4.0 - 1.0j]
    chosen = [0.7, -2.0 + 0.5j, -2.0 - 0.5j, -6.0, 1.5, -0.25][: 6 - degree]
    den, num = np.real(np.poly(poles_)), np.real(np.poly(chosen))
    if degree == 0:
        A, b, c = companion(2.0 * (num - den)[1:], den)
        d = [[2.0]]
    else:
        A, b, c = companion(num, den)
        d = [[0.0]]
    got = zeros(LinearSystem(A, b, c, d))
    # the polynomial coefficients are exact to round-off (integers and halves, order 6)
    assert matched(got, chosen) < 1e-10


def test_zeros_of_block_diagonal_and_tall_systems():
    # closed forms: a diagonal 2x2 transfer matrix has the union of its channels' zeros; a tall
    # system [G1; G2] over the same denominator has the zeros the two numerators share
    den = np.real(np.poly([-1.0, -2.0 + 1.0j, -2.0 - 1.0j, -5.0]))
    A1, b1, c1 = companion(np.real(np.poly([-3.0, 0.5])), den)
    A2, b2, c2 = companion(np.real(np.poly([-7.0])), den)
    diag = LinearSystem(scipy.linalg.block_diag(A1, A2), scipy.linalg.block_diag(b1, b2),
                        scipy.linalg.block_diag(c1, c2))
    assert matched(zeros(diag), [-3.0, 0.5, -7.0]) < 1e-10
    c_shared = companion(np.real(np.poly([-3.0, -4.0])), den)[2]
    tall = LinearSystem(A1, b1, np.vstack([c1, c_shared]))
    assert matched(zeros(tall), [-3.0]) < 1e-10
    wide = LinearSystem(A1.T, np.hstack([c1.T, c_shared.T]), b1.T)   # the dual: the same zero
    assert matched(zeros(wide), [-3.0]) < 1e-10


def test_the_standard_problem_is_used_unless_the_feedthrough_is_nearly_singular(monkeypatch):
    # the path choice is a measured property: on a well-scaled order-150 MIMO system of relative
    # degree 2 the QZ path is never called, while a nearly singular C B (1e-9 of ||C|| ||B||,
    # zeros escaping towards 1e9) makes A - B D^-1 C grow beyond 100 ||S|| and QZ is used;
    # both against AB08ND
    calls = []
    qz = zeros_module._finite_pencil_zeros
    monkeypatch.setattr(zeros_module, "_finite_pencil_zeros", lambda *a: calls.append(1) or qz(*a))
    A, B, C, D = random_system(7, 150, 2, 2, 2)
    A = A / np.sqrt(150)
    got = zeros(LinearSystem(A, B, C, D))
    assert not calls and len(got) == 146
    assert matched(got, slicot_zeros(A, B, C, D)) < 1e-9

    rng = np.random.default_rng(3)
    A, B, C, D = random_system(3, 12, 2, 2, 1)
    C = C - (C @ B) @ np.linalg.pinv(B) + 1e-9 * rng.normal(size=C.shape)
    got = zeros(LinearSystem(A, B, C, D))
    assert calls and len(got) == 10
    ref = slicot_zeros(A, B, C, D)
    # zeros of modulus up to ~1e9: relative accuracy eps * cond, both tools alike
    assert matched(got, ref) < 1e-5
    small = np.abs(ref) < 10
    assert matched(np.sort_complex(got[np.abs(got) < 10]), np.sort_complex(ref[small])) < 1e-7


@settings(derandomize=True, max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(1, 14), degree=st.integers(0, 3))
def test_loop_roots_equal_eigenvalues_and_slicot(seed, n, degree):
    # one Hessenberg form for a single loop: the closed-loop poles against numpy's eigenvalues of
    # A - b c / (1 + d) and the zeros against AB08ND, relative degree 0 (d != 0) to 3, to 1e-9 of
    # max(1, |root|) (round-off of these systems is 1e-13)
    if degree > 1 and n <= degree:
        degree = 1
    A, b, c, d = random_system(seed, n, 1, 1, degree)
    cl, z = zeros_module.loop_roots(A, b, c, d)
    assert matched(cl, np.linalg.eigvals(A - b @ c / (1.0 + d[0, 0]))) < 1e-9
    ref = slicot_zeros(A, b, c, d)
    assert len(z) == len(ref)
    assert matched(z, ref) < 1e-9
    if degree and n >= degree:
        assert len(z) == n - degree


def test_loop_roots_of_a_companion_loop_and_their_fallback(monkeypatch):
    # closed form: L = k num/den in companion form, closed-loop poles the roots of den + k num,
    # zeros the roots of num (relative degree 2); at order 150 (LAPACK's blocked Hessenberg
    # reduction) against numpy and the general reduction. A nearly vanishing Markov parameter
    # (c b = 1e-12 ||c|| ||b||) makes the last matrix grow: the general reduction is used instead
    poles_ = [-0.5, -1.0 + 2.0j, -1.0 - 2.0j, -3.0, -4.0 + 1.0j, -4.0 - 1.0j]
    chosen = [0.7, -2.0 + 0.5j, -2.0 - 0.5j, -6.0]
    den, num = np.real(np.poly(poles_)), np.real(np.poly(chosen))
    A, b, c = companion(3.0 * num, den)
    cl, z = zeros_module.loop_roots(A, b, c, np.zeros((1, 1)))
    assert matched(z, chosen) < 1e-10
    assert matched(cl, np.roots(np.polyadd(den, 3.0 * num))) < 1e-10

    calls = []
    general = zeros_module._invariant_zeros
    monkeypatch.setattr(zeros_module, "_invariant_zeros", lambda *a: calls.append(1) or general(*a))
    A, b, c, d = random_system(5, 150, 1, 1, 2)
    A = A / np.sqrt(150)
    cl, z = zeros_module.loop_roots(A, b, c, d)
    assert not calls and len(z) == 148
    assert matched(cl, np.linalg.eigvals(A - b @ c)) < 1e-9
    assert matched(z, general(A, b, c, d)) < 1e-9
    rng = np.random.default_rng(2)
    A, b, c, d = random_system(9, 12, 1, 1, 1)
    c = c - (c @ b) / (b.T @ b) * b.T + 1e-12 * np.linalg.norm(c) * rng.normal(size=c.shape) / np.sqrt(12)
    cl, z = zeros_module.loop_roots(A, b, c, d)
    assert calls
    assert matched(cl, np.linalg.eigvals(A - b @ c)) < 1e-9
    ref = slicot_zeros(A, b, c, d)
    assert len(z) == len(ref)
    small = np.abs(ref) < 10
    assert matched(np.sort_complex(z[np.abs(z) < 10]), np.sort_complex(ref[small])) < 1e-7


def test_hessenberg_eigenvalues_by_dhseqr_balanced_and_without_it(monkeypatch):
    # the eigenvalues of a Hessenberg matrix (LAPACK dhseqr from SciPy's cython_lapack, no
    # second reduction) against numpy's eig, for a well-scaled matrix, for a badly scaled one
    # (diagonal similarity spanning 1e-6..1e6: balanced first), and with dhseqr unavailable
    rng = np.random.default_rng(8)
    n = 60
    H = np.triu(rng.normal(size=(n, n)), -1)
    t = 10.0 ** np.linspace(-6, 6, n)
    bad = H * (1.0 / t)[:, None] * t[None, :]
    ref = np.linalg.eigvals(H)
    assert matched(zeros_module._hessenberg_eigvals(H, 1.0), ref) < 1e-12
    assert matched(zeros_module._hessenberg_eigvals(bad, 1.0), ref) < 1e-10
    monkeypatch.setattr(zeros_module, "_HSEQR", None)
    assert matched(zeros_module._hessenberg_eigvals(H, 1.0), ref) < 1e-12

"""Poles, zeros, root gain and Bode form (frequency/_zeros.py)."""

import numpy as np
import pytest
import scipy.linalg

from linflex import ConvergenceError, LinearSystem, ModelError
from linflex.frequency import bode_form, lambda_shift_zpk, poles, zeros, zpk

from .conftest import flexible_modal, two_mass


def match(a, b):
    """Max distance between two root sets after optimal pairing (independent of ordering)."""
    from scipy.optimize import linear_sum_assignment

    a, b = np.asarray(a), np.asarray(b)
    assert a.shape == b.shape, (a, b)
    if a.size == 0:
        return 0.0
    cost = np.abs(a[:, None] - b[None, :])
    r, c = linear_sum_assignment(cost)
    return float(np.max(cost[r, c]))


# Reference notes section 13, table and "Numbers for the test" (m1=2, m2=3, c=0.4, k=5).
Z_PAIR = [-0.0666667 + 1.2892720j, -0.0666667 - 1.2892720j]
TWO_MASS = {
    "v1": ([0.0] + Z_PAIR, 0.5, 1),
    "v2": ([0.0, -12.5], 0.0666667, 2),
    "x1": (Z_PAIR, 0.5, 2),
    "x2": ([-12.5], 0.0666667, 3),
}


@pytest.mark.parametrize("out", list(TWO_MASS))
def test_two_mass_zeros_and_root_gain(out):
    sys = two_mass()
    ref_z, ref_k, r = TWO_MASS[out]
    for result in (zpk(sys, output=out), lambda_shift_zpk(sys, output=out), lambda_shift_zpk(sys, output=out, lam=1.0)):
        # 7 significant digits are printed in the notes
        assert match(result.zeros, ref_z) < 1e-6
        assert result.gain == pytest.approx(ref_k, rel=1e-6)
        assert result.relative_degree == r
    # poles: 0, 0, -0.1666667 +- 2.0344259j (notes); the double pole at 0 splits to ~sqrt(eps)
    assert match(poles(sys), [0, 0, -0.1666667 + 2.0344259j, -0.1666667 - 2.0344259j]) < 1e-6


@pytest.mark.parametrize("out", list(TWO_MASS))
def test_root_gain_equals_first_markov_parameter(out):
    # independent: k_R = c A^(r-1) b (reference notes 7.3)
    sys = two_mass()
    z = zpk(sys, output=out)
    p = list(sys.outputs).index(out)
    markov = (np.linalg.matrix_power(sys.A, z.relative_degree - 1) @ sys.B)[p, 0]
    assert z.gain == pytest.approx(markov, rel=1e-12)


def test_non_null_pivot_matrix_gives_the_zeros_of_v1():
    # reference notes 7.2: A_red_ij = A_ij - b_i A_pj / b_p, i,j != p; eigenvalues 0, -0.0667 +- 1.2893j
    sys = two_mass()
    A, b = sys.A, sys.B[:, 0]
    keep = [1, 2, 3]
    A_red = A[np.ix_(keep, keep)] - np.outer(b[keep], A[0, keep]) / b[0]
    assert np.allclose(A_red, [[-0.1333333, 1.6666667, -1.6666667], [0, 0, 0], [1, 0, 0]], atol=1e-7)
    assert match(np.linalg.eigvals(A_red), zpk(sys, output="v1").zeros) < 1e-12


@pytest.mark.parametrize("out", ["v1", "x2"])
def test_numerator_rebuilt_equals_augmented_determinant(out):
    # reference notes 13 (ii): k_R prod(s - z) == det(sI - A with column p replaced by b)
    sys = two_mass()
    p = list(sys.outputs).index(out)
    z = zpk(sys, output=out)
    for s in (0.3 + 0.7j, -2.0 + 0.1j, 5j):
        M = s * np.eye(4) - sys.A
        M[:, p] = sys.B[:, 0]
        assert z.gain * np.prod(s - z.zeros) == pytest.approx(np.linalg.det(M), rel=1e-12)


def test_zeros_do_not_depend_on_lambda():
    sys = two_mass()
    ref = lambda_shift_zpk(sys, output="x1", lam=1.0)
    for lam in (0.5 + 2j, -3.0, 10 + 10j):
        other = lambda_shift_zpk(sys, output="x1", lam=lam)
        assert match(other.zeros, ref.zeros) < 1e-12
        assert other.gain == pytest.approx(ref.gain, rel=1e-12)


def test_bode_form_two_mass():
    # notes 13: k_B = 1/(m1 + m2) = 0.2 for all four; x: type 2, v: type 1;
    # |X1/F1|(j1) = 0.106758 at -174.699 deg, (j0.5) = 0.723550 at -179.742 deg
    sys = two_mass()
    for out, n_int in (("v1", 1), ("v2", 1), ("x1", 2), ("x2", 2)):
        bf = bode_form(sys, output=out)
        assert bf.gain == pytest.approx(0.2, rel=1e-9)
        assert bf.n_integrators == n_int
    bf = bode_form(sys, output="x1")
    assert bf.pole_frequencies == pytest.approx([2.0412415], rel=1e-7)
    assert bf.pole_damping == pytest.approx([0.0816497], rel=1e-6)
    assert bf.zero_frequencies == pytest.approx([1.2909944], rel=1e-7)
    assert bf.zero_damping == pytest.approx([0.0516398], rel=1e-6)
    for w, mag, deg in ((1.0, 0.106758, -174.699), (0.5, 0.723550, -179.742)):
        t = bf.evaluate(1j * w)
        assert abs(t) == pytest.approx(mag, rel=1e-5)
        assert np.degrees(np.angle(t)) == pytest.approx(deg, abs=1e-3)
        # independent: direct complex solve
        direct = (sys.C @ np.linalg.solve(1j * w * np.eye(4) - sys.A, sys.B))[2, 0]
        assert t == pytest.approx(direct, rel=1e-10)


def test_bode_form_time_constants():
    # closed form: 10 (s + 2) / ((s + 1)(s + 5)) = 4 (1 + 0.5 s) / ((1 + s)(1 + 0.2 s))
    sys = LinearSystem([[-1, 0], [0, -5]], [[1], [1]], [[10 * 1 / 4, 10 * 3 / 4]])
    bf = bode_form(sys)
    assert bf.gain == pytest.approx(4.0, rel=1e-12)
    assert bf.zero_time_constants == pytest.approx([0.5], rel=1e-12)
    assert np.sort(bf.pole_time_constants) == pytest.approx([0.2, 1.0], rel=1e-12)


def test_slicot_ab08nd_example():
    # SLICOT AB08ND documentation example: A = diag(1,1,3,-4,-1,3), 2 inputs, 3 outputs;
    # invariant zeros 2 and -1.
    A = np.diag([1.0, 1, 3, -4, -1, 3])
    B = np.array([[0, -1], [-1, 0], [1, -1], [0, 0], [0, 1], [-1, -1.0]])
    C = np.array([[1.0, 0, 0, 1, 0, 0], [0, 1, 0, 1, 0, 1], [0, 0, 1, 0, 0, 1]])
    z = zeros(LinearSystem(A, B, C))
    assert match(z, [2.0, -1.0]) < 1e-12


def test_tall_system_common_zero():
    # [ (s+1)/((s+2)(s+3)) ; (s+1)/((s+4)(s+5)) ]: transmission zero -1 only (closed form)
    A = np.diag([-2.0, -3, -4, -5])
    B = np.ones((4, 1))
    # partial fractions: (s+1)/((s+2)(s+3)) = -1/(s+2) + 2/(s+3); (s+1)/((s+4)(s+5)) = -3/(s+4) + 4/(s+5)
    C = np.array([[-1.0, 2, 0, 0], [0, 0, -3, 4]])
    sys = LinearSystem(A, B, C)
    z = zeros(sys)
    assert match(z, [-1.0]) < 1e-12
    # independent: the system matrix loses rank at s = -1 (smallest singular value)
    S = np.block([[A + np.eye(4), B], [C, np.zeros((2, 1))]])
    assert np.linalg.svd(S, compute_uv=False)[-1] < 1e-12
    # and its wide dual has the same zero
    dual = LinearSystem(A.T, C.T, B.T)
    assert match(zeros(dual), [-1.0]) < 1e-12


@pytest.mark.parametrize("seed", range(5))
def test_square_mimo_with_invertible_d(seed):
    # closed form: with D invertible, zeros = eig(A - B D^-1 C)
    rng = np.random.default_rng(seed)
    n, m = 7, 3
    A, B, C = rng.normal(size=(n, n)), rng.normal(size=(n, m)), rng.normal(size=(m, n))
    D = rng.normal(size=(m, m)) + 3 * np.eye(m)
    ref = np.linalg.eigvals(A - B @ np.linalg.solve(D, C))
    assert match(zeros(LinearSystem(A, B, C, D)), ref) < 1e-9 * max(1, np.max(np.abs(ref)))


@pytest.mark.parametrize("seed", range(5))
def test_square_mimo_strictly_proper(seed):
    # independent: at every computed zero the system matrix is rank deficient, and the count is
    # n - sum of relative degrees for CB invertible (n - m zeros)
    rng = np.random.default_rng(seed)
    n, m = 8, 2
    A, B, C = rng.normal(size=(n, n)), rng.normal(size=(n, m)), rng.normal(size=(m, n))
    z = zeros(LinearSystem(A, B, C))
    assert len(z) == n - m
    for s in z:
        S = np.block([[A - s * np.eye(n), B], [C, np.zeros((m, m))]])
        sv = np.linalg.svd(S, compute_uv=False)
        assert sv[-1] < 1e-10 * sv[0]


def test_generic_non_square_has_no_zeros():
    # a generic 1x2 system has no invariant zeros (normal rank 1, no rank drop)
    rng = np.random.default_rng(3)
    sys = LinearSystem(rng.normal(size=(5, 5)), rng.normal(size=(5, 2)), rng.normal(size=(1, 5)))
    assert zeros(sys).size == 0


def test_high_relative_degree_chain():
    # companion chain 1/(s+1)^6 written as a cascade: no finite zeros, relative degree 6, gain 1
    n = 6
    A = -np.eye(n) + np.diag(np.ones(n - 1), -1)
    B = np.zeros((n, 1))
    B[0, 0] = 1.0
    C = np.zeros((1, n))
    C[0, -1] = 1.0
    sys = LinearSystem(A, B, C)
    for z in (zpk(sys), lambda_shift_zpk(sys)):
        assert z.zeros.size == 0
        assert z.relative_degree == n
        assert z.gain == pytest.approx(1.0, rel=1e-9)


@pytest.mark.parametrize("zeta", [1e-2, 1e-4])
def test_order_200_lightly_damped_pencil_vs_lambda_shift(zeta):
    # collocated flexible structure, 100 modes, with a rigid-body double integrator: two
    # independent algorithms (pencil reduction and lambda-shift) agree on all zeros
    sys = flexible_modal(99, zeta, seed=1, rigid=True)
    a, b = zpk(sys), lambda_shift_zpk(sys)
    assert len(a.zeros) == len(b.zeros) == 198  # relative degree 2 (force to position)
    scale = np.max(np.abs(a.zeros))
    assert match(a.zeros, b.zeros) < 1e-8 * scale
    assert a.gain == pytest.approx(b.gain, rel=1e-8)
    # collocated: zeros are lightly damped and lie in the left half plane (interlacing)
    assert np.all(a.zeros.real < 1e-8 * scale)


def test_badly_scaled_states_do_not_change_zeros():
    # similarity with state scales 1e-6..1e6: invariant zeros unchanged (theory)
    sys = flexible_modal(10, 1e-3, seed=2, rigid=True, n_in=2, n_out=2)
    T = np.diag(np.logspace(-6, 6, sys.n_states))
    Ti = np.diag(1 / np.diag(T))
    scaled = LinearSystem(Ti @ sys.A @ T, Ti @ sys.B, sys.C @ T)
    za, zb = zeros(sys), zeros(scaled)
    assert len(za) == len(zb) == sys.n_states - 2 * 2
    assert match(za, zb) < 1e-8 * np.max(np.abs(za))


def test_control_statespace_accepted():
    import control

    z = zeros(control.ss([[-1, 0], [0, -2]], [[1], [1]], [[1, 1]], 0))
    assert match(z, [-1.5]) < 1e-12  # (2s + 3)/((s+1)(s+2)), closed form


def test_zpk_needs_a_channel_on_mimo():
    sys = two_mass()
    with pytest.raises(ModelError, match="4 outputs and 1 inputs"):
        zpk(sys)
    with pytest.raises(ModelError, match="unknown signal 'x3'"):
        zpk(sys, output="x3")
    with pytest.raises(ModelError, match="sys must be a LinearSystem"):
        poles(np.eye(2))


def test_zero_channel():
    # input does not reach the output: gain 0, no zeros
    sys = LinearSystem(np.diag([-1.0, -2.0]), [[1.0], [0.0]], [[0.0, 1.0]])
    assert zpk(sys).gain == 0.0
    assert lambda_shift_zpk(sys).gain == 0.0
    assert lambda_shift_zpk(sys).zeros.size == 0


def test_lambda_shift_singular_shift_refused():
    # lam = a pole of the bordered pencil... choose lam equal to the zero: M(lam) singular
    sys = LinearSystem([[-1, 0], [0, -2]], [[1], [1]], [[1, 1]])
    with pytest.raises(ConvergenceError, match="singular"):
        lambda_shift_zpk(sys, lam=-1.5)


def test_results_are_frozen():
    z = zpk(two_mass(), output="x1")
    with pytest.raises(AttributeError):
        z.gain = 1.0
    with pytest.raises(ValueError):
        z.zeros[0] = 0
    assert scipy.linalg.norm(z.poles) > 0

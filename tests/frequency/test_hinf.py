"""The H-infinity norm (``linflex.frequency.hinf_norm``): a value attained and an upper bound.

References: the closed-form peak ``1 / (2 zeta sqrt(1 - zeta^2))`` of a second-order mode and
``1 / (1 - |a|)`` of a discrete first-order lag; the Hamiltonian test (Bruinsma and Steinbuch
1990, an eigenvalue problem independent of the interval bounds) on random systems, dense,
block-modal and with a defective block; dense LU solves of ``jwI - A`` (numpy) at the peak.
"""

import math

import numpy as np
import pytest
import scipy.linalg
import scipy.signal
import scipy.sparse
from hypothesis import given, settings
from hypothesis import strategies as st

from linflex import LinearSystem, ModelError, ShapeError
from linflex.frequency import HinfNorm, hinf_norm
from tests.mor import load_mor, sparse_chain

RTOL = 1e-6


def sigma_at(sys, w):
    n = sys.n_states
    G = sys.C @ np.linalg.solve(1j * w * np.eye(n) - np.asarray(sys.A), sys.B) + sys.D
    return float(np.linalg.svd(G, compute_uv=False)[0])


def assert_brackets(res: HinfNorm, truth: float, rtol: float = RTOL):
    """``value <= truth <= upper`` (to rounding) and a certified bracket ``upper <= value (1 + 2 rtol)``."""
    assert res.certified, res
    assert res.value <= truth * (1 + 1e-9)
    assert truth <= res.upper * (1 + 1e-9)
    assert res.upper <= res.value * (1 + 2 * rtol)


@settings(max_examples=40, deadline=None)
@given(zeta=st.floats(1e-5, 0.5), wn=st.floats(1e-3, 1e3))
def test_second_order_peak_closed_form(zeta, wn):
    res = hinf_norm(([wn**2], [1.0, 2 * zeta * wn, wn**2]))
    truth = 1.0 / (2 * zeta * math.sqrt(1 - zeta**2))
    assert_brackets(res, truth)
    assert res.omega == pytest.approx(wn * math.sqrt(1 - 2 * zeta**2), rel=1e-2)
    assert "interval" in res.method


@st.composite
def stable_systems(draw):
    n = draw(st.integers(1, 8))
    p, m = draw(st.integers(1, 3)), draw(st.integers(1, 3))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    A = rng.standard_normal((n, n))
    A -= (np.linalg.eigvals(A).real.max() + 10 ** draw(st.floats(-4, 0))) * np.eye(n)
    D = rng.standard_normal((p, m)) if draw(st.booleans()) else np.zeros((p, m))
    return LinearSystem(A, rng.standard_normal((n, m)), rng.standard_normal((p, n)), D)


@settings(max_examples=60, deadline=None)
@given(sys=stable_systems())
def test_intervals_agree_with_the_hamiltonian_test(sys):
    a = hinf_norm(sys, method="interval")
    b = hinf_norm(sys, method="hamiltonian")
    assert a.certified and b.certified
    # two certified brackets of one number overlap
    assert a.value <= b.upper * (1 + 1e-9) and b.value <= a.upper * (1 + 1e-9)
    if math.isfinite(a.omega):
        assert sigma_at(sys, a.omega) == pytest.approx(a.value, rel=1e-8)


@st.composite
def block_modal_systems(draw):
    """Lightly damped modes as 2x2 blocks (some repeated frequencies), random MIMO B and C, and
    sometimes a hub state fed by every block."""
    k = draw(st.integers(2, 40))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    w = np.exp(rng.uniform(np.log(0.1), np.log(100.0), k))
    if k > 3:
        w[1] = w[0]
    zeta = 10 ** rng.uniform(-4, -1, k)
    A = scipy.linalg.block_diag(*[np.array([[0.0, 1.0], [-wi**2, -2 * z * wi]]) for wi, z in zip(w, zeta)])
    p, m = draw(st.integers(1, 3)), draw(st.integers(1, 3))
    B, C = rng.standard_normal((2 * k, m)), rng.standard_normal((p, 2 * k))
    if k > 8 and draw(st.booleans()):
        # a hub: a first-order filter fed by every block (a controller state after a modal plant)
        A = np.block([[A, np.zeros((2 * k, 1))], [rng.standard_normal((1, 2 * k)), np.array([[-3.0]])]])
        B, C = np.vstack([B, np.zeros((1, m))]), np.hstack([C, rng.standard_normal((p, 1))])
    return LinearSystem(A, B, C, np.zeros((p, m)))


@settings(max_examples=25, deadline=None)
@given(sys=block_modal_systems(), sparse=st.booleans())
def test_block_modal_form_agrees_with_the_hamiltonian_test(sys, sparse):
    given_sys = sys.with_(A=scipy.sparse.csr_matrix(sys.A)) if sparse else sys
    a = hinf_norm(given_sys)
    assert "block-modal" in a.method
    b = hinf_norm(sys, method="hamiltonian")
    assert a.certified and b.certified, (a, b)
    assert a.value <= b.upper * (1 + 1e-9) and b.value <= a.upper * (1 + 1e-9)


def test_defective_block_is_bounded_too():
    # a Jordan block of order 3 at -0.5 (split off from the modal form) beside two modes
    J = np.array([[-0.5, 1.0, 0.0], [0.0, -0.5, 1.0], [0.0, 0.0, -0.5]])
    M = scipy.linalg.block_diag(J, [[0.0, 1.0], [-4.0, -0.01]], [[0.0, 1.0], [-100.0, -0.2]])
    rng = np.random.default_rng(3)
    Q = np.linalg.qr(rng.standard_normal((7, 7)))[0]
    sys = LinearSystem(Q @ M @ Q.T, Q @ rng.standard_normal((7, 2)), rng.standard_normal((2, 7)) @ Q.T,
                       np.zeros((2, 2)))
    a = hinf_norm(sys, method="interval")
    b = hinf_norm(sys, method="hamiltonian")
    assert a.certified and b.certified
    assert a.value <= b.upper * (1 + 1e-9) and b.value <= a.upper * (1 + 1e-9)


def test_iss12a_sparse_equals_dense_and_the_peak_is_attained():
    dense = load_mor("ISS12A")
    sparse = load_mor("ISS12A", sparse=True)
    a, b = hinf_norm(dense), hinf_norm(sparse)
    assert a.certified and b.certified
    assert b.value == pytest.approx(a.value, rel=1e-12)
    assert "block-modal" in b.method
    # the value is a dense LU evaluation at its frequency
    assert sigma_at(dense, b.omega) == pytest.approx(b.value, rel=1e-9)
    # python-control's norm (slycot AB13DD) gives 0.01150062820009, 1.1e-8 below this attained value
    assert 0.01150062820009 <= b.value <= 0.01150062820009 * (1 + 1e-7)


def test_sparse_chain_without_blocks():
    A, B, C = sparse_chain(60)
    sys = LinearSystem(A, B, C, np.zeros((1, 1)))
    a = hinf_norm(sys)
    b = hinf_norm(LinearSystem(A.toarray(), B, C, np.zeros((1, 1))), method="hamiltonian")
    assert a.certified and b.certified
    assert a.value <= b.upper * (1 + 1e-9) and b.value <= a.upper * (1 + 1e-9)


def test_large_sparse_without_blocks_is_refused_clearly():
    A, B, C = sparse_chain(2001)     # 4002 states: its poles are not computed
    with pytest.raises(ModelError, match="hinf_norm.*SPARSE_POLES_MAX"):
        hinf_norm(LinearSystem(A, B, C, np.zeros((1, 1))))


@pytest.mark.parametrize("sys, why", [
    (([1.0], [1.0, 0.0, 0.0]), "double integrator"),
    (([1.0], [1.0, 0.0, 4.0]), "undamped mode"),
    (([1.0], [1.0, -1.0]), "unstable pole"),
    ((np.array([[1.5]]), np.eye(1), np.eye(1), np.zeros((1, 1)), 0.1), "unstable discrete"),
])
def test_not_in_h_infinity_is_infinite(sys, why):
    res = hinf_norm(sys)
    assert math.isinf(res.value) and math.isinf(res.upper), why
    assert "unstable" in res.method


@pytest.mark.parametrize("a, omega", [(0.9, 0.0), (-0.6, math.pi / 0.1)])
def test_discrete_first_order_lag(a, omega):
    # G(z) = 1 / (z - a): the peak 1 / (1 - |a|) at z = 1 (a > 0) or z = -1 (a < 0)
    res = hinf_norm(([1.0], [1.0, -a], 0.1))
    assert_brackets(res, 1.0 / (1.0 - abs(a)))
    assert res.omega == pytest.approx(omega, abs=1e-3)


def test_delays_leave_the_norm_unchanged():
    sys = LinearSystem([[-1.0, 2.0], [-2.0, -1.0]], [[1.0, 0.0], [0.0, 1.0]], [[1.0, 1.0], [0.0, 1.0]],
                       np.zeros((2, 2)))
    plain = hinf_norm(sys)
    delayed = hinf_norm(sys.with_(input_delay=[0.1, 0.3], output_delay=[0.2, 0.0]))
    assert delayed.value == pytest.approx(plain.value, rel=1e-12)


def test_supremum_at_infinity_and_static_gain():
    res = hinf_norm(([2.0, 1.0], [1.0, 1.0]))          # (2s + 1) / (s + 1): 1 at DC, 2 as w -> inf
    assert_brackets(res, 2.0)
    assert math.isinf(res.omega)
    static = hinf_norm((np.zeros((0, 0)), np.zeros((0, 2)), np.zeros((1, 0)), [[3.0, 4.0]]))
    assert static.value == pytest.approx(5.0, rel=1e-15) and static.certified


def test_budget_gives_a_valid_bracket_without_certificate():
    sys = load_mor("ISS12A", sparse=True)
    full = hinf_norm(sys)
    short = hinf_norm(sys, max_evaluations=50)
    assert not short.certified and "budget" in short.method
    assert short.value <= full.upper * (1 + 1e-9)
    assert full.value <= short.upper * (1 + 1e-9) and math.isfinite(short.upper)


def test_python_control_and_scipy_inputs():
    control = pytest.importorskip("control")
    tf = control.tf([4.0], [1.0, 0.04, 4.0])
    lti = scipy.signal.lti([4.0], [1.0, 0.04, 4.0])
    a, b = hinf_norm(tf), hinf_norm(lti)
    assert a.value == pytest.approx(b.value, rel=1e-12)
    assert_brackets(a, 1.0 / (2 * 0.01 * math.sqrt(1 - 1e-4)))
    assert "50.00" in str(a) and "certified" in str(a)


def test_bad_input_is_refused():
    with pytest.raises(ShapeError, match="not finite|finite"):
        hinf_norm(([[np.nan]], [[1.0]], [[1.0]], [[0.0]]))
    with pytest.raises(ShapeError):
        hinf_norm(([[-1.0, 0.0]], [[1.0]], [[1.0]], [[0.0]]))
    with pytest.raises(ModelError, match="method"):
        hinf_norm(([1.0], [1.0, 1.0]), method="slycot")
    with pytest.raises(ModelError, match="rtol"):
        hinf_norm(([1.0], [1.0, 1.0]), rtol=0.0)
    for bad in (0, None, 2.5):
        with pytest.raises(ModelError, match="max_evaluations"):
            hinf_norm(([1.0], [1.0, 1.0]), max_evaluations=bad)
    with pytest.raises(ModelError, match="interval"):
        # a Jordan block of order 250: the split-off block exceeds what the interval method takes
        n = 250
        J = -np.eye(n) + np.eye(n, k=1)
        hinf_norm((J, np.ones((n, 1)), np.ones((1, n)), np.zeros((1, 1))), method="interval")


@pytest.mark.parametrize("zeta", [0.3, 0.01, 1e-4])
def test_hamiltonian_peak_reaches_the_closed_form_and_refuses_a_failed_evaluation(zeta):
    # frequency/_hinf.py: hamiltonian_peak on w^2 / (s^2 + 2 zeta w s + w^2), w = 3 rad/s, from
    # the value at w: the peak 1 / (2 zeta sqrt(1 - zeta^2)) at w sqrt(1 - 2 zeta^2) (closed
    # form), certified; a gains function that returns nan at some trial points gives no
    # certificate (and its best value is still one it returned).
    from linflex.frequency._hinf import hamiltonian_peak

    w = 3.0
    A = np.array([[0.0, 1.0], [-w * w, -2 * zeta * w]])
    B, C, D = np.array([[0.0], [w * w]]), np.array([[1.0, 0.0]]), np.zeros((1, 1))

    def gains(x):
        s = 1j * np.asarray(x, dtype=float)
        return np.abs(w * w / (s * s + 2 * zeta * w * s + w * w))

    start = float(gains([w])[0])
    best_w, best, certified = hamiltonian_peak(A, B, C, D, gains, w, start, 1e-13, rounds=30)
    assert certified
    assert best == pytest.approx(1 / (2 * zeta * np.sqrt(1 - zeta**2)), rel=1e-12)
    assert best_w == pytest.approx(w * np.sqrt(1 - 2 * zeta**2), rel=1e-5)

    def failing(x):
        v = gains(x)
        v[1::2] = np.nan
        return v

    best_w, best, certified = hamiltonian_peak(A, B, C, D, failing, w, start, 1e-13, rounds=30)
    assert not certified
    assert best == start

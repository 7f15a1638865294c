"""Tests of square-root balanced truncation with the rigid part kept exactly."""


import warnings

import numpy as np
import pytest
import scipy.io
import scipy.linalg
import scipy.sparse
from hypothesis import given, settings
from hypothesis import strategies as st

from linflex import AccuracyWarning, LinearSystem, ModelError
from linflex.linearize import balanced_truncation
from linflex.linearize._block_lyapunov import DENSE_PART_MAX

from ..mor import load_mor
from .models import spacecraft


def response(sys, w):
    """Reference: direct complex solve C (jwI - A)^-1 B + D."""
    return sys.C @ np.linalg.solve(1j * w * np.eye(sys.A.shape[0]) - sys.A, sys.B) + sys.D


def reference_hsv(sys):
    """Independent Hankel singular values and the threshold above which they are trusted.

    slycot's AB09AD (SLICOT: Hammarling factors + square-root SVD, its own Schur form) when
    installed; otherwise the scipy gramians (Bartels-Stewart) and sqrt(eig(P Q)), whose small
    values lose accuracy like eps * hsv[0]^2 / hsv^2, so only values above 1e-3 of the largest
    are compared then.
    """
    try:
        import slycot
    except ImportError:
        P = scipy.linalg.solve_continuous_lyapunov(sys.A, -sys.B @ sys.B.T)
        Q = scipy.linalg.solve_continuous_lyapunov(sys.A.T, -sys.C.T @ sys.C)
        hsv = np.sort(np.sqrt(np.abs(np.linalg.eigvals(P @ Q).real)))[::-1]
        return hsv, 1e-3, 1e-6
    n, m, p = sys.n_states, sys.n_inputs, sys.n_outputs
    out = slycot.ab09ad("C", "B", "N", n, m, p, sys.A.copy(), sys.B.copy(), sys.C.copy(), nr=1)
    return out[-1], 1e-6, 1e-8


@pytest.mark.parametrize("solver", ["auto", "hammarling"])
@pytest.mark.parametrize("name", ["iss1R", "CDplayer", "build", "beam"])
def test_hsv_agree_with_independent_computation(name, solver):
    sys = load_mor(name)
    res = balanced_truncation(sys, order=10, lyapunov_solver=solver)
    ref, rel, rtol = reference_hsv(sys)
    keep = ref > rel * ref[0]
    # 1e-8 relative above 1e-6 of the largest (the requirement; with slycot)
    np.testing.assert_allclose(res.hsv[: ref.size][keep], ref[keep], rtol=rtol)
    assert max(res.lyapunov_residuals) < 1e-12  # round-off level for a backward-stable factor method


@pytest.mark.parametrize(("name", "orders"), [("build", [4, 12, 24]), ("iss1R", [25]), ("CDplayer", [8, 20])])
def test_measured_error_between_first_discarded_hsv_and_bound(name, orders):
    sys = load_mor(name)
    for r in orders:
        res = balanced_truncation(sys, order=r, measure_error=True)
        err = res.measured_error
        assert res.order == r and res.sys.n_states == r
        # Glover's bounds: hsv[r] <= ||G - Gr||_inf <= 2 sum(hsv[r:]); 1e-6 relative slack is the
        # certificate's tolerance
        assert res.hsv[r] * (1 - 1e-6) <= err.value <= res.error_bound * (1 + 1e-6)
        assert err.certified
        # independent check of the measurement: a direct complex solve at the reported frequency
        # reproduces the value (1e-9 relative, round-off of two solves)
        g = response(sys, err.omega) - response(res.sys, err.omega)
        np.testing.assert_allclose(np.linalg.norm(g, 2), err.value, rtol=1e-9)


def test_measured_error_against_slycot_linfnorm():
    pytest.importorskip("slycot")
    import control

    sys = load_mor("build")
    res = balanced_truncation(sys, order=8, measure_error=True)
    A = scipy.linalg.block_diag(sys.A, res.sys.A)
    E = control.ss(A, np.vstack([sys.B, res.sys.B]), np.hstack([sys.C, -res.sys.C]), 0)
    ref, _ = control.linfnorm(E, tol=1e-10)  # SLICOT AB13DD (Bruinsma-Steinbuch), independent code
    np.testing.assert_allclose(res.measured_error.value, ref, rtol=1e-6)  # our certificate's tolerance


def test_spacecraft_with_rigid_body_reduces_to_20_states():
    so = spacecraft()
    sys = so.to_state_space()
    res = balanced_truncation(so, order=20, measure_error=True)
    assert res.n_unstable == 2 and res.order == 20 and res.sys.n_states == 20
    # the rigid part is kept exactly: the reduced A holds the split's rigid block unchanged
    np.testing.assert_array_equal(res.sys.A[:2, :2], res.split.unstable.A)
    np.testing.assert_array_equal(res.sys.A[:2, 2:], 0.0)
    # the error system has no rigid-body poles: at low frequency the error stays below the bound
    # while each response grows like 1/w^2 (direct complex solves, independent of the method).
    # Below ~1e-2 rad/s the comparison itself is ill-conditioned: a round-off shift eps*||A|| of
    # a double pole at 0 changes 1/w^2 by a relative eps*||A||/w^2.
    for w in (1e-2, 0.1):
        g = response(sys, w)
        assert abs(g[0, 0]) > 0.5 / w**2
        assert np.linalg.norm(g - response(res.sys, w), 2) <= res.error_bound
    err = res.measured_error.value
    assert res.hsv[18] * (1 - 1e-6) <= err <= res.error_bound * (1 + 1e-6)


def test_spacecraft_hsv_against_slycot_on_stable_part():
    slycot = pytest.importorskip("slycot")
    res = balanced_truncation(spacecraft(), order=30)
    st = res.split.stable
    out = slycot.ab09ad("C", "B", "N", st.n_states, 1, 1, st.A.copy(), st.B.copy(), st.C.copy(), nr=1)
    ref = out[-1]
    keep = ref > 1e-6 * ref[0]
    # damping down to 1e-4: the gramians are large but the factors stay accurate (1e-8 relative)
    np.testing.assert_allclose(res.hsv[keep], ref[keep], rtol=1e-8)


def test_single_mode_damping_1e4_closed_form():
    z, w = 1e-4, 2.0
    sys = LinearSystem([[0.0, 1.0], [-(w**2), -2 * z * w]], [[0.0], [1.0]], [[1.0, 0.0]])
    # closed form gramians: P = diag(1/(4 z w^3), 1/(4 z w)); Q = [[1/(4zw) + z/w, 1/(2w^2)],
    # [1/(2w^2), 1/(4 z w^3)]]; hsv^2 are the roots of x^2 - tr(PQ) x + det(PQ)
    p1, p3 = 1 / (4 * z * w**3), 1 / (4 * z * w)
    q1, q2, q3 = 1 / (4 * z * w) + z / w, 1 / (2 * w**2), 1 / (4 * z * w**3)
    tr, det = p1 * q1 + p3 * q3, p1 * p3 * (q1 * q3 - q2**2)
    disc = np.sqrt(tr**2 - 4 * det)
    ref = np.sqrt([(tr + disc) / 2, 2 * det / (tr + disc)])
    res = balanced_truncation(sys, order=2)
    np.testing.assert_allclose(res.hsv, ref, rtol=1e-10)


def test_projection_bases_and_balanced_gramians():
    sys = load_mor("build")
    res = balanced_truncation(sys, order=10)
    # W^T V = I and the reduced matrices are the projections (1e-10 relative: round-off)
    np.testing.assert_allclose(res.W.T @ res.V, np.eye(10), atol=1e-10)
    np.testing.assert_allclose(res.W.T @ sys.A @ res.V, res.sys.A, atol=1e-10 * np.linalg.norm(sys.A, 1))
    # the reduced system is balanced: its gramians (scipy Bartels-Stewart, independent) are both
    # diag(hsv[:10]) to 1e-8 relative of the largest
    P = scipy.linalg.solve_continuous_lyapunov(res.sys.A, -res.sys.B @ res.sys.B.T)
    Q = scipy.linalg.solve_continuous_lyapunov(res.sys.A.T, -res.sys.C.T @ res.sys.C)
    np.testing.assert_allclose(P, np.diag(res.hsv[:10]), atol=1e-8 * res.hsv[0])
    np.testing.assert_allclose(Q, np.diag(res.hsv[:10]), atol=1e-8 * res.hsv[0])


def test_order_from_tol_is_smallest_meeting_bound():
    sys = load_mor("iss1R")
    res = balanced_truncation(sys, tol=1e-3)
    r = res.order
    tail = 2 * np.sum(res.hsv[r:])
    assert tail <= 1e-3 and res.error_bound == pytest.approx(tail, rel=1e-12)
    assert 2 * np.sum(res.hsv[r - 1:]) > 1e-3  # one state fewer would violate the bound


def test_default_order_is_minimal_balanced_realization():
    # a 3-state system with one unobservable mode: the minimal order is 2
    A = np.diag([-1.0, -2.0, -3.0])
    sys = LinearSystem(A, [[1.0], [1.0], [1.0]], [[1.0, 1.0, 0.0]], [[0.25]])
    res = balanced_truncation(sys)
    assert res.order == 2
    assert balanced_truncation(sys, tol=1e-300).order == 2  # tol below round-off: numerical order
    for w in (0.0, 1.0, 10.0):  # exact reduction: same response (direct solve), 1e-12 relative
        np.testing.assert_allclose(response(res.sys, w), response(sys, w), rtol=1e-12)


def test_bad_arguments():
    so = spacecraft(n_modes=5)
    with pytest.raises(ModelError, match="not both"):
        balanced_truncation(so, order=4, tol=1.0)
    with pytest.raises(ModelError, match="below the 2 states of the unstable"):
        balanced_truncation(so, order=1)
    with pytest.raises(ModelError, match="between 0 and the 12 states"):
        balanced_truncation(so, order=13)
    with pytest.raises(ModelError, match="integer"):
        balanced_truncation(so, order=3.5)
    with pytest.raises(ModelError, match="positive"):
        balanced_truncation(so, tol=-1.0)
    # a 3-state system with an unobservable mode has numerical order 2 (hsv[2] ~ 0)
    nonminimal = LinearSystem(np.diag([-1.0, -2.0, -3.0]), np.ones((3, 1)), [[1.0, 1.0, 0.0]])
    with pytest.raises(ModelError, match="only 2 Hankel singular values"):
        balanced_truncation(nonminimal, order=3)
    with pytest.raises(ModelError, match="sys must be"):
        balanced_truncation(np.eye(3), order=2)


@settings(max_examples=20, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(3, 12), r=st.integers(1, 2))
def test_property_error_between_glover_bounds(seed, n, r):
    rng = np.random.default_rng(seed)
    # random stable system: a random matrix shifted left of its spectral abscissa
    A = rng.normal(size=(n, n))
    A -= (np.max(np.linalg.eigvals(A).real) + rng.uniform(0.1, 2.0)) * np.eye(n)
    sys = LinearSystem(A, rng.normal(size=(n, 2)), rng.normal(size=(2, n)))
    res = balanced_truncation(sys, order=r, measure_error=True)
    # Glover: hsv[r] <= ||G - Gr||_inf <= 2 sum(hsv[r:]) (1e-6: certificate tolerance)
    assert res.hsv[r] * (1 - 1e-6) <= res.measured_error.value <= res.error_bound * (1 + 1e-6)


def test_badly_scaled_states_same_hsv_and_rigid_part():
    # orbit-like states in metres beside modal coordinates: a diagonal state scaling over 9 decades
    # is a similarity, so the Hankel singular values must not change (invariance; 1e-8 relative
    # above 1e-6 of the largest) and the rigid part is still found and kept
    so = spacecraft(n_modes=30, seed=5)
    base = so.to_state_space()
    s = np.logspace(-3, 6, base.n_states)
    scaled = LinearSystem(base.A * s[:, None] / s[None, :], base.B * s[:, None], base.C / s[None, :])
    a = balanced_truncation(base, order=12)
    b = balanced_truncation(scaled, order=12)
    assert a.n_unstable == b.n_unstable == 2
    keep = a.hsv > 1e-6 * a.hsv[0]
    np.testing.assert_allclose(b.hsv[keep], a.hsv[keep], rtol=1e-8)
    for w in (0.05, 3.0):  # same reduced response (direct solves), 1e-8 relative
        np.testing.assert_allclose(response(b.sys, w), response(a.sys, w), rtol=1e-8)


def test_lyapunov_residual_check_warns_and_refuses(monkeypatch):
    # the residual check is plumbing around a solver that is accurate on every model above;
    # force its value to exercise both thresholds (1e-8 warn, 1e-4 refuse) and the messages
    import linflex.linearize._balanced as bal
    from linflex import AccuracyWarning, ConvergenceError

    sys = LinearSystem(np.diag([-1.0, -2.0, -50.0]), np.ones((3, 1)), np.ones((1, 3)))
    monkeypatch.setattr(bal, "_lyapunov_residual", lambda A, Z, B: 3e-7)
    with pytest.warns(AccuracyWarning, match="3e-07"):
        res = balanced_truncation(sys, order=2)
    assert res.lyapunov_residuals == (3e-7, 3e-7)
    monkeypatch.setattr(bal, "_lyapunov_residual", lambda A, Z, B: 2e-3)
    with pytest.raises(ConvergenceError, match="0.002"):
        balanced_truncation(sys, order=2)


@pytest.mark.parametrize("name", ["iss1R", "CDplayer", "build", "beam"])
def test_sb03od_and_own_hammarling_agree(name):
    # two implementations of Hammarling's method (SLICOT's real 2x2-block one, linflex's complex
    # one) on the same Schur form: the Hankel singular values above 1e-6 of the largest agree to
    # 1e-9 relative (both backward stable; measured 3e-12 on ISS 1R), the reduced models' responses
    # to 1e-9 of the largest singular value
    pytest.importorskip("slycot")
    sys = load_mor(name)
    fast = balanced_truncation(sys, order=10, lyapunov_solver="SB03OD")
    own = balanced_truncation(sys, order=10, lyapunov_solver="hammarling")
    assert (fast.lyapunov_solver, own.lyapunov_solver) == ("SB03OD", "hammarling")
    keep = own.hsv > 1e-6 * own.hsv[0]
    np.testing.assert_allclose(fast.hsv[keep], own.hsv[keep], rtol=1e-9)
    for w in (0.1, 1.0, 10.0, 100.0):
        diff = np.linalg.norm(response(fast.sys, w) - response(own.sys, w), 2)
        assert diff <= 1e-9 * own.hsv[0]


def test_lyapunov_solver_choice_is_validated_and_falls_back(monkeypatch):
    import linflex.linearize._balanced as balanced_module

    sys = LinearSystem(np.diag([-1.0, -2.0, -50.0]), np.ones((3, 1)), np.ones((1, 3)))
    with pytest.raises(ModelError, match="lyapunov_solver must be one of"):
        balanced_truncation(sys, order=2, lyapunov_solver="bartels-stewart")
    reference = balanced_truncation(sys, order=2, lyapunov_solver="hammarling")
    # a modal (here diagonal) Schur form: the real block recursion
    res = balanced_truncation(sys, order=2, lyapunov_solver="modal")
    assert res.lyapunov_solver == "modal"
    np.testing.assert_allclose(res.hsv, reference.hsv, rtol=1e-13)
    # a dense Schur form of more than DENSE_PART_MAX states: "modal" is refused by name, and
    # without slycot "auto" falls back to linflex's own recursion, "SB03OD" is refused by name
    rng = np.random.default_rng(7)
    n = DENSE_PART_MAX + 6
    dense = LinearSystem(rng.standard_normal((n, n)) - 12.0 * np.eye(n), rng.standard_normal((n, 1)),
                         rng.standard_normal((1, n)))
    with pytest.raises(ModelError, match="lyapunov_solver='modal' needs"):
        balanced_truncation(dense, order=4, lyapunov_solver="modal")
    reference = balanced_truncation(dense, order=4, lyapunov_solver="hammarling")
    monkeypatch.setattr(balanced_module, "_slycot", lambda: None)
    # without slycot "auto" takes the block recursion on a modal form of any size
    assert balanced_truncation(sys, order=2).lyapunov_solver == "modal"
    res = balanced_truncation(dense, order=4)
    assert res.lyapunov_solver == "hammarling"
    np.testing.assert_allclose(res.hsv, reference.hsv, rtol=1e-14)
    with pytest.raises(ModelError, match="needs slycot"):
        balanced_truncation(sys, order=2, lyapunov_solver="SB03OD")


def test_full_order_measurement_is_not_certified_when_the_split_loses_accuracy():
    # issue 16: companion form of 1.334e6 / ((s + 1.026e-8)(s + 1e6)), |G(0)| = 1.3e8. The slow
    # pole is only known to eps * 1e6 = 2e-10 (2 % of itself), so the reduced model at full order
    # differs from G by 2e5 near w = 1e-8 rad/s (reference: dense numpy solves of both). Before,
    # the stable-part measurement said 1e-11, certified.
    a0, a1 = 1.026e-8 * 1e6, 1e6 + 1.026e-8
    sys = LinearSystem([[0, 1], [-a0, -a1]], [[0], [1]], [[1.334e6, 0]])
    # (G in companion form is evaluated by its Hessenberg LU, to 1e-16 there: the check now
    # sees G - G_r itself, and says where)
    with pytest.warns(AccuracyWarning, match=r"not certified: G - G_r reaches .* at omega = "):
        res = balanced_truncation(sys, order=2, measure_error=True)
    w = np.logspace(-12, 8, 801)
    diff = np.array([abs((response(sys, x) - response(res.sys, x))[0, 0]) for x in w])
    assert diff.max() > 1e4  # the truth: far from zero
    err = res.measured_error
    assert not err.certified
    # the reported value and its uncertainty bound the true difference (measured: the check
    # finds 1.961e5 at omega = 0, evaluation error 1e-6; the truth 1.961e5 towards omega = 0)
    assert err.value + err.evaluation_error >= diff.max()


@pytest.mark.parametrize("with_slycot", [True, False])
def test_recursion_that_lost_accuracy_is_replaced(monkeypatch, with_slycot):
    """Where the Hammarling recursion's residual exceeds LYAPUNOV_WARN (measured: a 1000-mass
    chain in first-order form, observability residual 5.5e-7 and Hankel singular values 37 % off,
    SB03OD and Bartels-Stewart right), SB03OD or, without slycot, Bartels-Stewart replaces it.
    Simulated here by a factor perturbed by 1e-4; reference: the unperturbed result."""
    import linflex.linearize._balanced as balanced_module
    from tests.mor import sparse_chain

    A, B, C = sparse_chain(40, damping=1e-2)
    sys = LinearSystem(A.toarray(), B, C)
    good = balanced_truncation(sys, order=6, lyapunov_solver="hammarling")
    exact = balanced_module._gramian_factors_hammarling
    noise = np.random.default_rng(0)

    def spoiled(S, B_, C_):
        Zc, Zo = exact(S, B_, C_)
        return Zc * (1 + 1e-4 * noise.standard_normal(Zc.shape)), Zo
    monkeypatch.setattr(balanced_module, "_gramian_factors_hammarling", spoiled)
    if not with_slycot:
        monkeypatch.setattr(balanced_module, "_slycot", lambda: None)
    with warnings.catch_warnings():
        warnings.simplefilter("error", AccuracyWarning)
        res = balanced_truncation(sys, order=6, lyapunov_solver="hammarling")
    assert res.lyapunov_solver == ("SB03OD" if with_slycot else "bartels-stewart")
    assert max(res.lyapunov_residuals) <= 1e-10
    np.testing.assert_allclose(res.hsv[:10], good.hsv[:10], rtol=0, atol=1e-9 * good.hsv[0])

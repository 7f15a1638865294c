"""The one frequency-domain engine (issue 16): a-posteriori error estimates, the spectrum policy,
input validation at the boundary."""

import warnings

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from linflex import AccuracyWarning, LinearSystem, LinflexError, ShapeError
from linflex.frequency import frequency_grid, frequency_response, nyquist_response, zeros
from linflex.frequency._spectrum import avoid_axis_poles, classify, system_scale

METHODS = ["auto", "modal", "hessenberg", "direct"]


def slow_fast_system():
    """Companion form of 1 / ((s + 1.026e-8)(s + 1e6)): eigenvalues 14 decades apart."""
    a0, a1 = 1.026e-8 * 1e6, 1e6 + 1.026e-8
    return LinearSystem([[0, 1], [-a0, -a1]], [[0], [1]], [[1, 0]]), a0, a1


@pytest.mark.parametrize("method", ["modal", "direct"])
def test_error_estimate_bounds_the_error_next_to_a_slow_pole(method):
    # reference (closed form): 1 / (s^2 + a1 s + a0) from the stored coefficients, evaluated in
    # double precision without cancellation at these points (|a1 s| >> |s^2|, a0 > 0)
    sys, a0, a1 = slow_fast_system()
    w = np.array([1e-10, 1e-8, 1e-2, 1e6])
    ref = 1 / ((1j * w) ** 2 + a1 * 1j * w + a0)
    with pytest.warns(AccuracyWarning, match=r"omega = 1e-10 rad/s.*poles span"):
        fr = frequency_response(sys, w, method=method)
    err = np.abs(fr.response[:, 0, 0] - ref) / np.abs(ref)
    # every path reports an estimate that bounds the true error (measured: true 8e-11 .. 1.5e-3,
    # estimates 2.2e-2 .. 0.12); before issue 16 the modal estimate was 2.1e-12 and the others 0
    assert 0 < err.max() <= fr.error_estimate
    assert fr.error_estimate > 1e-6


@pytest.mark.parametrize("method", ["auto", "hessenberg"])
def test_companion_form_next_to_a_slow_pole_by_its_hessenberg_lu(method):
    # the same companion matrix is upper Hessenberg already: no reduction, one banded LU per
    # point, whose componentwise residual bound sees that the LU keeps the tiny a0 apart from
    # a1 = 1e6 (the normwise bounds of the other paths cannot: 2e-2). The closed form above is
    # the reference; the largest error, 8.1e-11 at 1e-2 rad/s, is the cancellation in the back
    # substitution 1 - (s + a1) x2 = a0 x1, and the estimate bounds it without a warning.
    sys, a0, a1 = slow_fast_system()
    w = np.array([1e-10, 1e-8, 1e-2, 1e6])
    ref = 1 / ((1j * w) ** 2 + a1 * 1j * w + a0)
    fr = frequency_response(sys, w, method=method)
    err = np.abs(fr.response[:, 0, 0] - ref) / np.abs(ref)
    assert "hessenberg" in fr.method
    assert err.max() <= fr.error_estimate <= 1e-9
    assert err[:2].max() <= 1e-15


@pytest.mark.parametrize("method", METHODS)
def test_pole_on_a_user_grid_point_is_reported(method):
    # undamped mode at exactly 1 rad/s, 1 rad/s in omega: G(j) is infinite (closed form
    # 1 / (1 - w^2)); the other points are exact and the estimate says the point is not
    sys = LinearSystem([[0, 1], [-1, 0]], [[0], [1]], [[1, 0]])
    with pytest.warns(AccuracyWarning, match=r"omega = 1 rad/s.*pole at"):
        fr = frequency_response(sys, [0.5, 1.0, 2.0], method=method)
    np.testing.assert_allclose(fr.response[[0, 2], 0, 0], [1 / 0.75, -1 / 3], rtol=1e-14)
    assert fr.error_estimate >= 1.0  # before issue 16: 5.6e14 returned with estimate 3.6e-15


def test_estimates_are_never_a_constant_zero():
    # a benign system: every path gives a small, positive, bounding estimate (reference: dense
    # numpy solves)
    A = np.array([[-1.0, 2.0], [0.0, -3.0]])
    sys = LinearSystem(A, [[1.0], [1.0]], [[1.0, 0.5]])
    w = np.logspace(-1, 1, 9)
    ref = np.array([sys.C @ np.linalg.solve(1j * x * np.eye(2) - A, sys.B) for x in w])
    for method in METHODS:
        fr = frequency_response(sys, w, method=method)
        err = np.max(np.abs(fr.response - ref) / np.abs(ref))
        assert 0 < fr.error_estimate < 1e-13 and err <= max(fr.error_estimate, 1e-16)


def test_bad_input_names_the_argument():
    sys = LinearSystem([[-1.0]], [[1.0]], [[1.0]])
    with pytest.raises(ShapeError, match=r"omega\[0\] = 0.0 is not a positive"):
        frequency_response(sys, [0.0, 1.0])
    with pytest.raises(ShapeError, match=r"omega\[1\] = -2.0"):
        frequency_response(sys, np.array([1, -2]))
    with pytest.raises(ShapeError, match="omega must hold real frequencies"):
        frequency_response(sys, [1.0 + 1j])
    empty_in = LinearSystem([[-1.0]], np.zeros((1, 0)), [[1.0]])
    for f in (frequency_response, nyquist_response, zeros):
        with pytest.raises(ShapeError, match="(sys|loop).* has 1 outputs and 0 inputs"):
            f(empty_in)
    with pytest.raises(ShapeError, match="must be square"):
        nyquist_response(LinearSystem(-np.eye(2), np.ones((2, 2)), np.ones((1, 2))))
    with pytest.raises(LinflexError, match="B has shape"):
        LinearSystem(-np.eye(2), np.ones((3, 1)), np.ones((1, 2)))


def test_spectrum_policy_labels_perturbed_double_integrators_rigid():
    # the 1e-16 perturbations of a double integrator (transfer-function round-off) are rigid-body
    # poles like the exact one; the scale is that of the system (not the balanced nilpotent A,
    # whose norm collapses to 2e-16 without B and C)
    B, C = np.array([[0.0], [1.0]]), np.array([[60.0, 8.0]])
    for A in ([[0, 1], [0, 0]], [[0, 1], [0, 1e-16]], [[0, 1], [-1e-16, 0]], [[0, 1], [1e-16, 0]]):
        spec = classify(np.array(A, float), B=B, C=C)
        assert spec.rigid.all() and spec.n_rhp == 0 and spec.n_axis == 2
        # the loop's closed loop s^2 + 8 s + 60 (balanced [[0, 8], [-7.5, -8]]: 1-norm 16) sets it
        assert system_scale(np.array(A, float), B, C) == pytest.approx(16.0, rel=1e-12)
    # a genuine slow pole is not rigid: -1e-4 beside a mode at 100 rad/s
    A = np.array([[-1e-4, 0, 0], [0, 0, 1], [0, -1e4, -1]])
    spec = classify(A, B=np.ones((3, 1)), C=np.ones((1, 3)))
    assert not spec.rigid.any() and spec.n_axis == 0
    # user tolerance: |lambda| <= rigid_tol at the origin, |Re| <= rigid_tol on the axis
    spec = classify(A, 1e-3)
    assert spec.rigid.tolist() == [True, False, False] or spec.rigid.sum() == 1


def test_grid_never_holds_an_undamped_pole():
    # an undamped mode at exactly 1 rad/s (a base-grid point): the grid steps around it
    sys = LinearSystem([[0, 1], [-1, 0]], [[0], [1]], [[1, 0]])
    w = frequency_grid(sys)
    assert not np.any(np.abs(w - 1.0) <= 1e-9)
    assert np.any(np.abs(w - (1 - 1e-6)) < 1e-12) and np.any(np.abs(w - (1 + 1e-6)) < 1e-12)
    spec = classify(sys.A, B=sys.B, C=sys.C)
    np.testing.assert_array_equal(avoid_axis_poles(np.array([0.5, 2.0]), spec), [0.5, 2.0])


def test_automatic_response_of_an_undamped_mode_is_finite_and_warning_free():
    sys = LinearSystem([[0, 1], [-1, 0]], [[0], [1]], [[1, 0]])
    fr = frequency_response(sys)  # pytest turns an AccuracyWarning into an error
    assert np.all(np.isfinite(fr.response))
    # closed form 1 / (1 - w^2) (reference), relative to the large values next to the pole
    np.testing.assert_allclose(fr.response[:, 0, 0], 1 / (1 - fr.omega**2), rtol=1e-8)


@settings(max_examples=25, deadline=None)
@given(w0=st.floats(0.1, 100.0), zeta=st.floats(0.05, 0.7))
@example(w0=99.5, zeta=0.5)  # G evaluates to exactly 0 at w0 (found by CI)
def test_a_zero_on_the_axis_is_not_an_inaccuracy(w0, zeta):
    """``G = (s^2 + w0^2) / (s^2 + 2 zeta w0 s + w0^2)``, a notch whose zero is on the axis (as an
    undamped plant mode puts one in its loop's sensitivity): at and beside ``w0`` the relative
    error of ``G`` is unbounded however accurate the evaluation, so no AccuracyWarning, and the
    values are the closed form's to 1e-9 of the peak (absolute)."""
    sys = LinearSystem([[0.0, 1.0], [-w0**2, -2 * zeta * w0]], [[0.0], [1.0]], [[0.0, -2 * zeta * w0]], [[1.0]])
    w = w0 * np.array([0.5, 1 - 1e-9, 1.0, 1 + 1e-12, 2.0])
    with warnings.catch_warnings():
        warnings.simplefilter("error", AccuracyWarning)
        fr = frequency_response(sys, w)
    s = 1j * w
    ref = (s**2 + w0**2) / (s**2 + 2 * zeta * w0 * s + w0**2)
    assert np.max(np.abs(fr.response[:, 0, 0] - ref)) <= 1e-9 * np.max(np.abs(ref))


@settings(max_examples=40, deadline=None)
@given(n=st.integers(1, 40), m=st.integers(0, 3), p=st.integers(1, 3), seed=st.integers(0, 2**31 - 1),
       on_pole=st.booleans())
def test_schur_points_solved_together_match_one_solve_per_point(n, m, p, seed, on_pole):
    """The Schur path's stacked solve of small systems (frequency._evaluate._schur_eval_batched)
    against its per-point ``trsm`` path and an independent dense solve of ``sI - A`` in the original
    coordinates: values within their estimated errors (plus 1e-12 and 1e-10 of their size),
    estimates within a factor 2 of each other, and a point exactly on a diagonal entry of ``T``
    (a pole) infinite in both."""
    from linflex.frequency import _evaluate

    rng = np.random.default_rng(seed)
    A = rng.normal(size=(n, n)) - 3.0 * np.eye(n)
    B, C, D = rng.normal(size=(n, m)), rng.normal(size=(p, n)), rng.normal(size=(p, m))
    form = _evaluate._schur_form(LinearSystem(A, B, C, D))
    s = 1j * np.logspace(-2, 2, 37)
    if on_pole:
        s[5] = form[0][0, 0]
    batched, est_b = _evaluate._schur_eval_batched(form, D, s, chunk=8)
    looped, est_l = _loop(_evaluate, form, D, s)
    finite = np.isfinite(est_l)
    assert np.array_equal(finite, np.isfinite(est_b))
    assert finite.sum() == s.size - int(on_pole)
    scale = np.maximum(np.abs(looped[finite]).max(axis=(1, 2), initial=0.0), 1e-300)[:, None, None]
    # both are backward stable: they differ by at most their estimated errors (a point near an
    # eigenvalue of a random A is ill-conditioned for either)
    bound = (est_l[finite] + est_b[finite])[:, None, None] * scale
    assert np.all(np.abs(batched[finite] - looped[finite]) <= 1e-12 * scale + 2.0 * bound)
    dense = np.stack([C @ np.linalg.solve(sq * np.eye(n) - A, B) + D for sq in s[finite]])
    assert np.all(np.abs(batched[finite] - dense) <= 1e-10 * np.maximum(scale, np.abs(D).max(initial=0.0)) + 4.0 * bound)
    both = finite & (est_l > 0)
    assert np.all(est_b[both] <= 2.0 * est_l[both]) and np.all(est_l[both] <= 2.0 * est_b[both])


def _loop(module, form, D, s):
    """The per-point path of ``module._schur_eval``, whatever the size of ``form``."""
    saved = module.SCHUR_BATCH_MAX
    module.SCHUR_BATCH_MAX = -1
    try:
        return module._schur_eval(form, D, s)
    finally:
        module.SCHUR_BATCH_MAX = saved

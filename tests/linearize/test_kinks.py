"""linearize at points where the model is not differentiable (kinks, jumps) and where it is.

References: the one-sided slopes of the piecewise-linear test models are closed forms
(``|x|`` has slopes -1 and +1 at 0, a ReLU 0 and 1, ...); smooth models are checked against
their hand-differentiated Jacobians.
"""

import warnings

import casadi as ca
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from linflex import AccuracyWarning, NonlinearModel, OperatingPoint
from linflex.linearize import linearize
from linflex.linearize._differences import NOISE_POINTS

NUMERICAL = ("perturbation", "central", "complex-step")
EPS = np.finfo(float).eps

# name: (f(x, u) in numpy, left slope, right slope) at x = 0; every model is f + u.
KINKED = {
    "abs": (lambda x: np.abs(x), -1.0, 1.0),
    "x_plus_5abs": (lambda x: x + 5 * np.abs(x), -4.0, 6.0),
    "relu": (lambda x: np.maximum(x, 0.0), 0.0, 1.0),
    "clip": (lambda x: np.clip(x, 0.0, 1.0), 0.0, 1.0),
}
KINKED_CASADI = {
    "fabs": (lambda x: ca.fabs(x), -1.0, 1.0),
    "fmax": (lambda x: ca.fmax(x, 0), 0.0, 1.0),
    "fmin_plus_x": (lambda x: x + 3 * ca.fmin(x, 0), 4.0, 1.0),
    "if_else": (lambda x: ca.if_else(x > 0, x, -2 * x), -2.0, 1.0),
}
POINT = OperatingPoint([0.0], [0.0])


def scalar_model(f):
    return NonlinearModel(lambda x, u, t: np.array([f(x[0]) + u[0]]), states=["x"], inputs=["u"])


def casadi_model(f):
    x, u = ca.SX.sym("x"), ca.SX.sym("u")
    return NonlinearModel.from_casadi(f(x) + u, x, u, states=["x"], inputs=["u"])


def check_kinked(lin, left, right):
    # The Jacobian holds the central value; its error estimate reaches both one-sided slopes
    # (closed forms), and is not inflated beyond half their difference plus round-off.
    mean, half = (left + right) / 2, abs(right - left) / 2
    a, e = lin.sys.A[0, 0], lin.error_estimate.A[0, 0]
    assert a == pytest.approx(mean, abs=1e-9)  # one-sided three-point slopes of a linear piece: round-off
    assert e >= max(abs(a - left), abs(a - right))
    assert e <= half + 1e-6
    # The input column is smooth: exact, with a round-off-sized estimate, converged.
    assert lin.sys.B[0, 0] == pytest.approx(1.0, abs=1e-9)
    assert lin.error_estimate.B[0, 0] < 1e-6 and lin.converged.B[0, 0]
    assert not lin.converged.A[0, 0]


@pytest.mark.parametrize("method", NUMERICAL)
@pytest.mark.parametrize("name", KINKED)
def test_numpy_kinks_warn_and_bound_the_one_sided_slopes(name, method):
    f, left, right = KINKED[name]
    with pytest.warns(AccuracyWarning, match=r"kink.*d\(x\)/dt by x \(value.*central value") as record:
        lin = linearize(scalar_model(f), POINT, method=method)
    check_kinked(lin, left, right)
    assert len(record) == 1 and "by u" not in str(record[0].message)


@pytest.mark.parametrize("method", ["autodiff", "perturbation", "central"])
@pytest.mark.parametrize("name", KINKED_CASADI)
def test_casadi_kinks_warn_for_every_method(name, method):
    f, left, right = KINKED_CASADI[name]
    with pytest.warns(AccuracyWarning, match=rf"linearize \({method}\): the model has a kink.*d\(x\)/dt by x"):
        lin = linearize(casadi_model(f), POINT, method=method)
    check_kinked(lin, left, right)


@pytest.mark.parametrize("method", ["perturbation", "central", "complex-step", "autodiff"])
def test_sign_jumps_have_no_derivative(method):
    model = casadi_model(ca.sign) if method == "autodiff" else scalar_model(np.sign)
    with pytest.warns(AccuracyWarning, match=r"value jumps.*no derivative: d\(x\)/dt by x\..*infinite"):
        lin = linearize(model, POINT, method=method)
    assert lin.error_estimate.A[0, 0] == np.inf and not lin.converged.A[0, 0]
    assert lin.sys.B[0, 0] == pytest.approx(1.0, abs=1e-9)


def test_kinks_in_an_input_column_and_an_output_row_are_named():
    # Row d(v)/dt bends in the input "force" (dead-zone-free saturation reached exactly), the
    # output "speed" in the state "v"; the other entries stay smooth.
    model = NonlinearModel(lambda x, u, t: np.array([x[1], -x[0] + np.maximum(u[0], 0.0)]),
                           lambda x, u, t: np.array([np.abs(x[1])]),
                           states=["p", "v"], inputs=["force"], outputs=["speed"])
    op = OperatingPoint([0.0, 0.0], [0.0])
    with pytest.warns(AccuracyWarning) as record:
        lin = linearize(model, op, method="central")
    message = str(record[0].message)
    assert "d(v)/dt by force" in message and "speed by v" in message and "by p" not in message
    assert lin.sys.B[1, 0] == pytest.approx(0.5, abs=1e-9) and lin.error_estimate.B[1, 0] >= 0.5
    assert lin.sys.C[0, 1] == pytest.approx(0.0, abs=1e-9) and lin.error_estimate.C[0, 1] >= 1.0
    np.testing.assert_allclose(lin.sys.A, [[0.0, 1.0], [-1.0, 0.0]], atol=1e-9)


def test_complex_step_through_abs_away_from_the_kink_is_corrected():
    # np.abs of a complex number is real, so the complex step of |x| is 0 at x = 1 where the
    # derivative is 1 (closed form): the real check replaces it and says so.
    model = scalar_model(np.abs)
    with pytest.warns(AccuracyWarning, match=r"complex-step derivative disagrees.*d\(x\)/dt by x: 0 against 1"):
        lin = linearize(model, OperatingPoint([1.0], [-1.0]), method="complex-step")
    assert abs(lin.sys.A[0, 0] - 1.0) <= lin.error_estimate.A[0, 0] < 1e-6


def test_digits_not_reached_warns_with_the_digits_reached():
    # exp(10 x) at 0 with one halving from a 1 % step: the quadratic fit is still moving by
    # ~1e-2 relative (third-derivative term), far from 6 digits; d/dx exp(10 x) = 10.
    model = scalar_model(lambda x: np.exp(10 * x) - 1.0)
    with pytest.warns(AccuracyWarning, match=r"1 Jacobian entries did not reach digits=6 .*: d\(x\)/dt by x = ") as rec:
        lin = linearize(model, OperatingPoint([0.0], [0.0]), method="perturbation", max_halvings=1,
                        zero_step=0.01)
    a, e = lin.sys.A[0, 0], lin.error_estimate.A[0, 0]
    assert f"({np.log10(abs(a) / e):.1f} digits)" in str(rec[0].message)
    assert abs(a - 10.0) <= e and not lin.converged.A[0, 0]


def test_non_smooth_casadi_graph_away_from_its_kinks_keeps_the_exact_jacobian():
    # fabs and fmax at points where they are smooth: the probe runs (six evaluations per
    # column) and agrees, so autodiff keeps its exact value and zero error estimate.
    x, u = ca.SX.sym("x", 2), ca.SX.sym("u")
    model = NonlinearModel.from_casadi(ca.vertcat(x[1], -ca.fabs(x[0]) * x[0] + ca.fmax(u, -1)), x, u)
    lin = linearize(model, OperatingPoint([0.5, 0.0], [0.25]), method="autodiff")
    np.testing.assert_array_equal(lin.sys.A, [[0.0, 1.0], [-1.0, 0.0]])  # d(-|x| x)/dx = -2|x| = -1
    np.testing.assert_array_equal(lin.sys.B, [[0.0], [1.0]])
    assert lin.error_estimate.stacked().max() == 0.0 and lin.all_converged
    assert lin.n_evaluations == 1 + 3 * 6 + NOISE_POINTS  # nominal, six real per column, the noise measurement


def pendulum(backend):
    if backend == "casadi":
        x, u = ca.SX.sym("x", 2), ca.SX.sym("u")
        return NonlinearModel.from_casadi(ca.vertcat(x[1], -9.81 * ca.sin(x[0]) - 0.1 * x[1] + u), x, u)
    return NonlinearModel(lambda x, u, t: np.array([x[1], -9.81 * np.sin(x[0]) - 0.1 * x[1] + u[0]]),
                          states=2, inputs=1)


@pytest.mark.parametrize("method", [*NUMERICAL, "autodiff"])
@pytest.mark.parametrize("theta", [0.0, np.pi, 0.3])
def test_pendulum_does_not_warn(method, theta):
    # Closed form: A = [[0, 1], [-9.81 cos(theta), -0.1]].
    model = pendulum("casadi" if method == "autodiff" else "numpy")
    with warnings.catch_warnings():
        warnings.simplefilter("error", AccuracyWarning)
        lin = linearize(model, OperatingPoint([theta, 0.0], [9.81 * np.sin(theta)]), method=method)
    exact = np.array([[0.0, 1.0], [-9.81 * np.cos(theta), -0.1]])
    assert np.all(np.abs(lin.sys.A - exact) <= lin.error_estimate.A + 4 * EPS * np.abs(exact))
    assert lin.all_converged
    if method == "autodiff":
        assert lin.n_evaluations == 1  # a smooth graph is not probed


def polynomial_model(coefficients):
    """f_i(x, u) = sum_k c_ik * monomial_k, monomials of degree <= 3 in (x0, x1, u0), plus sin(x0 + x1)."""
    def monomials(x0, x1, u0):
        return [x0, x1, u0, x0 * x1, x0**2, x1 * u0, x0**3, x0 * x1**2, u0**3]

    def jac(x0, x1, u0):
        # Rows: d monomial_k / d(x0, x1, u0), by hand.
        return np.array([[1, 0, 0], [0, 1, 0], [0, 0, 1], [x1, x0, 0], [2 * x0, 0, 0], [0, u0, x1],
                         [3 * x0**2, 0, 0], [x1**2, 2 * x0 * x1, 0], [0, 0, 3 * u0**2]], dtype=float)

    c = np.asarray(coefficients, dtype=float)

    def f(x, u, t):
        return c @ np.array(monomials(x[0], x[1], u[0])) + np.sin(x[0] + x[1])

    def jacobian(x, u):
        """The Jacobian and a bound on its own round-off (a few ulps of the sum of its terms)."""
        s = np.cos(x[0] + x[1])
        terms = jac(x[0], x[1], u[0])
        sine = np.array([[s, s, 0.0]] * 2)
        return c @ terms + sine, 4 * EPS * (np.abs(c) @ np.abs(terms) + np.abs(sine))

    return NonlinearModel(f, states=2, inputs=1), jacobian


@settings(derandomize=True, max_examples=100, deadline=None)
@given(st.lists(st.floats(-3, 3), min_size=18, max_size=18),
       st.lists(st.floats(-2, 2), min_size=3, max_size=3),
       st.sampled_from(NUMERICAL))
def test_random_smooth_models_do_not_warn_and_are_bounded(coefficients, point, method):
    # Property: a smooth model never reports a kink, a jump or missed digits, and the error
    # estimate bounds the true error against the analytic Jacobian (round-off aside).
    model, jacobian = polynomial_model(np.reshape(coefficients, (2, 9)))
    op = OperatingPoint(point[:2], point[2:])
    with warnings.catch_warnings():
        warnings.simplefilter("error", AccuracyWarning)
        lin = linearize(model, op, method=method, allow_non_equilibrium=True)
    J = np.hstack([lin.sys.A, lin.sys.B])
    exact, reference_roundoff = jacobian(op.x, op.u)
    err = np.hstack([lin.error_estimate.A, lin.error_estimate.B])
    assert np.all(np.abs(J - exact) <= err + reference_roundoff)
    # No warning means the requested 6 digits relative to each row's scale.
    assert lin.max_relative_error_estimate <= 1e-6


def noisy_model(f, cond: float):
    """``f(x, u)`` computed through a linear solve with a matrix of condition ``cond``: the values
    carry ~``cond * eps`` of relative noise that the Jacobian's terms do not show (as a constrained
    model's accelerations do)."""
    rng = np.random.default_rng(7)
    Q1, _ = np.linalg.qr(rng.normal(size=(2, 2)))
    Q2, _ = np.linalg.qr(rng.normal(size=(2, 2)))
    M = Q1 @ np.diag([1.0, 1.0 / cond]) @ Q2

    def rhs(x, u, t):
        value = np.array([f(x[0], x[1]) + u[0], x[0] - 2.0 * x[1]])
        return np.linalg.solve(M, M @ value)

    return NonlinearModel(rhs, states=["x", "y"], inputs=["u"])


@pytest.mark.parametrize("method", ["perturbation", "central"])
def test_noise_above_round_off_is_not_called_a_kink(method):
    # A smooth model (closed-form Jacobian [[cos x0, 3], [1, -2]], B = e1) computed through a solve
    # with condition 1e9: before the noise was measured (Moré-Wild difference tables), its noise
    # showed as kinks and jumps. Now: no kink or jump warning, the Jacobian to the accuracy the noise
    # allows (1e9 eps ~ 2e-7 in the values over steps ~1e-4: 1e-2), and an error estimate that
    # bounds the true error.
    model = noisy_model(lambda x, y: np.sin(x) + 3 * y, 1e9)
    x0 = np.array([0.3, -0.2])
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        lin = linearize(model, OperatingPoint(x0, [0.0]), method=method, allow_non_equilibrium=True)
    messages = [str(w.message) for w in caught]
    assert not any("kink" in m or "jumps" in m for m in messages), messages
    want = np.array([[np.cos(0.3), 3.0], [1.0, -2.0]])
    np.testing.assert_allclose(lin.sys.A, want, atol=1e-2)
    assert np.all(np.abs(lin.sys.A - want) <= lin.error_estimate.A)


@pytest.mark.parametrize("method", ["perturbation", "central"])
def test_a_kink_is_found_through_the_noise(method):
    # |x0| + 3 y through the same noisy solve: the slope jump of 2 stands far above the noise.
    model = noisy_model(lambda x, y: np.abs(x) + 3 * y, 1e9)
    with pytest.warns(AccuracyWarning, match="kink"):
        lin = linearize(model, OperatingPoint([0.0, 0.1], [0.0]), method=method, allow_non_equilibrium=True)
    assert lin.sys.A[0, 0] == pytest.approx(0.0, abs=1e-2)  # the mean of the slopes -1 and +1
    assert lin.error_estimate.A[0, 0] >= 1.0 - 1e-2


def test_measured_noise_against_repeated_evaluation():
    # The Moré-Wild estimate against the noise's own standard deviation, measured independently
    # as the spread of 200 evaluations at points 1e-9 apart (where the smooth change is 1e-9):
    # within a factor 4 (the estimate uses 9 values).
    from linflex.linearize._differences import CountingFunction, measured_noise

    model = noisy_model(lambda x, y: np.sin(x) + 3 * y, 1e10)

    def g(z):
        return model.f(z[:2], z[2:], 0.0)

    z0 = np.array([0.3, -0.2, 0.0])
    noise = measured_noise(CountingFunction(g, ("x", "y", "u"), ("a", "b")), z0, np.full(3, 1e-4))
    spread = np.std([g(z0 + k * 1e-12) - g(z0) for k in range(200)], axis=0)
    assert np.all(noise <= 4 * spread) and np.all(noise >= spread / 4), (noise, spread)


@pytest.mark.parametrize("method", ["perturbation", "central"])
def test_a_row_that_is_zero_at_the_point_keeps_a_zero_error(method):
    # d(x0)/dt = x0 x1^2 has the Jacobian row [0, 0] at the origin and values of ~1e-27 beside it:
    # their rounding is not noise of the model, so the row's error estimate stays 0 and the
    # linearization's relative estimate finite (it was inf once the noise was measured).
    model = NonlinearModel(lambda x, u, t: np.array([x[0] * x[1] ** 2, x[0] - x[1] + u[0]]), states=2, inputs=1)
    lin = linearize(model, OperatingPoint([0.0, 0.0], [0.0]), method=method)
    np.testing.assert_array_equal(lin.sys.A[0], [0.0, 0.0])
    assert lin.error_estimate.A[0].max() == 0.0
    assert lin.max_relative_error_estimate < 1e-5

"""linearize: every method against closed forms and against each other."""

from pathlib import Path

import casadi as ca
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from linflex import (
    LinearSystem,
    MethodUnavailableError,
    ModelError,
    NonlinearModel,
    NotAnEquilibriumError,
    OperatingPoint,
    ShapeError,
)
from linflex.linearize import METHODS, linearize
from linflex.linearize._differences import NOISE_POINTS

from .models import euler_equations, orbit_and_pitch, orbit_and_pitch_jacobian

NUMERICAL = ("perturbation", "central", "complex-step")


def analytic(backend="numpy"):
    """f = [x0^2 x1 + sin(u0), exp(x1) - x2 u0, x0 x2^3], h = [x0 x1 x2 + u0^2]."""

    def f(x, u, lib):
        return [x[0] ** 2 * x[1] + lib.sin(u[0]), lib.exp(x[1]) - x[2] * u[0], x[0] * x[2] ** 3]

    def h(x, u):
        return [x[0] * x[1] * x[2] + u[0] ** 2]

    if backend == "casadi":
        x, u = ca.SX.sym("x", 3), ca.SX.sym("u", 1)
        return NonlinearModel.from_casadi(ca.vertcat(*f(x, u, ca)), x, u, ca.vertcat(*h(x, u)))
    return NonlinearModel(lambda x, u, t: np.array(f(x, u, np)), lambda x, u, t: np.array(h(x, u)), states=3,
                          inputs=1)


def analytic_jacobian(x, u):
    # Hand-differentiated Jacobians of `analytic`.
    A = [[2 * x[0] * x[1], x[0] ** 2, 0], [0, np.exp(x[1]), -u[0]], [x[2] ** 3, 0, 3 * x[0] * x[2] ** 2]]
    B = [[np.cos(u[0])], [-x[2]], [0]]
    C = [[x[1] * x[2], x[0] * x[2], x[0] * x[1]]]
    D = [[2 * u[0]]]
    return np.block([[np.array(A), np.array(B)], [np.array(C), np.array(D)]])


# x1 = 0 exercises the zero-value step; A[0, 2] and A[1, 0] are structurally zero.
POINT = OperatingPoint([1.3, 0.0, -0.7], [0.4])
# The methods for any model ("kane" needs a compiled scene: tests/linearize/test_kane.py).
GENERAL_METHODS = [m for m in METHODS if m != "kane"]


@pytest.mark.parametrize("method", GENERAL_METHODS)
def test_analytic_function(method):
    model = analytic("casadi" if method == "autodiff" else "numpy")
    lin = linearize(model, POINT, method=method, allow_non_equilibrium=True)
    J = np.block([[lin.sys.A, lin.sys.B], [lin.sys.C, lin.sys.D]])
    exact = analytic_jacobian(POINT.x, POINT.u)
    # Tolerance per method: perturbation agrees to `digits` = 6 significant digits (error of the
    # accepted estimate is about a third of the last change); central with Richardson ~1e-10;
    # complex step and autodiff to round-off.
    rtol = {"perturbation": 1e-6, "central": 1e-9, "complex-step": 1e-14, "autodiff": 1e-14}[method]
    np.testing.assert_allclose(J, exact, rtol=rtol, atol=rtol * np.max(np.abs(exact)))
    assert lin.all_converged
    # The error estimate bounds the true error (absolute, per entry), round-off aside.
    true_error = np.abs(J - exact)
    assert np.all(true_error <= lin.error_estimate.stacked() + 4 * np.finfo(float).eps * np.abs(exact))


def test_perturbation_on_linear_model_converges_after_one_halving():
    # Reference notes section 1.7 test 2: F = A y + B u converges after one halving, so the
    # evaluation count is exactly 1 + n (2 + 1), plus 3 per variable on the other side for the
    # kink check, and the result exact up to round-off (eps |F| / |Delta|, 1e-9 relative with
    # the 1e-6 zero-value step).
    rng = np.random.default_rng(1)
    A, B = rng.normal(size=(6, 6)), rng.normal(size=(6, 2))
    model = NonlinearModel(lambda x, u, t: A @ x + B @ u, states=6, inputs=2)
    x0 = rng.normal(size=6)
    x0[2] = 0.0
    lin = linearize(model, OperatingPoint(x0, np.zeros(2)), method="perturbation", allow_non_equilibrium=True)
    assert lin.n_evaluations == 1 + 8 * (3 + 3) + NOISE_POINTS
    np.testing.assert_allclose(lin.sys.A, A, rtol=1e-8, atol=1e-8)
    np.testing.assert_allclose(lin.sys.B, B, rtol=1e-8, atol=1e-8)


@pytest.mark.parametrize("method", GENERAL_METHODS)
@pytest.mark.parametrize("axis,stable", [(0, True), (1, False), (2, True)])
def test_torque_free_spin_eigenvalues(method, axis, stable):
    # Closed form (Euler's equations about principal axis i spinning at Omega): the non-zero
    # eigenvalues satisfy lambda^2 = Omega^2 (Ij - Ii)(Ii - Ik) / (Ij Ik); stable (imaginary)
    # about the major and minor axes, real about the intermediate axis.
    inertia = [30.0, 20.0, 10.0]  # major x, intermediate y, minor z [kg m^2]
    omega = 0.7  # rad/s
    model = euler_equations(np.diag(inertia), backend="casadi" if method == "autodiff" else "numpy")
    w0 = np.zeros(3)
    w0[axis] = omega
    lin = linearize(model, OperatingPoint(w0, np.zeros(3)), method=method)
    Ii = inertia[axis]
    Ij, Ik = (inertia[k] for k in range(3) if k != axis)
    lam2 = omega**2 * (Ij - Ii) * (Ii - Ik) / (Ij * Ik)
    eig = np.linalg.eigvals(lin.sys.A)
    nonzero = eig[np.argsort(np.abs(eig))][1:]
    expected = np.sqrt(complex(lam2))
    # Tolerance: 1e-6 relative for perturbation (6 digits), 1e-10 for the others.
    rtol = 1e-6 if method == "perturbation" else 1e-10
    np.testing.assert_allclose(np.sort_complex(nonzero), np.sort_complex([expected, -expected]), rtol=rtol)
    assert (np.max(eig.real) < 1e-6) == stable


@pytest.mark.parametrize("method", ["perturbation", "central", "complex-step", "autodiff"])
def test_states_scaled_1e9_apart(method):
    # Orbit radius 7e6 m beside a pitch angle and rates ~1e-3 rad/s. python-control's fixed
    # absolute step of 1e-6 loses accuracy here; every linflex method must reach 1e-6 relative
    # accuracy entrywise (closed form in models.orbit_and_pitch_jacobian).
    A_exact, B_exact, n = orbit_and_pitch_jacobian()
    model = orbit_and_pitch(backend="casadi" if method == "autodiff" else "numpy")
    op = OperatingPoint([7.0e6, 0.0, n, 0.0, 0.0], [0.0, 0.0])
    lin = linearize(model, op, method=method)
    assert lin.is_equilibrium
    for got, exact in ((lin.sys.A, A_exact), (lin.sys.B, B_exact)):
        nonzero = exact != 0
        np.testing.assert_allclose(got[nonzero], exact[nonzero], rtol=1e-6)
        # Structural zeros: below 1e-6 of the largest entry in the same row.
        row_scale = np.max(np.abs(np.hstack([A_exact, B_exact])), axis=1, keepdims=True)
        assert np.all(np.abs(got[~nonzero]) <= 1e-6 * np.broadcast_to(row_scale, got.shape)[~nonzero])


def test_methods_agree_on_a_casadi_model_and_its_numpy_twin():
    # The same equations in two backends: autodiff (exact) against each numerical method.
    inertia = np.array([[30.0, 1.0, -2.0], [1.0, 20.0, 0.5], [-2.0, 0.5, 10.0]])
    w0 = np.array([0.1, -0.2, 0.3])
    op = OperatingPoint(w0, np.zeros(3))
    exact = linearize(euler_equations(inertia, backend="casadi"), op, method="autodiff",
                      allow_non_equilibrium=True)
    for method in NUMERICAL:
        lin = linearize(euler_equations(inertia), op, method=method, allow_non_equilibrium=True)
        np.testing.assert_allclose(lin.sys.A, exact.sys.A, rtol=1e-6, atol=1e-9)
        np.testing.assert_allclose(lin.sys.B, exact.sys.B, rtol=1e-6, atol=1e-9)
        assert np.all(np.abs(lin.sys.A - exact.sys.A) <= lin.error_estimate.A + 1e-15)
    assert exact.error_estimate.A.max() == 0.0 and exact.method == "autodiff"


def test_auto_method_picks_autodiff_for_casadi_and_perturbation_for_numpy():
    op = OperatingPoint([0.0, 0.0, 0.0], [0.0, 0.0, 0.0])
    assert linearize(euler_equations(np.eye(3), backend="casadi"), op).method == "autodiff"
    assert linearize(euler_equations(np.eye(3)), op).method == "perturbation"


def test_names_carry_over():
    lin = linearize(euler_equations(np.eye(3)), OperatingPoint(np.zeros(3), np.zeros(3)))
    assert lin.sys.states == ("wx", "wy", "wz") and lin.sys.inputs == ("tx", "ty", "tz")
    assert lin.sys.outputs == ("gx", "gy", "gz")
    assert isinstance(lin.sys, LinearSystem)


def test_not_an_equilibrium_is_refused_with_the_residual():
    model = orbit_and_pitch()
    op = OperatingPoint([7.0e6, 0.0, 0.0, 0.0, 0.0], [0.0, 0.0])  # no orbit rate: falls
    with pytest.raises(NotAnEquilibriumError, match=r"d\(r_dot\)/dt = -8\.13") as info:
        linearize(model, op)
    assert info.value.residual[1] == pytest.approx(-3.986004418e14 / 7.0e6**2, rel=1e-12)
    lin = linearize(model, op, allow_non_equilibrium=True)
    assert not lin.is_equilibrium
    assert lin.residual[1] == pytest.approx(-3.986004418e14 / 7.0e6**2, rel=1e-12)


def test_bad_input():
    model = euler_equations(np.eye(3))
    with pytest.raises(ShapeError, match=r"x has shape \(2,\) but shape \(3,\) was expected"):
        linearize(model, OperatingPoint([0.0, 0.0], np.zeros(3)))
    with pytest.raises(ModelError, match="unknown method 'forward'"):
        linearize(model, OperatingPoint(np.zeros(3), np.zeros(3)), method="forward")
    with pytest.raises(ModelError, match="op must be an OperatingPoint"):
        linearize(model, (np.zeros(3), np.zeros(3)))
    with pytest.raises(ModelError, match="max_halvings must be a positive integer"):
        linearize(model, OperatingPoint(np.zeros(3), np.zeros(3)), method="perturbation", max_halvings=0)
    with pytest.raises(ShapeError, match=r"scale has shape \(3,\) but shape \(6,\)"):
        linearize(model, OperatingPoint(np.zeros(3), np.zeros(3)), scale=np.ones(3))


def test_autodiff_on_numpy_model_names_the_working_methods():
    with pytest.raises(MethodUnavailableError, match="'perturbation', 'central' or 'complex-step'"):
        linearize(euler_equations(np.eye(3)), OperatingPoint(np.zeros(3), np.zeros(3)), method="autodiff")


def test_complex_step_refuses_models_that_drop_the_imaginary_part():
    model = NonlinearModel(lambda x, u, t: np.array([float(np.real(x[0])) ** 2 - 1.0]), states=1)
    with pytest.raises(MethodUnavailableError, match="complex"):
        linearize(model, OperatingPoint([1.0]), method="complex-step")
    with pytest.raises(MethodUnavailableError, match="CasADi model"):
        linearize(euler_equations(np.eye(3), backend="casadi"), OperatingPoint(np.zeros(3), np.zeros(3)),
                  method="complex-step")


def test_non_finite_during_perturbation_names_variable_and_entry():
    # sqrt(x1) is finite at x1 = 0.5 but the first perturbed point of x1 is fine; x0 = 0 with a
    # negative scale direction is not: use log(x0) at x0 = 1e-9 where a 1 % step stays positive,
    # and log(1 - x2) at x2 = 1 - 1e-9 where the upward step leaves the domain.
    model = NonlinearModel(lambda x, u, t: np.array([np.log(1.0 - x[0])]), states=["x"])
    with np.errstate(invalid="ignore"), pytest.raises(ModelError, match="while perturbing 'x'"):
        linearize(model, OperatingPoint([0.995]), method="perturbation", allow_non_equilibrium=True)


def test_exception_inside_f_is_chained():
    def f(x, u, t):
        if x[0] != 0.0:
            raise RuntimeError("table lookup out of range")
        return np.zeros(1)

    with pytest.raises(ModelError, match="RuntimeError: table lookup out of range") as info:
        linearize(NonlinearModel(f, states=1), OperatingPoint([0.0]), method="central")
    assert isinstance(info.value.__cause__.__cause__, RuntimeError)


def test_result_is_frozen_and_reports_cost():
    lin = linearize(euler_equations(np.eye(3)), OperatingPoint([0.0, 0.0, 0.5], np.zeros(3)), method="central")
    # one nominal + 2 per level, 3 levels per variable, and the model's noise measured once
    assert lin.n_evaluations == 1 + 6 * 2 * 3 + NOISE_POINTS
    assert lin.seconds > 0 and lin.settings["levels"] == 3
    with pytest.raises(AttributeError):
        lin.method = "x"
    with pytest.raises(TypeError):
        lin.settings["levels"] = 4


@settings(max_examples=20, deadline=None)
@given(st.integers(min_value=1, max_value=6), st.integers(min_value=0, max_value=2**31 - 1),
       st.sampled_from(NUMERICAL))
def test_linear_models_are_recovered_by_every_numerical_method(n, seed, method):
    # Property: the Jacobian of an affine model is its matrix, whatever the point.
    rng = np.random.default_rng(seed)
    A, B = rng.normal(size=(n, n)), rng.normal(size=(n, 1))
    model = NonlinearModel(lambda x, u, t: A @ x + B @ u, states=n, inputs=1)
    lin = linearize(model, OperatingPoint(rng.normal(size=n), [0.0]), method=method, allow_non_equilibrium=True)
    np.testing.assert_allclose(lin.sys.A, A, rtol=1e-7, atol=1e-7)


# -- the method registry (linearize/_methods.py) ----------------------------------------------------

BUILT_IN = ("perturbation", "central", "complex-step", "autodiff", "kane")


def test_registry_lists_every_method_with_its_options_in_the_docs():
    from linflex import LinflexError

    assert tuple(METHODS) == BUILT_IN  # registration order, the old tuple's order
    for name, entry in METHODS.items():
        assert entry.name == name and entry.description and "\n" not in entry.description
        # The docstring of linearize is generated from the registry: every method and option.
        assert f"{name}: {entry.description}" in linearize.__doc__
        for info in entry.option_infos:
            assert f"{info.name} = {info.default!r}" in linearize.__doc__
            assert info.description and (info.unit.startswith("[") or isinstance(info.default, bool))
    assert METHODS["perturbation"].option_names == ("digits", "rel_step", "zero_step", "max_halvings", "abs_tol")
    assert METHODS["central"].option_names == ("digits", "rel_step", "zero_step", "levels")
    assert METHODS["complex-step"].option_names == ("complex_step",)
    assert METHODS["autodiff"].option_names == ()
    assert METHODS["kane"].option_names == ("premature",)
    # Read-only: adding a method goes through register_method.
    with pytest.raises(TypeError):
        METHODS["forward"] = METHODS["central"]
    # settings: exactly the method's options (defaults filled in) and the two contract settings.
    for method in NUMERICAL:
        lin = linearize(analytic(), POINT, method=method, allow_non_equilibrium=True)
        assert set(lin.settings) == set(METHODS[method].option_names) | {"equilibrium_tol", "allow_non_equilibrium"}
    assert linearize(analytic(), POINT, method="perturbation", allow_non_equilibrium=True).settings["rel_step"] == 0.01
    assert linearize(analytic(), POINT, method="central", allow_non_equilibrium=True).settings["rel_step"] == 1e-3
    from linflex.linearize._methods import LinearizationMethod, register_method

    with pytest.raises(LinflexError, match="already registered"):
        register_method(METHODS["central"])
    # A registration is checked when it is made, not when the method is first used.
    from dataclasses import dataclass

    @dataclass(frozen=True)
    class NoDefault:
        step: float

    run = METHODS["central"].function
    with pytest.raises(ModelError, match=r"options of method 'x' need defaults \(made with option\(\)\): \['step'\]"):
        LinearizationMethod("x", "a test", NoDefault, run)
    with pytest.raises(ModelError, match="other than 'auto'"):
        LinearizationMethod("auto", "a test", NoDefault, run)
    with pytest.raises(ModelError, match="must be one line"):
        LinearizationMethod("x", "two\nlines", type(METHODS["central"].make_options({})), run)
    with pytest.raises(ModelError, match="models of method 'x' must be one of"):
        LinearizationMethod("x", "a test", type(METHODS["central"].make_options({})), run, models="matlab")


def test_every_keyword_of_before_is_still_accepted_by_its_method():
    # The keywords linearize took before the registry (all of them, at non-default values),
    # each with a method that uses it; rel_step=None still means the method's default.
    model, op = analytic(), POINT
    calls = {
        "perturbation": dict(digits=7, rel_step=0.02, zero_step=1e-5, max_halvings=12, abs_tol=1e-14),
        "central": dict(digits=8, rel_step=None, zero_step=1e-5, levels=4),
        "complex-step": dict(complex_step=1e-30),
    }
    for method, options in calls.items():
        lin = linearize(model, op, method=method, scale=np.ones(4), equilibrium_tol=1e-6, allow_non_equilibrium=True,
                        **options)
        for key, value in options.items():
            assert lin.settings[key] == (1e-3 if value is None else value)
        # Same Jacobian as the closed form, to each method's accuracy (see test_analytic_function).
        rtol = {"perturbation": 1e-6, "central": 1e-9, "complex-step": 1e-14}[method]
        exact = analytic_jacobian(op.x, op.u)
        np.testing.assert_allclose(lin.sys.A, exact[:3, :3], rtol=rtol, atol=rtol * np.max(np.abs(exact)))


def test_an_option_the_method_does_not_take_names_the_option_the_method_and_its_options():
    from linflex import LinflexError

    model, op = euler_equations(np.eye(3)), OperatingPoint(np.zeros(3), np.zeros(3))
    with pytest.raises(LinflexError, match=r"max_halvings=3 applies to method 'perturbation' only, not to "
                                           r"'central'; 'central' takes digits, rel_step, zero_step, levels"):
        linearize(model, op, method="central", max_halvings=3)
    with pytest.raises(ModelError, match=r"unknown option 'step' for method 'complex-step'; 'complex-step' takes "
                                         r"complex_step$"):
        linearize(model, op, method="complex-step", step=1e-20)
    with pytest.raises(ModelError, match=r"digits=8 applies to methods 'perturbation', 'central' only, not to "
                                         r"'autodiff'; 'autodiff' takes no options"):
        linearize(euler_equations(np.eye(3), backend="casadi"), op, method="autodiff", digits=8)
    # "auto" checks the options against the method it resolves to.
    with pytest.raises(ModelError, match=r"levels=4 applies to method 'central' only, not to 'perturbation'; .* "
                                         r"\(method 'auto' is 'perturbation' for this numpy model; name the method\)"):
        linearize(model, op, levels=4)
    # Invalid values keep their messages.
    with pytest.raises(ModelError, match="levels must be an integer of at least 2, got 1"):
        linearize(model, op, method="central", levels=1)
    with pytest.raises(ModelError, match=r"rel_step must lie in \(0, 1\), got 2.0"):
        linearize(model, op, method="perturbation", rel_step=2.0)
    with pytest.raises(ModelError, match="complex_step must be a finite positive number, got -1"):
        linearize(model, op, method="complex-step", complex_step=-1)
    with pytest.raises(ModelError, match="equilibrium_tol must be a finite positive number"):
        linearize(model, op, equilibrium_tol=0.0)


def test_a_method_that_cannot_apply_names_the_ones_that_can():
    numpy_model, op = euler_equations(np.eye(3)), OperatingPoint(np.zeros(3), np.zeros(3))
    casadi_model = euler_equations(np.eye(3), backend="casadi")
    with pytest.raises(MethodUnavailableError, match=r"method 'kane' needs a compiled scene .* this is a model of "
                                                     r"numpy callables: use 'perturbation', 'central' or 'complex-step'"):
        linearize(numpy_model, op, method="kane")
    with pytest.raises(MethodUnavailableError, match=r"this is a CasADi model: use 'perturbation', 'central' or "
                                                     r"'autodiff'$"):
        linearize(casadi_model, op, method="complex-step")
    assert [m for m in METHODS if METHODS[m].applies(numpy_model)] == ["perturbation", "central", "complex-step"]
    assert [m for m in METHODS if METHODS[m].applies(casadi_model)] == ["perturbation", "central", "autodiff"]


class _Forward:
    """A test method: one-sided forward differences, exact to round-off on affine models."""

    calls: list = []

    @staticmethod
    def run(problem, options):
        from linflex.linearize._result import MethodResult

        model, n = problem.model, problem.model.n_states

        def g(z):
            xdot, y = model.evaluate_raw(z[:n], z[n:], problem.t, problem.p)
            return np.concatenate([np.ravel(xdot), np.ravel(y)])

        z0 = np.concatenate([problem.x, problem.u])
        g0 = g(z0)
        columns, errors = [], []
        for j in range(z0.size):
            h = options.step * max(1.0, abs(z0[j]))
            z = z0.copy()
            z[j] += h
            gj = g(z)
            columns.append((gj - g0) / h)
            errors.append(np.finfo(float).eps * (np.abs(gj) + np.abs(g0)) / h)  # forwarded, checked as such
        J, err = np.column_stack(columns), np.column_stack(errors)
        _Forward.calls.append((problem, err))
        return MethodResult(g0[:n], g0[n:], J, err, np.ones(J.shape, dtype=bool), 1 + z0.size)


@pytest.fixture
def forward_method():
    from dataclasses import dataclass

    from linflex.linearize._methods import LinearizationMethod, option, register_method, unregister_method

    @dataclass(frozen=True)
    class ForwardOptions:
        step: float = option(1e-6, "[-]", "step relative to max(|z_j|, 1)")

    register_method(LinearizationMethod("forward", "one-sided forward differences (a test)", ForwardOptions,
                                        _Forward.run))
    _Forward.calls.clear()
    yield METHODS["forward"]
    unregister_method("forward")


@settings(derandomize=True, max_examples=10, deadline=None)
@given(st.integers(min_value=1, max_value=5), st.integers(min_value=0, max_value=2**31 - 1))
def test_a_registered_method_is_dispatched_to(n, seed):
    # Property: linearize hands the registered function the checked point and its options, and
    # wraps what it returns; on an affine model forward differences give the matrices to
    # round-off (reference: the matrices themselves).
    from linflex.linearize._methods import LinearizationMethod, option, register_method, unregister_method

    rng = np.random.default_rng(seed)
    A, B = rng.normal(size=(n, n)), rng.normal(size=(n, 2))
    C = rng.normal(size=(1, n))
    model = NonlinearModel(lambda x, u, t: A @ x + B @ u, lambda x, u, t: C @ x, states=n, inputs=2)
    op = OperatingPoint(rng.normal(size=n), [0.0, 0.0], 0.5)

    from dataclasses import dataclass

    @dataclass(frozen=True)
    class ForwardOptions:
        step: float = option(1e-6, "[-]", "step relative to max(|z_j|, 1)")

    register_method(LinearizationMethod("forward", "one-sided forward differences (a test)", ForwardOptions,
                                        _Forward.run))
    try:
        _Forward.calls.clear()
        lin = linearize(model, op, method="forward", step=1e-5, allow_non_equilibrium=True)
        ((problem, err),) = _Forward.calls
        assert problem.t == 0.5 and np.array_equal(problem.x, op.x) and problem.model is model
        assert lin.method == "forward" and lin.settings["step"] == 1e-5 and lin.n_evaluations == 1 + n + 2
        assert np.array_equal(lin.error_estimate.stacked(), err)
        # Round-off of forward differences of g = A x + B u with the step h = 1e-5 max(|z_j|, 1):
        # a few ulps of the terms |A| |x| over h, about 1e-10 for entries ~ N(0, 1); 1e-8 leaves
        # margin and still catches any mix-up of point, options or blocks (errors of order 1).
        np.testing.assert_allclose(np.hstack([lin.sys.A, lin.sys.B]), np.hstack([A, B]), rtol=0, atol=1e-8)
        np.testing.assert_allclose(lin.sys.C, C, rtol=0, atol=1e-8)
        assert lin.second_order is None and lin.stiffness is None and lin.damping is None
        with pytest.raises(ModelError, match=r"digits=6 applies to methods 'perturbation', 'central' only, not to "
                                             r"'forward'; 'forward' takes step"):
            linearize(model, op, method="forward", digits=6)
    finally:
        unregister_method("forward")
    with pytest.raises(ModelError, match="unknown method 'forward'"):
        linearize(model, op, method="forward")


def test_the_report_command_offers_every_registered_method(forward_method, capsys):
    from linflex.cli import build_parser, main

    for name in METHODS:  # the built-in ones and the one registered by the fixture
        assert build_parser().parse_args(["report", "scene.toml", "--method", name]).method == name
    assert "forward" in METHODS
    with pytest.raises(SystemExit):
        build_parser().parse_args(["report", "scene.toml", "--method", "secant"])
    capsys.readouterr()
    # complex-step cannot apply to a compiled scene (a CasADi model): refused before compiling,
    # with the methods that can.
    scene = Path(__file__).resolve().parents[2] / "examples" / "spacecraft_arrays.toml"
    assert main(["report", str(scene), "--method", "complex-step", "--no-pdf", "-o", "/nonexistent"]) == 2
    err = capsys.readouterr().err
    assert "--method complex-step needs a model of numpy callables" in err
    assert "a scene compiles to a CasADi model; use one of perturbation, central, autodiff, kane, forward" in err
    with pytest.raises(SystemExit):
        main(["report", "--help"])
    help_text = capsys.readouterr().out
    for name, entry in METHODS.items():
        assert f"{name}: {entry.description}" in help_text


@pytest.mark.parametrize("dense_row, sym", [(False, "SX"), (True, "SX"), (False, "MX")])
def test_autodiff_sweeps_equal_the_symbolic_jacobian(dense_row, sym):
    # Independent computation: CasADi's symbolic ca.jacobian of the same expressions. A banded
    # model is swept forward (3 column colours); one dense row beside identity rows is swept in
    # reverse (2 row colours against 8 column colours); the MX model (4 directions per call,
    # the last call padded) adds a linear solve that stays a node.
    import casadi as ca

    from linflex.linearize._autodiff import _build

    x, u = getattr(ca, sym).sym("x", 8), getattr(ca, sym).sym("u", 2)
    if sym == "MX":
        M = ca.diag(2.0 + ca.sin(x)) + 0.1
        rows = [ca.solve(M, ca.cos(x) * u[0] + x[::-1] * x)]
    elif dense_row:
        rows = [ca.sum1(ca.sin(x) * ca.cos(u[0])) * x[0]] + [x[k] * u[1] for k in range(1, 8)]
    else:
        rows = [ca.sin(x[k]) * x[(k + 1) % 8] + u[k % 2] * x[k] ** 2 for k in range(8)]
    xdot = ca.vertcat(*rows)
    y = ca.vertcat(x[0] * u[1], ca.exp(x[3]))
    model = NonlinearModel.from_casadi(xdot, x, u, y)
    assert model.f.is_a("SXFunction") == (sym == "SX")
    fun = _build(model)
    rng = np.random.default_rng(3)
    xv, uv = rng.standard_normal(8), rng.standard_normal(2)
    got = [np.asarray(v) for v in fun(xv, uv, [], 0.0)[2:]]
    exact = ca.Function("J", [x, u], [ca.jacobian(xdot, x), ca.jacobian(xdot, u), ca.jacobian(y, x), ca.jacobian(y, u)])
    for a, b in zip(got, exact(xv, uv)):
        np.testing.assert_allclose(a, np.asarray(b), rtol=1e-13, atol=1e-13)  # both are exact AD: round-off



def test_a_scene_given_to_linearize_is_told_to_compile_first():
    # A hurried user passes the scene itself: a ModelError that says what to do, not a crash.
    from pathlib import Path

    from linflex import load_scene

    scene = load_scene(Path(__file__).resolve().parents[2] / "examples" / "attitude_control.toml")
    with pytest.raises(ModelError, match=r"got Scene: compile it first, linearize\(compile_model\(scene\)\)"):
        linearize(scene, method="autodiff")

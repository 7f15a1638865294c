"""NonlinearModel and OperatingPoint: evaluation, validation and errors."""

import casadi as ca
import numpy as np
import pytest

from linflex import MethodUnavailableError, ModelError, NonlinearModel, OperatingPoint, ShapeError


def pendulum(**kw):
    return NonlinearModel(lambda x, u, t: np.array([x[1], -9.81 * np.sin(x[0]) + u[0]]),
                          lambda x, u, t: np.array([x[0]]), states=["theta", "omega"], inputs=["torque"],
                          outputs=["angle"], **kw)


def test_numpy_and_casadi_models_agree():
    x = ca.SX.sym("x", 2)
    u = ca.SX.sym("u", 1)
    cm = NonlinearModel.from_casadi(ca.vertcat(x[1], -9.81 * ca.sin(x[0]) + u), x, u, x[0],
                                    states=["theta", "omega"], inputs=["torque"], outputs=["angle"])
    for point in ([0.3, -0.2], [1.0, 2.0]):
        a = pendulum().evaluate(point, [0.5])
        b = cm.evaluate(point, [0.5])
        np.testing.assert_allclose(a[0], b[0], rtol=1e-15)  # same arithmetic: equal to round-off
        np.testing.assert_allclose(a[1], b[1], rtol=1e-15)
    assert cm.is_casadi and not pendulum().is_casadi


def test_parameters_are_passed_and_replaceable():
    model = NonlinearModel(lambda x, u, p, t: -p[0] * x, states=1, params={"k": 2.0})
    assert model.evaluate([3.0])[0][0] == -6.0
    assert model.with_params(k=5.0).evaluate([3.0])[0][0] == -15.0
    with pytest.raises(ModelError, match="unknown signal 'kk'"):
        model.with_params(kk=1.0)


def test_output_count_found_by_evaluation():
    model = NonlinearModel(lambda x, u, t: -x, lambda x, u, t: np.array([x[0], 2 * x[0]]), states=1)
    assert model.outputs == ("y0", "y1")


def test_bad_shapes_name_the_argument():
    with pytest.raises(ShapeError, match=r"x has shape \(3,\) but shape \(2,\) was expected"):
        pendulum().evaluate([0, 0, 0], [0])
    with pytest.raises(ShapeError, match=r"u has shape \(2,\)"):
        pendulum().evaluate([0, 0], [0, 0])


def test_model_exceptions_are_chained():
    def f(x, u, t):
        raise ZeroDivisionError("boom")

    model = NonlinearModel(f, states=1)
    with pytest.raises(ModelError, match="ZeroDivisionError: boom") as info:
        model.evaluate([1.0])
    assert isinstance(info.value.__cause__, ZeroDivisionError)


def test_non_finite_values_name_the_entry():
    model = NonlinearModel(lambda x, u, t: np.array([x[0], np.log(x[1])]), states=["a", "b"])
    with np.errstate(divide="ignore"), pytest.raises(ModelError, match=r"d\(b\)/dt = -?(nan|inf)"):
        model.evaluate([1.0, 0.0])


def test_wrong_size_from_f():
    model = NonlinearModel(lambda x, u, t: np.zeros(3), states=2)
    with pytest.raises(ModelError, match="f returned 3 values for 2 states"):
        model.evaluate([0.0, 0.0])


@pytest.mark.parametrize("method", ["perturbation", "central", "complex-step"])
def test_wrong_size_output_is_named_in_linearize(method):
    # A LinflexError naming the function, the count and the signals, from every method (not a
    # numpy broadcasting error, and not a complaint about complex input).
    from linflex import LinflexError
    from linflex.linearize import linearize

    op = OperatingPoint([0.1, 0.0], [0.0])
    too_many = NonlinearModel(lambda x, u, t: np.zeros(3), states=["theta", "omega"], inputs=1)
    with pytest.raises(LinflexError, match=r"^f returned 3 values for 2 states \(theta, omega\)$"):
        linearize(too_many, op, method=method, allow_non_equilibrium=True)
    # h right at the point but not beside it (a data-dependent branch): named with what was being
    # done (the first evaluations beside the point measure the model's noise, all variables moved).
    drifting = NonlinearModel(lambda x, u, t: np.array([x[1], 0.0]),
                              lambda x, u, t: np.zeros(1 if np.real(x[0]) == 0.1 else 2),
                              states=["theta", "omega"], inputs=1, outputs=["angle"])
    with pytest.raises(ModelError, match=r"h returned 2 values for 1 outputs \(angle\) while (perturbing 'theta'|measuring the model's noise)"):
        linearize(drifting, op, method=method, allow_non_equilibrium=True)


def test_wrong_size_casadi_functions_are_refused_when_built():
    x, u, t = ca.SX.sym("x", 2), ca.SX.sym("u"), ca.SX.sym("t")
    with pytest.raises(ModelError, match=r"f returned 3 values for 2 states \(x0, x1\)"):
        NonlinearModel.from_casadi(ca.vertcat(x, u), x, u)
    f = ca.Function("f", [x, u, t], [x])
    h = ca.Function("h", [x, u, t], [ca.vertcat(x, u)])
    with pytest.raises(ModelError, match=r"h returned 3 values for 2 outputs \(a, b\)"):
        NonlinearModel(f, h, states=2, inputs=1, outputs=["a", "b"])


def test_casadi_functions_refused_for_numpy_model():
    with pytest.raises(MethodUnavailableError, match="perturbation"):
        pendulum().casadi_functions()


def test_casadi_function_arity_checked():
    x = ca.SX.sym("x")
    f = ca.Function("f", [x], [x])
    with pytest.raises(ModelError, match="expected 3"):
        NonlinearModel(f, states=1)


def test_operating_point_is_frozen_and_validated():
    op = OperatingPoint([1.0, 2.0], [0.5], t=3.0)
    with pytest.raises(ValueError):
        op.x[0] = 0.0
    assert op == OperatingPoint([1.0, 2.0], [0.5], t=3.0)
    with pytest.raises(ShapeError, match="x must be a vector"):
        OperatingPoint(np.zeros((2, 2)))
    with pytest.raises(ShapeError, match=r"x\[1\] is not finite"):
        OperatingPoint([0.0, np.inf])

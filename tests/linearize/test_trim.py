"""find_operating_point: trim for equilibria and steady motions, checked against closed forms."""

import numpy as np
import pytest

from linflex import ConvergenceError, ModelError, NonlinearModel
from linflex.linearize import find_operating_point, linearize

from .models import MU_EARTH, euler_equations, orbit_and_pitch


def pendulum():
    return NonlinearModel(lambda x, u, t: np.array([x[1], -9.81 * np.sin(x[0]) + u[0]]),
                          states=["theta", "omega"], inputs=["torque"])


def test_holding_torque_of_a_pendulum():
    # Closed form: holding theta requires torque = g sin(theta).
    trim = find_operating_point(pendulum(), [0.8, 0.3], [0.0], fix_states=["theta"], free=["torque"])
    assert trim.success and trim.free_inputs == ("torque",) and trim.free_states == ("omega",)
    assert trim.op.u[0] == pytest.approx(9.81 * np.sin(0.8), rel=1e-12)
    assert trim.op.x[1] == pytest.approx(0.0, abs=1e-12)
    assert trim.max_scaled_residual <= 1e-10


def test_circular_orbit_rate_found_with_radius_held():
    # Closed form: the circular orbit rate at radius r is sqrt(mu / r^3).
    r = 7.0e6
    trim = find_operating_point(orbit_and_pitch(), [r, 0.0, 1e-3, 0.0, 0.0], [0.0, 0.0], fix_states=["r"])
    assert trim.op.x[2] == pytest.approx(np.sqrt(MU_EARTH / r**3), rel=1e-10)
    assert trim.op.x[0] == r
    # The trimmed point is an equilibrium that linearize accepts.
    assert linearize(orbit_and_pitch(), trim.op, method="central").is_equilibrium


def test_steady_spin_with_rate_held_casadi():
    # A spin about a principal axis is a steady motion of Euler's equations: held rate, other
    # rates trimmed to zero (closed form), exact Jacobians from the CasADi graph.
    model = euler_equations(np.diag([30.0, 20.0, 10.0]), backend="casadi")
    trim = find_operating_point(model, [0.05, 0.02, 1.5], np.zeros(3), fix_states=["wz"])
    np.testing.assert_allclose(trim.op.x, [0.0, 0.0, 1.5], atol=1e-10)
    assert trim.n_evaluations > 0 and trim.seconds > 0


def test_failure_is_reported_with_the_residual():
    # Holding theta with no free torque has no solution unless theta = 0 or pi.
    with pytest.raises(ConvergenceError, match=r"scaled residual .* at d\(omega\)/dt"):
        find_operating_point(pendulum(), [0.8, 0.0], [0.0], fix_states=["theta"])
    result = find_operating_point(pendulum(), [0.8, 0.0], [0.0], fix_states=["theta"], raise_on_failure=False)
    assert not result.success
    assert result.residual[1] == pytest.approx(-9.81 * np.sin(0.8), rel=1e-9)


def test_bad_names():
    with pytest.raises(ModelError, match="did you mean 'theta'"):
        find_operating_point(pendulum(), [0.0, 0.0], [0.0], fix_states=["thetta"])
    with pytest.raises(ModelError, match="neither a state nor an input"):
        find_operating_point(pendulum(), [0.0, 0.0], [0.0], free=["speed"])
    with pytest.raises(ModelError, match="nothing to solve for"):
        find_operating_point(pendulum(), [0.0, 0.0], [0.0], fix_states=["theta", "omega"])

"""linearize_along: linear time-varying models along a simulated spin-up."""

import casadi as ca
import numpy as np
import pytest

from linflex import ModelError, NonlinearModel, simulate
from linflex.linearize import linearize_along

OMEGA0, SOUTHWELL, ZETA, SPIN_ACCEL = 2.0, 1.193, 0.01, 0.5  # rad/s, -, -, rad/s^2


def spin_up_model():
    """A spinning appendage mode that stiffens with spin: q'' + 2 zeta w0 q' + (w0^2 + K W^2) q = 0.

    States: spin rate W [rad/s], modal coordinate q and its rate; input: spin acceleration.
    """
    x = ca.SX.sym("x", 3)
    u = ca.SX.sym("u", 1)
    spin, q, qd = x[0], x[1], x[2]
    qdd = -(OMEGA0**2 + SOUTHWELL * spin**2) * q - 2 * ZETA * OMEGA0 * qd
    return NonlinearModel.from_casadi(ca.vertcat(u, qd, qdd), x, u, states=["spin", "q", "q_dot"],
                                      inputs=["spin_accel"])


def test_frozen_time_frequencies_follow_the_spin_up():
    model = spin_up_model()
    timepts = np.linspace(0.0, 8.0, 17)
    response = simulate(model, timepts, x0=[0.0, 0.0, 0.0], inputs=[SPIN_ACCEL])
    along = linearize_along(model, response, times=timepts[::4])
    modes = along.frozen_time_modes()
    # Closed form: frozen-time frequency sqrt(w0^2 + K W(t)^2) with W(t) = a t (q stays 0, so
    # the spin row adds only a zero eigenvalue).
    expected = np.sqrt(OMEGA0**2 + SOUTHWELL * (SPIN_ACCEL * along.times) ** 2)
    oscillating = np.max(modes.frequencies, axis=1)
    np.testing.assert_allclose(oscillating, expected, rtol=1e-7)  # integrator tolerance 1e-8
    # The tracked branch keeps the positive-imaginary eigenvalue in one column.
    column = np.argmax(modes.eigenvalues[0].imag)
    assert np.all(modes.eigenvalues[:, column].imag > 0)
    # Every instant keeps its affine term: the nominal spin-up rate.
    assert all(lin.residual[0] == pytest.approx(SPIN_ACCEL) for lin in along.linearizations)
    assert along.max_relative_error_estimate == 0.0  # autodiff


def test_instants_must_be_samples():
    model = spin_up_model()
    response = simulate(model, [0.0, 1.0, 2.0], x0=[0.0, 0.0, 0.0], inputs=[SPIN_ACCEL])
    with pytest.raises(ModelError, match=r"1.5 s is not a sample time .*nearest 1.0 s"):
        linearize_along(model, response, times=[1.5])

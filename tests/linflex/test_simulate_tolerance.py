"""simulate with one absolute tolerance per state: against the closed form, and exactly the
scaled problem CVODES is given (see simulate's Notes)."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from linflex import NonlinearModel, ShapeError, simulate


def oscillator(omega: float, force: float = 0.0):
    """``q'' = -omega^2 q + force``, states (q, v): a modal coordinate of an undamped mode."""
    x, u, t = ca.SX.sym("x", 2), ca.SX.sym("u", 1), ca.SX.sym("t")
    f = ca.Function("f", [x, u, t], [ca.vertcat(x[1], -omega**2 * x[0] + force + u[0])])
    return NonlinearModel(f, states=["q", "v"], inputs=["u"])


@settings(derandomize=True, max_examples=8, deadline=None)
@given(st.floats(2.0, 40.0), st.floats(-12.0, -3.0), st.sampled_from(["cvodes", "cvodes-adams", "scipy-DOP853", "exponential"]))
def test_per_state_tolerance_keeps_small_states_accurate(omega, log_amplitude, method):
    # Closed form: q = a cos(omega t), v = -a omega sin(omega t). With atol at 1e-8 of each
    # state's amplitude (as rtol) the global error over 10 periods stays within 1e-4 of each
    # amplitude, whatever the amplitude (1e-12 to 1e-3; one atol of 1e-10 for both would leave
    # the small ones unresolved).
    a = 10.0**log_amplitude
    t = np.linspace(0.0, 10 * 2 * np.pi / omega, 201)
    r = simulate(oscillator(omega), t, [a, 0.0], method=method, rtol=1e-8, atol=[1e-8 * a, 1e-8 * a * omega])
    exact = np.column_stack([a * np.cos(omega * t), -a * omega * np.sin(omega * t)])
    assert np.max(np.abs(r.x[:, 0] - exact[:, 0])) <= 1e-4 * a
    assert np.max(np.abs(r.x[:, 1] - exact[:, 1])) <= 1e-4 * a * omega
    np.testing.assert_array_equal(r.atol, [1e-8 * a, 1e-8 * a * omega])


@pytest.mark.parametrize("method", ["cvodes", "cvodes-adams"])
def test_per_state_tolerance_is_the_scaled_problem(method):
    # Independent computation: the states scaled by hand, z = x / w, integrated with the one
    # absolute tolerance min(atol); the same steps, so the same trajectory to round-off.
    omega, force, w = 12.0, 3.0, np.array([1.0, 12.0])
    t = np.linspace(0.0, 3.0, 31)
    x0 = np.array([1e-3, 0.0])
    r = simulate(oscillator(omega, force), t, x0, method=method, rtol=1e-9, atol=1e-11 * w)
    z, u, s = ca.SX.sym("z", 2), ca.SX.sym("u", 1), ca.SX.sym("t")
    scaled = NonlinearModel(ca.Function("g", [z, u, s], [ca.vertcat(z[1] * w[1] / w[0],
                                                                       (-omega**2 * z[0] * w[0] + force) / w[1])]),
                            states=["z0", "z1"], inputs=["u"])
    by_hand = simulate(scaled, t, x0 / w, method=method, rtol=1e-9, atol=1e-11).x * w
    for k in range(2):
        np.testing.assert_allclose(r.x[:, k], by_hand[:, k], rtol=0, atol=1e-12 * np.max(np.abs(by_hand[:, k])))


@pytest.mark.parametrize("atol, match", [([1e-8], "shape"), ([1e-8, 0.0], "positive"), ([1e-8, np.nan], "positive"),
                                         (-1.0, "positive"), ("tight", "atol")])
def test_bad_absolute_tolerances_are_refused(atol, match):
    with pytest.raises(ShapeError, match=match):
        simulate(oscillator(1.0), [0.0, 1.0], [1.0, 0.0], method="cvodes", atol=atol)

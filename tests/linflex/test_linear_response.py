"""Time responses of linear systems by matrix exponentials: closed forms and scipy.signal.lsim."""

import control
import numpy as np
import pytest
import scipy.linalg
import scipy.signal
from hypothesis import given, settings
from hypothesis import strategies as st

import linflex
from linflex import (
    LinearSystem,
    ModelError,
    ShapeError,
    TimeResponse,
    forced_response,
    impulse_response,
    initial_response,
    step_response,
)


def lag(tau=0.5, gain=3.0):
    # tau x' = -x + gain u, y = x: step response gain (1 - exp(-t / tau)).
    return LinearSystem([[-1.0 / tau]], [[gain / tau]], [[1.0]], states=["x"], inputs=["u"], outputs=["y"])


def double_integrator():
    return LinearSystem([[0.0, 1.0], [0.0, 0.0]], [[0.0], [1.0]], [[1.0, 0.0]],
                        states=["pos", "vel"], inputs=["force"], outputs=["pos"])


def oscillator(wn=2.0, zeta=0.1):
    return LinearSystem([[0.0, 1.0], [-wn**2, -2 * zeta * wn]], [[0.0], [1.0]], [[1.0, 0.0]],
                        states=["q", "q_dot"], inputs=["torque"], outputs=["angle"])


def test_first_order_lag_step_on_a_nonuniform_grid():
    t = np.concatenate([[0.0], np.cumsum(np.random.default_rng(1).uniform(0.001, 0.3, 60))])
    r = step_response(lag(), t)
    assert isinstance(r, TimeResponse) and r.method == "expm-zoh"
    assert (r.states, r.inputs, r.outputs) == (("x",), ("u",), ("y",))
    # Closed form 3 (1 - exp(-2 t)); exact to round-off: 1e-14 absolute on values up to 3.
    np.testing.assert_allclose(r["y"], 3.0 * (1.0 - np.exp(-2.0 * t)), rtol=0, atol=1e-14)
    np.testing.assert_array_equal(r.u, np.ones((t.size, 1)))
    assert not r.x.flags.writeable and r.rtol > 0


def test_double_integrator_is_exact_at_long_times():
    # A unit force from rest: pos = t^2 / 2, vel = t (polynomials: expm of a nilpotent matrix is
    # exact); at t = 1e4 s round-off grows like eps * t^2 / 2 per step sum, 1e-12 relative.
    t = np.linspace(0.0, 1e4, 1001)
    r = step_response(double_integrator(), t)
    np.testing.assert_allclose(r.x[:, 0], t**2 / 2, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(r.x[:, 1], t, rtol=1e-12, atol=1e-12)
    # A ramp force u = t with a first-order hold is exact: pos = t^3 / 6, vel = t^2 / 2.
    t = np.linspace(0.0, 10.0, 41)
    ramp = forced_response(double_integrator(), t, t[:, None], hold="foh")
    np.testing.assert_allclose(ramp["pos"], t**3 / 6, rtol=1e-12, atol=1e-13)
    np.testing.assert_allclose(ramp["vel"], t**2 / 2, rtol=1e-12, atol=1e-13)
    # ...while a zero-order hold of the same samples lags: pos = sum of the held ramp (closed
    # form for a staircase t_k: pos(T) = T^3/6 - h T^2/4 + ... differs by O(h)), not t^3 / 6.
    zoh = forced_response(double_integrator(), t, t[:, None])
    assert abs(zoh["pos"][-1] - 1000 / 6) > 1.0


def test_damped_oscillator_impulse_and_initial_responses():
    wn, zeta = 2.0, 0.1
    wd, sigma = wn * np.sqrt(1 - zeta**2), zeta * wn
    t = np.linspace(0.0, 30.0, 3001)
    # Impulse response of 1 / (s^2 + 2 zeta wn s + wn^2): exp(-sigma t) sin(wd t) / wd.
    r = impulse_response(oscillator(wn, zeta), t)
    # 3000 steps of round-off (measured 2e-14): 1e-13.
    np.testing.assert_allclose(r["angle"], np.exp(-sigma * t) * np.sin(wd * t) / wd, rtol=0, atol=1e-13)
    np.testing.assert_array_equal(r.u, 0.0)
    # Free response from q = 1: exp(-sigma t) (cos wd t + sigma / wd sin wd t).
    r = initial_response(oscillator(wn, zeta), t, [1.0, 0.0])
    expected = np.exp(-sigma * t) * (np.cos(wd * t) + sigma / wd * np.sin(wd * t))
    np.testing.assert_allclose(r["q"], expected, rtol=0, atol=1e-13)


def test_undamped_oscillator_keeps_its_amplitude_over_many_periods():
    # zeta = 0: q = cos(2 t) over 1000 periods (~3142 s) in 20000 steps: round-off of expm's
    # entries (1 ulp) accumulates linearly to ~2e-12 (measured); a step size taken from a plain
    # sum of the steps drifted in phase by 1e-9, so 1e-11 also guards the exact mean step.
    t = np.linspace(0.0, 1000 * np.pi, 20001)
    r = initial_response(oscillator(2.0, 0.0), t, [1.0, 0.0])
    np.testing.assert_allclose(r["q"], np.cos(2.0 * t), rtol=0, atol=1e-11)


def random_stable(rng, n, m, p):
    A = rng.normal(size=(n, n))
    A -= (np.max(np.linalg.eigvals(A).real) + rng.uniform(0.1, 1.0)) * np.eye(n)
    return LinearSystem(A, rng.normal(size=(n, m)), rng.normal(size=(p, n)), rng.normal(size=(p, m)))


@settings(derandomize=True, max_examples=25, deadline=None)
@given(st.integers(1, 6), st.integers(1, 3), st.sampled_from(["zoh", "foh"]), st.integers(0, 2**31 - 1))
def test_agrees_with_scipy_lsim(n, m, hold, seed):
    # Independent computation: scipy.signal.lsim on a uniform grid (interp=True is its
    # first-order hold); both are exact, so they agree to round-off (1e-9 on O(1) signals).
    rng = np.random.default_rng(seed)
    sys = random_stable(rng, n, m, 2)
    t = np.linspace(0.0, 5.0, 101)
    U = rng.normal(size=(t.size, m))
    x0 = rng.normal(size=n)
    r = forced_response(sys, t, U, x0, hold=hold)
    _, y, x = scipy.signal.lsim((sys.A, sys.B, sys.C, sys.D), U, t, X0=x0, interp=(hold == "foh"))
    np.testing.assert_allclose(r.x, x.reshape(t.size, n), rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(r.y, y.reshape(t.size, 2), rtol=1e-9, atol=1e-9)


@settings(derandomize=True, max_examples=25, deadline=None)
@given(st.integers(1, 6), st.integers(0, 2**31 - 1))
def test_free_motion_on_random_grids_is_expm(n, seed):
    # Reference: x(t_k) = expm(A (t_k - t_0)) x0 by one exponential per sample.
    rng = np.random.default_rng(seed)
    sys = random_stable(rng, n, 1, 1)
    t = 2.0 + np.concatenate([[0.0], np.cumsum(rng.uniform(1e-3, 0.5, 15))])
    x0 = rng.normal(size=n)
    r = initial_response(sys, t, x0)
    expected = np.array([scipy.linalg.expm(sys.A * (tk - t[0])) @ x0 for tk in t])
    np.testing.assert_allclose(r.x, expected, rtol=1e-10, atol=1e-12)


def test_one_exponential_per_distinct_step(monkeypatch):
    calls = []
    real_expm = scipy.linalg.expm
    monkeypatch.setattr(scipy.linalg, "expm", lambda M: calls.append(M.shape) or real_expm(M))
    # np.linspace's steps differ in their last bits: still one step size.
    step_response(lag(), np.linspace(0.0, 7.3, 1000))
    assert len(calls) == 1
    calls.clear()
    step_response(lag(), np.concatenate([np.linspace(0.0, 1.0, 11), np.linspace(1.5, 3.0, 4)]))
    assert len(calls) == 2  # steps 0.1 and 0.5
    calls.clear()
    # Steps growing by 1e-15 each (below the grouping width 8 eps max|t| = 3.5e-15 s) span
    # 2e-13 s: chained into one group their mean shifts the times by up to 5e-12 s (an error
    # 8.6e-12 in y, measured); anchored groups keep every step within 3.5e-15 s of the true
    # one, a time shift at the round-off of t (measured error 1.2e-14 in y; bound 1e-13).
    t = np.concatenate([[0.0], np.cumsum(0.01 + 1e-15 * np.arange(200))])
    r = step_response(lag(), t)
    assert len(calls) > 1
    np.testing.assert_allclose(r["y"], 3.0 * (1.0 - np.exp(-2.0 * t)), rtol=0, atol=1e-13)


def test_inputs_by_name_and_callable_and_other_system_types():
    sys = LinearSystem(np.diag([-1.0, -3.0]), np.eye(2), np.eye(2), inputs=["motor.x", "motor.y"])
    t = np.linspace(0.0, 2.0, 21)
    by_name = forced_response(sys, t, {"motor.y": 2.0})
    by_array = forced_response(sys, t, np.column_stack([np.zeros_like(t), 2.0 * np.ones_like(t)]))
    np.testing.assert_array_equal(by_name.x, by_array.x)
    # x2 = 2/3 (1 - exp(-3 t)) (closed form).
    np.testing.assert_allclose(by_name.x[:, 1], 2 / 3 * (1 - np.exp(-3 * t)), atol=1e-15)
    sampled = forced_response(sys, t, lambda tk: [np.sin(tk), 0.0], hold="foh")
    np.testing.assert_array_equal(sampled.u[:, 0], np.sin(t))
    np.testing.assert_allclose(step_response(sys, t, input="motor.x")["y0"], 1 - np.exp(-t), atol=1e-15)
    # python-control and (num, den) inputs: 3 / (0.5 s + 1) is the lag above.
    for given_ in (control.tf([3.0], [0.5, 1.0]), ([3.0], [0.5, 1.0])):
        np.testing.assert_allclose(step_response(given_, t).y[:, 0], 3 * (1 - np.exp(-2 * t)), atol=1e-14)


def test_bad_arguments_are_refused():
    mimo = LinearSystem(-np.eye(2), np.eye(2), np.eye(2), inputs=["a", "b"])
    with pytest.raises(ModelError, match=r"input: the system has 2 inputs \['a', 'b'\]; name one"):
        step_response(mimo, [0.0, 1.0])
    with pytest.raises(ModelError, match="did you mean 'a'"):
        impulse_response(mimo, [0.0, 1.0], input="aa")
    with pytest.raises(ShapeError, match="strictly increasing"):
        step_response(lag(), [0.0, 1.0, 1.0])
    with pytest.raises(ShapeError, match="at least 2 times"):
        step_response(lag(), [0.0])
    with pytest.raises(ModelError, match="hold must be one of"):
        forced_response(lag(), [0.0, 1.0], hold="linear")
    with pytest.raises(ShapeError, match="x0"):
        initial_response(lag(), [0.0, 1.0], [1.0, 2.0])
    with pytest.raises(ShapeError, match=r"inputs has shape \(3, 2\)"):
        forced_response(lag(), [0.0, 1.0, 2.0], np.ones((3, 2)))
    # a discrete system is taken at its own sample instants only (x[1] = 0.5 x[0] + 1 = 1)
    assert step_response(control.ss([[0.5]], [[1.0]], [[1.0]], [[0.0]], dt=0.1), [0.0, 0.1]).y[-1, 0] == 1.0
    with pytest.raises(ShapeError, match="spaced by dt = 0.1 s"):
        step_response(control.ss([[0.5]], [[1.0]], [[1.0]], [[0.0]], dt=0.1), [0.0, 1.0])


def test_exported_from_linflex():
    assert linflex.forced_response is forced_response and "step_response" in linflex.__all__
    assert "initial_response" in linflex.simulation.__all__


def test_static_gains_and_systems_without_inputs():
    # A static gain 5 / 2 has no states: y = 2.5 u at every sample (exact).
    r = step_response(([5.0], [2.0]), [0.0, 1.0, 2.0])
    assert r.x.shape == (3, 0)
    np.testing.assert_array_equal(r.y[:, 0], 2.5)
    # No inputs: the free motion of x' = -x from [1, 1] seen by y = x1 + x2 is 2 exp(-t).
    free = LinearSystem(-np.eye(2), np.zeros((2, 0)), np.ones((1, 2)))
    r = initial_response(free, [0.0, 1.0], [1.0, 1.0])
    assert r.u.shape == (2, 0)
    np.testing.assert_allclose(r.y[:, 0], [2.0, 2.0 * np.exp(-1.0)], rtol=1e-15)


@settings(derandomize=True, max_examples=20, deadline=None)
@given(st.integers(1, 5), st.floats(0.0, 0.7), st.floats(0.0, 0.9), st.integers(0, 2**31 - 1))
def test_initial_and_impulse_responses_with_delays_are_one_free_motion(n, tau_in, tau_out, seed):
    # One routine for both (the free motion from a state at t0 + tau), checked against two
    # independent computations: forced_response's delayed path with zero inputs (initial), and
    # expm(A (t - t0 - tau)) B e_0 by one exponential per sample (impulse), zero before tau.
    rng = np.random.default_rng(seed)
    base = random_stable(rng, n, 2, 2)
    sys = base.with_(input_delay=[tau_in, 0.0], output_delay=[tau_out, 0.0])
    t = 1.0 + np.concatenate([[0.0], np.cumsum(rng.uniform(0.05, 0.3, 20))])
    x0 = rng.normal(size=n)
    free, forced = initial_response(sys, t, x0), forced_response(sys, t, None, x0)
    np.testing.assert_allclose(free.x, forced.x, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(free.y, forced.y, rtol=1e-10, atol=1e-12)
    r = impulse_response(sys, t, input=0)
    s = t - t[0] - tau_in
    expected = np.array([scipy.linalg.expm(base.A * sk) @ base.B[:, 0] if sk >= -1e-12 else np.zeros(n) for sk in s])
    np.testing.assert_allclose(r.x, expected, rtol=1e-10, atol=1e-12)
    y_expected = np.array([scipy.linalg.expm(base.A * (sk - tau_out)) @ base.B[:, 0] if sk - tau_out >= -1e-12
                           else np.zeros(n) for sk in s]) @ base.C[0]
    np.testing.assert_allclose(r.y[:, 0], y_expected, rtol=1e-10, atol=1e-12)

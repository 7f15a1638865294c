"""Time responses of discrete and delayed linear systems (linflex/simulation/_linear_response.py).

References: closed forms of first-order systems, ``scipy.signal.dstep`` / ``dimpulse``, and
:func:`linflex.discretize` (the exact zero-order-hold discretization of a fractional input delay,
an independent path through the Franklin-Powell construction).
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.signal
from hypothesis import given, settings
from hypothesis import strategies as st

from linflex import (
    LinearSystem,
    ModelError,
    ShapeError,
    discretize,
    forced_response,
    impulse_response,
    initial_response,
    step_response,
)

SETTINGS = settings(derandomize=True, max_examples=10, deadline=None)


@SETTINGS
@given(a=st.floats(-0.95, 0.95), b=st.floats(0.1, 3.0), dt=st.floats(0.01, 1.0))
def test_discrete_step_response_is_the_closed_form(a, b, dt):
    d = LinearSystem([[a]], [[b]], [[1.0]], dt=dt)
    k = np.arange(30)
    r = step_response(d, k * dt)
    # closed form: y[k] = b (1 - a^k) / (1 - a)
    np.testing.assert_allclose(r.y[:, 0], b * (1 - a**k) / (1 - a), rtol=1e-12, atol=1e-14)
    assert r.method == "recursion"
    # reference: scipy.signal.dstep
    _, (ys,) = scipy.signal.dstep((d.A, d.B, d.C, d.D, dt), n=30)   # n samples, or n - 1 by its rounding
    np.testing.assert_allclose(r.y[:len(ys), 0], ys[:, 0], rtol=1e-12, atol=1e-14)


def test_discrete_impulse_is_the_unit_pulse_of_scipy_dimpulse():
    d = LinearSystem([[0.5, 0.1], [0.0, 0.8]], [[1.0], [0.5]], [[1.0, 1.0]], [[0.3]], dt=0.1)
    r = impulse_response(d, np.arange(12) * 0.1)
    _, (ys,) = scipy.signal.dimpulse((d.A, d.B, d.C, d.D, 0.1), n=12)
    assert len(ys) >= 11
    np.testing.assert_allclose(r.y[:len(ys), 0], ys[:, 0], rtol=1e-13, atol=1e-15)


def test_whole_period_delays_of_a_discrete_system_shift_the_sequences():
    d = LinearSystem([[0.7]], [[1.0]], [[1.0]], dt=0.1)
    k = np.arange(20)
    u = np.sin(k)[:, None]
    y0 = forced_response(d, k * 0.1, u).y[:, 0]
    y = forced_response(d.with_(input_delay=0.2, output_delay=0.1), k * 0.1, u).y[:, 0]
    np.testing.assert_array_equal(y[3:], y0[:-3])
    assert not y[:3].any()


@SETTINGS
@given(seed=st.integers(0, 2**31), frac=st.floats(0.05, 2.9))
def test_continuous_input_delay_at_the_samples_equals_the_exact_zoh_discretization(seed, frac):
    dt = 0.1
    rng = np.random.default_rng(seed)
    A = rng.normal(size=(3, 3))
    A -= (np.max(np.linalg.eigvals(A).real) + 0.3) * np.eye(3)
    sys = LinearSystem(A, rng.normal(size=(3, 1)), rng.normal(size=(2, 3)), rng.normal(size=(2, 1)),
                       input_delay=frac * dt)
    t = np.arange(40) * dt
    u = rng.normal(size=(40, 1))
    r = forced_response(sys, t, u)
    # reference: the discrete system from discretize (Franklin-Powell states for the fraction)
    rd = forced_response(discretize(sys, dt), t, u)
    np.testing.assert_allclose(r.y, rd.y, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(r.x, rd.x[:, :3], rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize("where", ["input_delay", "output_delay"])
def test_delayed_step_and_impulse_of_a_lag_are_the_shifted_closed_forms(where):
    lag = LinearSystem([[-2.0]], [[2.0]], [[1.0]])
    t = np.linspace(0.0, 2.0, 41)
    tau = 0.37
    r = step_response(lag.with_(**{where: tau}), t)
    # closed form: 1 - exp(-2 (t - tau)) after the delay, 0 before
    np.testing.assert_allclose(r.y[:, 0], np.where(t >= tau, 1 - np.exp(-2 * (t - tau)), 0.0), atol=1e-14)
    ri = impulse_response(lag.with_(**{where: tau}), t)
    np.testing.assert_allclose(ri.y[:, 0], np.where(t >= tau, 2 * np.exp(-2 * (t - tau)), 0.0), atol=1e-14)


def test_an_output_delay_hides_the_initial_motion_until_it_has_passed():
    sys = LinearSystem([[-1.0]], [[1.0]], [[1.0]], output_delay=0.5)
    t = np.linspace(0.0, 2.0, 21)
    r = initial_response(sys, t, [1.0])
    np.testing.assert_allclose(r.y[:, 0], np.where(t >= 0.5, np.exp(-(t - 0.5)), 0.0), atol=1e-14)
    np.testing.assert_allclose(r.x[:, 0], np.exp(-t), rtol=1e-14)


def test_discrete_time_points_and_holds_are_checked():
    d = LinearSystem([[0.5]], [[1.0]], [[1.0]], dt=0.1)
    with pytest.raises(ShapeError, match="spaced by dt = 0.1 s"):
        step_response(d, [0.0, 0.1, 0.25])
    with pytest.raises(ModelError, match="hold='foh'"):
        forced_response(d, [0.0, 0.1], hold="foh")


@SETTINGS
@given(seed=st.integers(0, 2**31), tau_in=st.floats(0.0, 0.35), tau_out=st.floats(0.01, 0.35))
def test_an_output_delay_is_the_undelayed_output_read_earlier(seed, tau_in, tau_out):
    rng = np.random.default_rng(seed)
    A = rng.normal(size=(3, 3))
    A -= (np.max(np.linalg.eigvals(A).real) + 0.3) * np.eye(3)
    base = LinearSystem(A, rng.normal(size=(3, 1)), rng.normal(size=(1, 3)), rng.normal(size=(1, 1)),
                        input_delay=tau_in)
    t = np.arange(25) * 0.1
    u = rng.normal(size=(25, 1))
    x0 = rng.normal(size=3)
    r = forced_response(base.with_(output_delay=tau_out), t, u, x0)
    # reference: the input-delayed system (checked above against discretize) on a grid that also
    # holds t - tau_out, with the same held input, read at t - tau_out
    s = t - tau_out
    grid = np.unique(np.concatenate([t, s[s >= 0]]))
    held = u[np.clip(np.searchsorted(t, grid + 1e-12, side="right") - 1, 0, 24)]
    ref = forced_response(base, grid, held, x0)
    k = np.searchsorted(grid, s - 1e-12)
    expected = np.where(s >= -1e-12, ref.y[np.clip(k, 0, grid.size - 1), 0], 0.0)
    np.testing.assert_allclose(r.y[:, 0], expected, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(r.x, forced_response(base, t, u, x0).x, rtol=1e-12, atol=1e-14)

"""frequency_response and frequency_grid of discrete and delayed systems (frequency/_sampled.py).

References: python-control 0.10.2's ``frequency_response`` of discrete systems (evaluation at
``exp(j w dt)``), dense complex solves at ``z`` done here, the closed form ``exp(-j w tau)``.
"""

from __future__ import annotations

import control
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from linflex import LinearSystem, ShapeError, discretize
from linflex.frequency import frequency_grid, frequency_response

SETTINGS = settings(derandomize=True, max_examples=10, deadline=None)


def flexible_plant(zeta: float = 0.01) -> LinearSystem:
    """1/(s^2) rigid body plus a 4 rad/s mode, force to angle."""
    A = np.array([[0, 1, 0, 0], [0, 0, 0, 0], [0, 0, 0, 1], [0, 0, -16.0, -8.0 * zeta]])
    return LinearSystem(A, [[0], [1.0], [0], [0.5]], [[1.0, 0, 1.0, 0]])


def at_z(sys: LinearSystem, z: complex) -> np.ndarray:
    return sys.D + sys.C @ np.linalg.solve(z * np.eye(sys.n_states) - sys.A, sys.B)


@SETTINGS
@given(T=st.floats(0.02, 0.5), zeta=st.floats(0.001, 0.2))
def test_discrete_response_is_the_response_on_the_unit_circle(T, zeta):
    d = discretize(flexible_plant(zeta), T)
    fr = frequency_response(d)
    assert fr.dt == T and fr.grid == "auto"
    assert 0 < fr.omega[0] and fr.omega[-1] < np.pi / T and np.all(np.diff(fr.omega) > 0)
    # reference: dense complex solves at z = exp(j w T)
    ref = np.array([at_z(d, np.exp(1j * w * T))[0, 0] for w in fr.omega])
    err = np.abs(fr.response[:, 0, 0] - ref) / np.max(np.abs(ref))
    assert np.max(err) <= max(10 * fr.error_estimate, 1e-12)
    # reference: python-control's discrete frequency response
    mag, phase, _ = control.frequency_response(d.to_control(), fr.omega[:20])
    np.testing.assert_allclose(np.abs(fr.response[:20, 0, 0]), mag, rtol=1e-9)


def test_a_discrete_resonance_is_resolved_by_the_automatic_grid():
    T = 0.05
    d = discretize(flexible_plant(0.001), T)
    fr = frequency_response(d)
    # reference: the peak near the mode by a dense scan on the unit circle (bounded search)
    w = np.linspace(3.9, 4.1, 200001)
    dense = np.abs([at_z(d, np.exp(1j * x * T))[0, 0] for x in w[::100]]).max()
    assert 20 * np.log10(np.abs(fr.response).max() / dense) > -0.06


def test_user_frequencies_of_a_sampled_system_stop_at_the_nyquist_frequency():
    T = 0.1
    d = discretize(flexible_plant(), T)
    fr = frequency_response(d, [1.0, np.pi / T])
    # at the Nyquist frequency z = -1
    np.testing.assert_allclose(fr.response[-1], at_z(d, -1.0), rtol=1e-9)
    with pytest.raises(ShapeError, match=r"above the Nyquist frequency pi/dt = 31.4159 rad/s"):
        frequency_response(d, [40.0])
    assert frequency_grid(d)[-1] < np.pi / T


@SETTINGS
@given(tau_in=st.floats(0.0, 0.5), tau_out=st.floats(0.0, 0.5))
def test_delays_multiply_the_response_by_exp_minus_j_omega_tau_exactly(tau_in, tau_out):
    sys = flexible_plant()
    delayed = sys.with_(input_delay=tau_in, output_delay=tau_out)
    omega = np.array([0.3, 1.0, 3.9, 10.0, 100.0])
    fr0 = frequency_response(sys, omega)
    fr1 = frequency_response(delayed, omega)
    # closed form: G(jw) exp(-j w (tau_in + tau_out))
    np.testing.assert_allclose(fr1.response[:, 0, 0], fr0.response[:, 0, 0] * np.exp(-1j * omega * (tau_in + tau_out)),
                               rtol=1e-14, atol=0)
    np.testing.assert_array_equal(frequency_grid(delayed), frequency_grid(sys))


def test_whole_period_delays_of_a_discrete_system_are_z_to_the_minus_k():
    T = 0.1
    d = discretize(flexible_plant(), T).with_(input_delay=0.2)
    fr = frequency_response(d, [0.5, 5.0, 30.0])
    z = np.exp(1j * fr.omega * T)
    ref = np.array([at_z(d, zz)[0, 0] * zz**-2 for zz in z])
    np.testing.assert_allclose(fr.response[:, 0, 0], ref, rtol=1e-12)


def test_poles_and_zeros_of_discrete_and_delayed_systems():
    from linflex.frequency import poles, zeros

    d = discretize(LinearSystem([[0, 1], [0, 0]], [[0], [1]], [[1, 0]]), 0.1)
    # reference: the ZOH double integrator (T^2/2) (z + 1) / (z - 1)^2
    np.testing.assert_allclose(poles(d), [1.0, 1.0], atol=1e-12)
    np.testing.assert_allclose(zeros(d), [-1.0], atol=1e-12)
    # z^-2 adds two poles at the origin; a continuous delay adds none
    np.testing.assert_allclose(np.sort(np.abs(poles(d.with_(input_delay=0.2)))), [0.0, 0.0, 1.0, 1.0], atol=1e-12)
    c = LinearSystem([[-1.0]], [[1.0]], [[1.0]], [[1.0]], input_delay=0.3)
    np.testing.assert_allclose(poles(c), [-1.0])
    np.testing.assert_allclose(zeros(c), [-2.0])


def test_nyquist_count_and_root_locus_of_a_sampled_loop():
    from linflex.frequency import bode_plot, nyquist_response, root_locus, root_locus_plot

    T = 0.1
    for k, unstable in ((1.0, 0), (0.3, 1)):
        L = LinearSystem([[1.5]], [[1.0]], [[k]], dt=T)   # k / (z - 1.5): closed-loop pole 1.5 - k
        r = nyquist_response(L)
        # reference: the closed-loop pole 1.5 - k against the unit circle
        assert r.open_loop_unstable_poles == 1 and r.closed_loop_unstable_poles == unstable
    rl = root_locus(LinearSystem([[1.5]], [[1.0]], [[1.0]], dt=T), gains=[0.0, 1.0, 2.0])
    # closed form: the root of z - 1.5 + k
    np.testing.assert_allclose(rl.roots[:, 0], [1.5, 0.5, -0.5], atol=1e-12)
    assert rl.dt == T
    handle = root_locus_plot(rl)
    assert handle.axes[0].get_xlabel() == "real [-] (z)"
    bode_plot(frequency_response(discretize(flexible_plant(), T)))


def test_nyquist_count_of_a_delayed_loop_is_the_delayed_curves():
    from linflex.frequency import nyquist_response

    L0 = LinearSystem([[0, 1], [0, 0]], [[0], [0.01]], [[100.0, 200.0]])   # PD on 1/(100 s^2): DM 0.6 s
    assert nyquist_response(L0.with_(input_delay=0.3)).closed_loop_unstable_poles == 0
    assert nyquist_response(L0.with_(input_delay=0.9)).closed_loop_unstable_poles == 2

"""discretize and pade (linflex/system/_sampling.py) against scipy, python-control and closed forms."""

from __future__ import annotations

import math

import control
import numpy as np
import pytest
import scipy.signal
from hypothesis import given, settings
from hypothesis import strategies as st

from linflex import LinearSystem, ModelError, discretize, forced_response, pade
from linflex.system import delay_factors, from_w_frequency, to_w_frequency, w_plane

SETTINGS = settings(derandomize=True, max_examples=15, deadline=None)


def random_stable(seed: int, n: int = 3, m: int = 2, p: int = 2) -> LinearSystem:
    rng = np.random.default_rng(seed)
    A = rng.normal(size=(n, n))
    A -= (np.max(np.linalg.eigvals(A).real) + 0.5) * np.eye(n)
    return LinearSystem(A, rng.normal(size=(n, m)), rng.normal(size=(p, n)), rng.normal(size=(p, m)))


def response_at(sys: LinearSystem, s: complex) -> np.ndarray:
    return sys.D + sys.C @ np.linalg.solve(s * np.eye(sys.n_states) - sys.A, sys.B)


@SETTINGS
@given(seed=st.integers(0, 2**31), dt=st.floats(0.01, 0.5), method=st.sampled_from(["zoh", "foh", "tustin"]))
def test_discretize_matches_scipy_cont2discrete(seed, dt, method):
    sys = random_stable(seed)
    d = discretize(sys, dt, method)
    ref = scipy.signal.cont2discrete((sys.A, sys.B, sys.C, sys.D), dt, method={"tustin": "bilinear"}.get(method, method))
    # reference: scipy.signal.cont2discrete; compared as transfer matrices at two points of the unit circle
    # (a first-order hold realization may differ by a state transformation)
    for w in (0.3 / dt, 2.0 / dt):
        z = np.exp(1j * w * dt)
        Gref = ref[3] + ref[2] @ np.linalg.solve(z * np.eye(len(ref[0])) - ref[0], ref[1])
        np.testing.assert_allclose(response_at(d, z), Gref, rtol=1e-10, atol=1e-12)
    assert d.dt == dt and d.inputs == sys.inputs and d.outputs == sys.outputs


def test_tustin_prewarp_matches_the_continuous_response_at_the_prewarp_frequency():
    sys = LinearSystem([[0, 1], [-100.0, -0.2]], [[0], [1]], [[1, 0]])   # 10 rad/s, zeta 0.01
    dt, w0 = 0.05, 10.0
    d = discretize(sys, dt, "tustin", prewarp=w0)
    # reference: the continuous response at j w0 (the definition of prewarping)
    np.testing.assert_allclose(response_at(d, np.exp(1j * w0 * dt)), response_at(sys, 1j * w0), rtol=1e-9)
    plain = discretize(sys, dt, "tustin")
    assert abs(response_at(plain, np.exp(1j * w0 * dt))[0, 0] - response_at(sys, 1j * w0)[0, 0]) > 0.4  # the peak moved


def test_matched_matches_python_control():
    sys = LinearSystem([[0, 1], [-4.0, -0.4]], [[0], [1]], [[2.0, 1.0]], inputs=["u.a"], outputs=["y.b"])
    d = discretize(sys, 0.1, "matched")
    ref = control.sample_system(control.tf(control.ss(sys.A, sys.B, sys.C, sys.D)), 0.1, method="matched")
    z = np.exp(0.7j)
    np.testing.assert_allclose(response_at(d, z)[0, 0], complex(ref(z)), rtol=1e-10)
    assert d.inputs == ("u.a",) and d.outputs == ("y.b",)


@SETTINGS
@given(seed=st.integers(0, 2**31), frac=st.floats(0.05, 0.95), whole=st.integers(0, 2))
def test_zoh_of_a_fractional_input_delay_is_exact_at_the_samples(seed, frac, whole):
    dt = 0.1
    tau = (whole + frac) * dt
    base = random_stable(seed, n=3, m=1, p=2)
    d = discretize(base.with_(input_delay=tau), dt)
    assert d.n_states == 4 and d.input_delay[0] == pytest.approx(whole * dt, abs=1e-15)
    rng = np.random.default_rng(seed)
    n_samples = 30
    u = rng.normal(size=n_samples)
    # reference: the continuous system driven by the delayed held input, integrated exactly
    # (matrix exponentials, forced_response) on a grid that holds every switching instant
    switches = np.arange(n_samples) * dt + tau
    t = np.unique(np.concatenate([np.arange(n_samples) * dt, switches[switches < n_samples * dt]]))
    k_of_t = np.floor((t - tau) / dt + 1e-9).astype(int)
    ut = np.where(k_of_t >= 0, u[np.clip(k_of_t, 0, n_samples - 1)], 0.0)
    ref = forced_response(base, t, ut[:, None])
    on_samples = np.isin(t, np.arange(n_samples) * dt)
    # the discrete recursion with the whole-period delay as a shift of the input sequence
    shift = int(round(d.input_delay[0] / dt))
    ud = np.concatenate([np.zeros(shift), u])[:n_samples]
    x = np.zeros(d.n_states)
    y = []
    for k in range(n_samples):
        y.append(d.C @ x + d.D @ ud[k:k + 1])
        x = d.A @ x + d.B @ ud[k:k + 1]
    np.testing.assert_allclose(np.array(y), ref.y[on_samples], rtol=1e-9, atol=1e-12)


def test_discretize_refuses_what_it_cannot_do_exactly():
    sys = LinearSystem([[-1.0]], [[1.0]], [[1.0]])
    with pytest.raises(ModelError, match="method must be one of"):
        discretize(sys, 0.1, "euler")
    with pytest.raises(ModelError, match="prewarp is a frequency of the 'tustin' method"):
        discretize(sys, 0.1, "zoh", prewarp=1.0)
    with pytest.raises(ModelError, match=r"prewarp must be a frequency in \(0, pi/dt\)"):
        discretize(sys, 0.1, "tustin", prewarp=40.0)
    with pytest.raises(ModelError, match="exactly by method='zoh' only"):
        discretize(sys.with_(input_delay=0.05), 0.1, "tustin")
    with pytest.raises(ModelError, match=r"output_delay\[0\] = 0.05 s is not a whole number of periods"):
        discretize(sys.with_(output_delay=0.05), 0.1)
    with pytest.raises(ModelError, match="continuous-time systems only"):
        discretize(discretize(sys, 0.1), 0.1)
    with pytest.raises(ModelError, match="dt must be a finite positive"):
        discretize(sys, -0.1)
    assert discretize(sys.with_(output_delay=0.2), 0.1).output_delay.tolist() == [0.2]


def test_discrete_systems_round_trip_through_python_control():
    d = discretize(LinearSystem([[0, 1], [0, 0]], [[0], [1]], [[1, 0]], inputs=["motor.cmd"], outputs=["gyro.x"]), 0.1)
    back = LinearSystem.from_control(d.to_control())
    assert back.dt == 0.1 and back.inputs == ("motor.cmd",) and back.outputs == ("gyro.x",)
    assert np.array_equal(back.A, d.A) and np.array_equal(back.B, d.B)
    assert d.to_control().dt == 0.1


@SETTINGS
@given(order=st.integers(1, 6), tau=st.floats(0.01, 1.0), seed=st.integers(0, 2**31))
def test_pade_error_estimate_bounds_the_true_error(order, tau, seed):
    sys = random_stable(seed, n=3, m=2, p=2).with_(input_delay=[tau, 0.5 * tau], output_delay=[0.0, 0.3 * tau])
    p = pade(sys, order, bandwidth=5.0 / tau)
    assert p.sys.n_states == 3 + 3 * order and not p.sys.has_delay
    # reference: the exact delayed transfer matrix diag(exp(-s tau_out)) G diag(exp(-s tau_in)) on a dense grid
    worst = 0.0
    for w in np.linspace(1e-3, p.bandwidth, 400):
        G = response_at(sys, 1j * w)
        exact = G * delay_factors(sys, [w])[0]
        approx = response_at(p.sys, 1j * w)
        worst = max(worst, np.linalg.norm(exact - approx, 2) / np.linalg.norm(G, 2))
    assert worst <= p.error_estimate * (1 + 1e-9) + 1e-13
    assert p.error_estimate <= 4.0


def test_pade_converges_to_the_delay_and_its_phase_limit_is_where_the_phase_error_is_phase_tol():
    lag = LinearSystem([[-1.0]], [[1.0]], [[1.0]], input_delay=0.1)
    errors = [pade(lag, k, bandwidth=10.0).error_estimate for k in (1, 2, 3, 4)]
    assert all(b < a for a, b in zip(errors, errors[1:])) and errors[-1] < 1e-7
    p = pade(lag, 2)
    num, den = control.pade(0.1, 2)
    w = p.frequency_limit
    P = np.polyval(num, 1j * w) / np.polyval(den, 1j * w)
    # reference: the phase of python-control's Pade approximant against the exact -w tau
    assert abs(np.angle(P * np.exp(1j * w * 0.1))) == pytest.approx(math.radians(1.0), rel=1e-9)


def test_pade_of_a_discrete_delay_is_an_exact_shift_register():
    d = LinearSystem([[0.5]], [[1.0]], [[1.0]], dt=0.1, input_delay=0.3)
    p = pade(d, 3)
    assert p.method == "shift register" and p.error_estimate == 0.0 and p.sys.n_states == 4
    z = np.exp(0.9j)
    np.testing.assert_allclose(response_at(p.sys, z)[0, 0], z**-3 / (z - 0.5), rtol=1e-13)


def test_pade_refuses_bad_orders():
    with pytest.raises(ModelError, match="order must be an integer from 1 to 10"):
        pade(LinearSystem([[-1.0]], [[1.0]], [[1.0]], input_delay=0.1), 0)


@SETTINGS
@given(seed=st.integers(0, 2**31), dt=st.floats(0.01, 1.0))
def test_w_plane_is_the_unit_circle_on_the_imaginary_axis(seed, dt):
    d = discretize(random_stable(seed), dt)
    cw, cond = w_plane(d)
    omega = np.array([0.01, 0.5, 2.0, 3.0]) / dt
    nu = to_w_frequency(omega, dt)
    np.testing.assert_allclose(from_w_frequency(nu, dt), omega, rtol=1e-14)
    for w, v in zip(omega, nu):
        np.testing.assert_allclose(response_at(cw, 1j * v), response_at(d, np.exp(1j * w * dt)), rtol=1e-9, atol=1e-12)
    # poles outside the unit circle go to the right half-plane
    unstable = LinearSystem([[1.5, 0.0], [0.0, 0.2]], np.eye(2), np.eye(2), dt=dt)
    assert np.count_nonzero(np.linalg.eigvals(w_plane(unstable)[0].A).real > 0) == 1
    assert cond >= 1.0


def test_w_plane_refuses_a_pole_at_minus_one():
    with pytest.raises(ModelError, match="pole at z = -1"):
        w_plane(LinearSystem([[-1.0]], [[1.0]], [[1.0]], dt=0.1))

"""simulate(method="exponential"): the exponential integrator against independent references.

References: the exact zero-order-hold recursion ``x+ = e^{A h} x + (int_0^h e^{A s} ds) B u``
from one ``scipy.linalg.expm`` of ``[[A, B], [0, 0]] h`` per interval (linear models);
``scipy`` DOP853 at rtol 1e-12 (nonlinear models); the exact discrete solution of a sampled PD
on a double integrator (``test_controller_chains.exact_pd``).
"""

from __future__ import annotations

import math
from pathlib import Path

import casadi as ca
import numpy as np
import pytest
import scipy.linalg
from hypothesis import example, given, settings
from hypothesis import strategies as st

import linflex
from linflex import MethodUnavailableError, NonlinearModel, ShapeError, simulate
from linflex.simulation import _exponential
from linflex.simulation._exponential import phi_matrices, phi_matrices_augmented

from .test_controller_chains import exact_pd, pd, slider

ROOT = Path(__file__).resolve().parents[2]


def linear_model(A: np.ndarray, B: np.ndarray) -> NonlinearModel:
    n, m = B.shape
    x, u, t = ca.SX.sym("x", n), ca.SX.sym("u", m), ca.SX.sym("t")
    f = ca.Function("f", [x, u, t], [ca.mtimes(ca.DM(A), x) + ca.mtimes(ca.DM(B), u)])
    return NonlinearModel(f, states=[f"x{i}" for i in range(n)], inputs=[f"u{j}" for j in range(m)])


def modal_system(rng, n_modes: int, top: float):
    """Lightly damped modes (damping ratios 0 to 0.02) from 0.5 rad/s up to ``top``, in 2x2
    rotation blocks, turned by a random orthogonal matrix (a full J), and a random B."""
    omega = np.sort(np.concatenate([[0.5, top], rng.uniform(0.5, top, n_modes - 2)]))
    zeta = rng.uniform(0.0, 0.02, n_modes)
    A = scipy.linalg.block_diag(*[np.array([[-z * w, w], [-w, -z * w]]) for w, z in zip(omega, zeta)])
    Q, _ = np.linalg.qr(rng.standard_normal(A.shape))
    return Q @ A @ Q.T, rng.standard_normal((A.shape[0], 2))


def zoh_recursion(A, B, timepts, x0, U):
    n, m = B.shape
    M = np.zeros((n + m, n + m))
    M[:n, :n], M[:n, n:] = A, B
    X = [np.asarray(x0, float)]
    for k in range(timepts.size - 1):
        W = scipy.linalg.expm(M * (timepts[k + 1] - timepts[k]))
        X.append(W[:n, :n] @ X[-1] + W[:n, n:] @ U[k])
    return np.array(X)


@settings(derandomize=True, max_examples=6, deadline=None)
@given(seed=st.integers(0, 2**16), log_top=st.floats(0.5, 3.5), n_modes=st.integers(2, 6))
def test_linear_models_are_the_exact_zero_order_hold_recursion(seed, log_top, n_modes):
    # Highest mode 3 to 3000 rad/s, 0.1 s samples (up to 300 rad per sample): one step per
    # sample and one Jacobian whatever the frequencies, and the result is the exact recursion
    # to round-off (1e-12 of the largest state).
    rng = np.random.default_rng(seed)
    A, B = modal_system(rng, n_modes, 10.0**log_top)
    t = np.linspace(0.0, 5.0, 51)
    U = rng.standard_normal((t.size, 2))
    x0 = rng.standard_normal(A.shape[0])
    r = simulate(linear_model(A, B), t, x0, inputs=U, method="exponential", rtol=1e-10, atol=1e-12)
    ref = zoh_recursion(A, B, t, x0, U)
    assert np.max(np.abs(r.x - ref)) <= 1e-12 * np.max(np.abs(ref))
    assert r.n_steps == t.size - 1
    assert r.n_linearizations == 1
    assert r.n_evaluations <= 4 * r.n_steps + t.size  # four per step, one more where u jumps


def test_phi_matrices_are_the_series_of_a_small_matrix():
    # phi_k(Z) = sum_j Z^j / (j + k)! summed to 30 terms for ||Z|| = 0.6 (independent of expm).
    rng = np.random.default_rng(3)
    J, h = rng.standard_normal((4, 4)) * 0.3, 0.5
    Z = h * J
    series = []
    for k in range(4):
        term, total = np.eye(4), np.zeros((4, 4))
        for j in range(30):
            total += term / math.factorial(j + k)
            term = term @ Z
        series.append(total * h**k)
    for got, want in zip(phi_matrices(J, h), series):
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-14)


def _phi_reference(J: np.ndarray, h: float) -> list[np.ndarray]:
    """``e^{hJ}`` and ``Q_k = h^k phi_k(hJ)`` to 50 digits (mpmath): the exponential of the exact
    binary values of ``J`` and ``h``, then ``Q_1 = J^-1 (e^{hJ} - I)``, ``Q_2 = J^-1 (Q_1 - h I)``,
    ``Q_3 = J^-1 (Q_2 - h^2 I / 2)`` (the cancellation costs digits the 50 have to spare)."""
    mp = pytest.importorskip("mpmath")
    with mp.workdps(50):
        Jm, eye, hm = mp.matrix(J.tolist()), mp.eye(J.shape[0]), mp.mpf(h)
        E = mp.expm(hm * Jm)
        Ji = mp.inverse(Jm)
        Q1 = Ji * (E - eye)
        Q2 = Ji * (Q1 - hm * eye)
        Q3 = Ji * (Q2 - hm**2 / 2 * eye)
        return [np.array(M.tolist(), dtype=float) for M in (E, Q1, Q2, Q3)]


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(1, 14), log_h=st.floats(-3.0, 0.0),
       log_spread=st.floats(0.0, 4.0))
@example(seed=33, n=2, log_h=0.0, log_spread=4.0)  # where scipy's augmented expm is off by 1.6e-5
@example(seed=138, n=9, log_h=0.0, log_spread=0.0)  # expm's condition 1.6e6: an error of 3.3e-10 is its due
@example(seed=213402, n=12, log_h=0.0, log_spread=0.0)  # failed a fixed 1e-9 row-wise (CI, session 15)
def test_phi_matrices_agree_with_a_50_digit_reference(seed, n, log_h, log_spread):
    # Scaled Taylor series and doublings against the functions computed to 50 digits (mpmath), on
    # badly scaled matrices (a diagonal similarity spread over up to 4 decades, as the states of
    # a flexible model) with lightly damped modes up to 500 rad/s and real parts from -50 to +2
    # 1/s. (scipy's expm of the 4n augmented matrix is no reference here: at h = 1 on a mode
    # decaying as e^-27 it is off by 1.6e-5 of a row where these functions are within 2e-14.)
    # The error, measured in the unscaled coordinates (D^-1 . D) relative to the largest entry,
    # is held to 100 eps times the relative condition of the exponential there
    # (scipy.linalg.expm_cond, Al-Mohy and Higham's estimate): no algorithm in double precision
    # does better on the non-normal matrices drawn here (condition up to 1e6 and more; measured
    # on 60 random draws: at most 12 eps cond).
    rng = np.random.default_rng(seed)
    lam = rng.uniform(-50.0, 2.0, n) + 1j * rng.uniform(-500.0, 500.0, n) * (rng.random(n) < 0.7)
    A = np.zeros((n, n))
    k = 0
    while k < n:  # real blocks: a 2x2 rotation-dilation for a complex pair, else the real part
        if k + 1 < n and lam[k].imag != 0.0:
            A[k:k + 2, k:k + 2] = [[lam[k].real, lam[k].imag], [-lam[k].imag, lam[k].real]]
            k += 2
        else:
            A[k, k] = lam[k].real
            k += 1
    Q = np.linalg.qr(rng.standard_normal((n, n)))[0] + 0.3 * rng.standard_normal((n, n))
    D = 10.0 ** rng.uniform(0.0, log_spread, n)
    M = Q @ A @ np.linalg.inv(Q)
    J = (D[:, None] * M) / D[None, :]
    h = 10.0**log_h
    tol = 100.0 * np.finfo(float).eps * max(scipy.linalg.expm_cond(h * M), 10.0)
    for got, want in zip(phi_matrices(J, h), _phi_reference(J, h)):
        unscaled = (got - want) / D[:, None] * D[None, :]
        assert np.max(np.abs(unscaled)) <= tol * np.max(np.abs(want / D[:, None] * D[None, :]))


def test_phi_matrices_augmented_agrees_with_a_50_digit_reference():
    # The fall-back on a lightly damped, badly scaled matrix where its Pade approximant is accurate
    # (h = 0.05: no mode decays below 1e-1 within the step).
    rng = np.random.default_rng(3)
    Q = np.linalg.qr(rng.standard_normal((6, 6)))[0]
    A = scipy.linalg.block_diag(*[np.array([[-0.01 * w, w], [-w, -0.01 * w]]) for w in (3.0, 40.0, 250.0)])
    D = 10.0 ** np.array([0.0, 1.0, 2.0, 3.0, 0.5, 1.5])
    J = (D[:, None] * (Q @ A @ Q.T)) / D[None, :]
    for got, want in zip(phi_matrices_augmented(J, 0.05), _phi_reference(J, 0.05)):
        scale = np.abs(want).max(axis=1, keepdims=True)
        assert np.max(np.abs(got - want) / scale) <= 1e-11


def test_phi_matrices_fall_back_to_the_augmented_expm_where_their_check_fails(monkeypatch):
    # The a posteriori check: with an acceptable residual of 0 the series is refused and the
    # augmented expm's result is returned as it is.
    rng = np.random.default_rng(7)
    J = rng.standard_normal((6, 6)) * 40.0
    monkeypatch.setattr(_exponential, "_RESIDUAL_MAX", 0.0)
    for got, want in zip(phi_matrices(J, 0.3), phi_matrices_augmented(J, 0.3)):
        np.testing.assert_array_equal(got, want)


def pendulum():
    # A pendulum (large swings: nonlinear) with an undamped 30 rad/s spring-mass coupled
    # linearly into it: the slow motion nonlinear, the fast one linear.
    x, u, t = ca.SX.sym("x", 4), ca.SX.sym("u", 1), ca.SX.sym("t")
    q, v, e, w = x[0], x[1], x[2], x[3]
    f = ca.vertcat(v, -9.81 * ca.sin(q) - 0.05 * v + 0.2 * e + u[0], w, -30.0**2 * e)
    return NonlinearModel(ca.Function("f", [x, u, t], [f]), states=["q", "v", "e", "w"], inputs=["u"])


def errors_against_dop853(model, t, x0=None, inputs=None, rtol=1e-8, atol=1e-10):
    r = simulate(model, t, x0, inputs=inputs, method="exponential", rtol=rtol, atol=atol)
    ref = simulate(model, t, x0, inputs=inputs, method="scipy-DOP853", rtol=1e-12, atol=1e-14).x
    return r, np.max(np.abs(r.x - ref), axis=0), np.max(np.abs(ref), axis=0)


def test_nonlinear_pendulum_against_dop853():
    # Large swings (2 rad) of the nonlinear pendulum: at rtol 1e-8 every state within 100 rtol of
    # its own peak (the global error of some thousand steps and the re-linearizations of a large
    # motion).
    t = np.linspace(0.0, 10.0, 101)
    r, err, peak = errors_against_dop853(pendulum(), t, [2.0, 0.0, 1e-3, 0.0],
                                         inputs=0.1 * np.sin(0.7 * t)[:, None])
    assert np.all(err <= 100 * 1e-8 * peak + 1e-9)
    assert r.n_linearizations >= 2  # the Jacobian at rest does not serve a 2 rad swing
    # Every attempt, accepted or rejected, costs four evaluations; f at a step's start is taken
    # afresh only where the held input changes (here at every sample).
    attempts = r.n_steps + r.n_rejected
    assert r.n_rejected > 0 and 4 * attempts < r.n_evaluations <= 4 * attempts + t.size - 1


def test_gyrostat_scene_against_dop853():
    # The spinning gyrostat (examples/gyrostat.toml: quaternion attitude, wheels, slosh): 10 s,
    # every state within 100 rtol of its own peak (plus atol scale for states near zero).
    model = linflex.compile_model(linflex.load_scene(ROOT / "examples" / "gyrostat.toml"))
    t = np.linspace(0.0, 10.0, 101)
    r, err, peak = errors_against_dop853(model, t)
    assert np.all(err <= 100 * 1e-8 * peak + 1e-8)
    assert r.quaternion_drift < 1e-8


@pytest.fixture(scope="module")
def arrays4():
    import dataclasses

    scene = linflex.vary_scene(linflex.load_scene(ROOT / "examples" / "spacecraft_arrays.toml"),
                               {f"bodies.{b}.modes": 4 for b in ("array_left", "array_right")})
    bodies = tuple(dataclasses.replace(b, beam={**b.beam, "damping": 0.0}) if b.beam else b for b in scene.bodies)
    return linflex.compile_model(dataclasses.replace(scene, bodies=bodies))


def test_solar_arrays_with_four_modes_against_dop853(arrays4):
    # The hub with two undamped arrays (4 modes each) after a 2 s, 50 N m yaw-wheel pulse, 10 s:
    # each state within 100 rtol of its peak; one step per sample suffices for the modes, so the
    # steps stay within a few per sample.
    t = np.linspace(0.0, 10.0, 101)
    inputs = {"motor_z": 50.0 * (t < 2.0)}
    r, err, peak = errors_against_dop853(arrays4, t, inputs=inputs)
    assert np.all(err <= 100 * 1e-8 * peak + 1e-9)
    assert r.n_steps <= 8 * (t.size - 1)


def test_spin_up_of_a_flexible_beam_against_dop853():
    # A 10 m beam (3 modes) clamped to a hub spun up to 6 rad/s in 4 s by a prescribed profile
    # (the linear part changes with the spin: the frozen J is taken anew along the way): 5 s,
    # each state within 100 rtol of its own peak, plus 1e-9 for the states the in-plane
    # spin-up leaves at zero.
    data = linflex.beam_modal_data(linflex.Beam((0, 0, 0), (10.0, 0, 0), EA=2.8e7, EIy=1.4e5, EIz=1.4e4, GJ=1e4,
                                                mass_per_length=1.2, elements=12), 3)
    spin = linflex.Joint(name="spin", type="revolute", child="hub", axis=(0.0, 0.0, 1.0),
                         prescribed={"profile": "spinup", "rate": 6.0, "ramp_time": 4.0})
    scene = linflex.Scene(name="spinup", effects=("geometric_stiffness",),
                          bodies=(linflex.Body(name="hub", mass=1.0, inertia=(1.0, 1.0, 1.0)),
                                  linflex.Body(name="beam", mass=0.0, type="flexible", modal_data=data)),
                          joints=(spin, linflex.Joint(name="clamp", type="fixed", parent="hub", child="beam")))
    r, err, peak = errors_against_dop853(linflex.compile_model(scene), np.linspace(0.0, 5.0, 51))
    assert np.all(err <= 100 * 1e-8 * peak + 1e-9)
    assert r.n_linearizations >= 2


def test_sampled_pd_with_the_exponential_method():
    # A sampled PD with a 30 ms delay on a double integrator (J nilpotent: e^{hJ} = I + hJ): the
    # pieces between samples and command instants are 30 and 70 ms; exact to round-off.
    T, kp, kd, n = 0.1, 8.0, 6.0, 30
    model = linflex.compile_model(slider([pd(kp=kp, kd=kd, sample_time=T, delay=0.03)]))
    r = simulate(model, np.linspace(0.0, n * T, n + 1), method="exponential", rtol=1e-10, atol=1e-12)
    ref = exact_pd(kp, kd, T, 0.03, n, [0.1, 0.0])
    np.testing.assert_allclose(r["s.position"], ref[:, 0], rtol=0, atol=1e-14)
    np.testing.assert_allclose(r["s.rate"], ref[:, 1], rtol=0, atol=1e-14)
    assert r.method == "exponential"


def test_auto_takes_the_exponential_method_for_fast_modes_only():
    # 16 modes (32 states) up to 2000 rad/s against 0.1 s samples over 30 s: 6e4 rad, 200 rad
    # per sample -> exponential; the same at 20 rad/s (2 rad per sample), or 3 modes at 2000
    # rad/s (6 states) -> Adams; a time-varying model -> Adams.
    rng = np.random.default_rng(0)
    t = np.linspace(0.0, 30.0, 301)
    for n_modes, top, expected in ((16, 2000.0, "exponential"), (16, 20.0, "cvodes-adams"),
                                   (3, 2000.0, "cvodes-adams")):
        A, B = modal_system(rng, n_modes, top)
        assert simulate(linear_model(A, B), t[:3], np.ones(2 * n_modes)).method == "cvodes-adams"  # 0.2 s
        assert simulate(linear_model(A, B), t, np.ones(2 * n_modes)).method == expected
    x, u, s = ca.SX.sym("x", 2), ca.SX.sym("u", 1), ca.SX.sym("t")
    varying = NonlinearModel(ca.Function("f", [x, u, s], [ca.vertcat(x[1], -(2000.0 + ca.sin(s))**2 * x[0])]),
                             states=["q", "v"], inputs=["u"])
    assert simulate(varying, t[:3], [1.0, 0.0]).method == "cvodes-adams"


def test_auto_hands_its_jacobian_to_the_exponential_stepper():
    # auto takes df/dx at (x0, u0, t0) to choose; the exponential stepper starts from it instead
    # of taking it again: the run is the same as method="exponential" to the bit, and a stepper
    # given J0 of a linear model never calls its Jacobian (the exact ZOH recursion from J0 alone).
    from linflex.simulation._exponential import exponential_stepper
    from linflex.simulation._steppers import IntegratorCounts

    A, B = modal_system(np.random.default_rng(3), 16, 2000.0)
    model, t = linear_model(A, B), np.linspace(0.0, 30.0, 301)
    auto = simulate(model, t, np.ones(32))
    assert auto.method == "exponential"
    np.testing.assert_array_equal(auto.x, simulate(model, t, np.ones(32), method="exponential").x)

    def no_jacobian(x, u, tt):
        raise AssertionError("the Jacobian was taken again")
    U = np.ones((t.size, 2))
    step = exponential_stepper(lambda x, u, tt: A @ x + B @ u, no_jacobian, 1e-10, 1e-12, IntegratorCounts(),
                               jacobian0=A)
    X = step(t[:11], np.ones(32), U[:11])
    np.testing.assert_allclose(X, zoh_recursion(A, B, t[:11], np.ones(32), U[:10])[1:], rtol=0, atol=1e-11)


def test_bad_input_is_refused():
    numpy_model = NonlinearModel(lambda x, u, t: -x, states=["x"])
    with pytest.raises(MethodUnavailableError, match="exponential"):
        simulate(numpy_model, [0.0, 1.0], [1.0], method="exponential")
    A, B = modal_system(np.random.default_rng(1), 2, 10.0)
    with pytest.raises(ShapeError, match=r"x0\[1\]"):
        simulate(linear_model(A, B), [0.0, 1.0], [1.0, np.nan, 0.0, 0.0], method="exponential")


def test_per_state_atol_is_honoured():
    # A pendulum swinging 2 rad drives a second one to 1e-6 rad. With atol at 1e-8 of each
    # state's peak every state is within 1e-6 of its peak against DOP853 at rtol 1e-12 (atol
    # 1e-20); loosening the atol of the small states alone (to their peak) saves steps, so the
    # step control reads each state's own atol.
    x, u, t = ca.SX.sym("x", 4), ca.SX.sym("u", 1), ca.SX.sym("t")
    f = ca.vertcat(x[1], -9.81 * ca.sin(x[0]), x[3], -9.81 * ca.sin(x[2]) + 1e-6 * ca.sin(x[0]) + 0.0 * u[0])
    model = NonlinearModel(ca.Function("f", [x, u, t], [f]), states=["q", "v", "p", "w"], inputs=["u"])
    ts = np.linspace(0.0, 5.0, 51)
    x0 = [2.0, 0.0, 0.0, 0.0]
    ref = simulate(model, ts, x0, method="scipy-DOP853", rtol=1e-12, atol=1e-20).x
    peak = np.max(np.abs(ref), axis=0)
    tight = simulate(model, ts, x0, method="exponential", rtol=1e-8, atol=1e-8 * peak)
    assert np.all(np.max(np.abs(tight.x - ref), axis=0) <= 1e-6 * peak)
    loose = simulate(model, ts, x0, method="exponential", rtol=1e-8, atol=peak * [1e-8, 1e-8, 1.0, 1.0])
    assert loose.n_steps < tight.n_steps

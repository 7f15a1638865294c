"""linflex.design against closed forms and independent computations (references named per test)."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from linflex import ConvergenceError, LinearSystem, ModelError, SecondOrderSystem, as_linear_system, series
from linflex.design import lqg, lqr, notch_at, pid_from_bandwidth, rigid_inertia, roll_off, tune
from linflex.frequency import Loop, transfer_function
from linflex.scene import Requirements

FAST = dict(derandomize=True, deadline=None, max_examples=25)


def response(sys, w):
    sys = as_linear_system(sys)
    s = 1j * np.atleast_1d(np.asarray(w, dtype=float))
    n = sys.n_states
    return np.array([sys.C @ np.linalg.solve(si * np.eye(n) - sys.A, sys.B) + sys.D for si in s])


@settings(**FAST)
@given(seed=st.integers(0, 2**31 - 1), n_rigid=st.integers(1, 3), n_flex=st.integers(1, 6))
def test_rigid_inertia_is_the_rigid_block_of_the_mass_matrix(seed, n_rigid, n_flex):
    # Reference: a hub (rigid dofs, no stiffness) carrying appendages (flexible dofs relative to the
    # hub, stiffness K_ff > 0): the rigid mode is [I; 0], its modal mass the block M_rr, so
    # G(s) = M_rr^-1 / s^2 + O(1/s) at the origin (the whole inertia, appendages included).
    rng = np.random.default_rng(seed)
    n = n_rigid + n_flex
    X = rng.standard_normal((n, n))
    M = X @ X.T + n * np.eye(n)
    Kf = rng.standard_normal((n_flex, n_flex))
    K = np.zeros((n, n))
    K[n_rigid:, n_rigid:] = Kf @ Kf.T + 0.5 * np.eye(n_flex)
    D = 0.01 * K
    B = np.vstack([np.eye(n_rigid), np.zeros((n_flex, n_rigid))])
    plant = SecondOrderSystem(M, D, K, B, Cq=B.T)
    result = rigid_inertia(plant)
    Mrr = M[:n_rigid, :n_rigid]
    np.testing.assert_allclose(result.matrix, Mrr, rtol=1e-7, atol=1e-7 * np.abs(Mrr).max())
    assert result.n_rigid == 2 * n_rigid
    assert result.error_estimate < 1e-6


def test_rigid_inertia_of_the_example_spacecraft():
    # Reference: the hand computation in examples/spacecraft_arrays.toml: hub, wheels and the
    # arrays' sum m y^2 = 1213 kg m^2 about x and z give [3227, 604, 3327] kg m^2 (wheel motors:
    # reaction torque, so negative), to the 0.5 kg m^2 the comment rounds to.
    from linflex.stability.report import analyse_scene

    plant = analyse_scene("examples/spacecraft_arrays.toml", figures=False, stiffness_by_origin=False).plant.sys
    J = rigid_inertia(plant, inputs=["motor_x", "motor_y", "motor_z"], outputs=["roll", "pitch", "yaw"])
    np.testing.assert_allclose(J.axes, [-3227.0, -604.0, -3327.0], atol=1.0)
    gains = pid_from_bandwidth(J, 0.3, 0.7)
    np.testing.assert_allclose(gains.kp, [-290.4, -54.4, -299.4], atol=0.1)   # the scene's own gains
    np.testing.assert_allclose(gains.kd, [-1355.3, -253.7, -1397.3], atol=0.5)


def test_rigid_inertia_refuses_loops_without_double_integrators():
    with pytest.raises(ModelError, match="no rigid-body"):
        rigid_inertia(LinearSystem([[-1.0]], [[1.0]], [[1.0]]))
    with pytest.raises(ModelError, match="pair each actuator"):
        rigid_inertia(LinearSystem(np.zeros((2, 2)), np.eye(2), np.ones((1, 2))))


@settings(**FAST)
@given(J=st.floats(-1e4, 1e4).filter(lambda j: abs(j) > 1e-2), w=st.floats(1e-3, 1e2), z=st.floats(0.1, 2.0),
       ratio=st.one_of(st.none(), st.floats(0.01, 2.0)))
def test_pid_places_the_closed_loop_poles(J, w, z, ratio):
    # Reference: the closed-loop characteristic polynomial J s^3 + kd s^2 + kp s + ki (PD: J s^2 +
    # kd s + kp) equals J (s^2 + 2 z w s + w^2)(s + a), a = ratio w (numpy.polymul), coefficient by
    # coefficient (roots of a multiple pole would be ill-conditioned; coefficients are not).
    g = pid_from_bandwidth([J], w, z, integral_ratio=ratio)
    got = [J, g.kd[0], g.kp[0], g.ki[0]] if ratio else [J, g.kd[0], g.kp[0]]
    want = J * (np.polymul([1, 2 * z * w, w * w], [1, ratio * w]) if ratio else np.array([1, 2 * z * w, w * w]))
    scale = np.abs(want) + np.abs(J) * np.finfo(float).eps * np.max(np.abs(want / J))
    np.testing.assert_array_less(np.abs(np.subtract(got, want)), 1e-13 * scale + 1e-300)


def test_pid_controller_entry_and_bad_input():
    entry = pid_from_bandwidth([800.0, 600.0], 0.5).controller("pd", inputs=["a", "b"], outputs=["m1", "m2"],
                                                                 rate_inputs=["p", "q"])
    assert entry.type == "pid" and tuple(entry.kp) == (200.0, 150.0)
    with pytest.raises(ModelError, match="bandwidth must be a finite positive"):
        pid_from_bandwidth([800.0], -1.0)
    with pytest.raises(ModelError, match="inertia must be finite and non-zero"):
        pid_from_bandwidth([0.0, 1.0], 1.0)


def flexible_plant():
    # A rigid body (J = 100) with two appendage modes at 2 and 7 rad/s (damping 0.005), torque to angle.
    M = np.array([[100.0, 4.0, 2.0], [4.0, 1.0, 0.0], [2.0, 0.0, 1.0]])
    K = np.diag([0.0, 4.0, 49.0])
    return SecondOrderSystem(M, np.diag([0.0, 0.02, 0.07]), K, [[1.0], [0.0], [0.0]], Cq=[[1.0, 0.0, 0.0]],
                             dofs=["hub", "array.q1", "array.q2"])


def test_notch_at_picks_the_mode_by_frequency_state_or_index():
    plant = as_linear_system(flexible_plant())
    by_freq = notch_at(plant, 7.5, depth=30.0)
    by_state = notch_at(plant, "array.q2", depth=30.0)
    by_index = notch_at(plant, 1, depth=30.0)
    assert by_freq.frequency == by_state.frequency == by_index.frequency
    # Reference: eigenvalues of the pencil (K, M) (scipy.linalg.eigh) give the mode's natural frequency.
    import scipy.linalg

    w2 = scipy.linalg.eigh(np.diag([0.0, 4.0, 49.0]), flexible_plant().M, eigvals_only=True)
    np.testing.assert_allclose(by_freq.frequency, np.sqrt(w2[-1]), rtol=1e-3)   # lightly damped: |lambda| ~ w
    np.testing.assert_allclose(abs(response(by_freq.filter, by_freq.frequency)[0, 0, 0]), 10 ** (-30 / 20), rtol=1e-9)
    with pytest.raises(ModelError, match="no oscillatory mode has state 'hub.x'"):
        notch_at(plant, "hub.x")
    with pytest.raises(ModelError, match="no oscillatory"):
        notch_at(LinearSystem([[-1.0]], [[1.0]], [[1.0]]), 1.0)


@settings(**FAST)
@given(f=st.floats(0.1, 1e3), att=st.floats(1.0, 80.0), sections=st.integers(1, 3))
def test_roll_off_attenuates_at_and_above_the_frequency(f, att, sections):
    r = roll_off(f, att, sections=sections)
    g = np.abs(response(r, f * np.array([1.0, 1.5, 3.0, 10.0, 100.0]))[:, 0, 0])
    np.testing.assert_allclose(20 * np.log10(g[0]), -att, atol=1e-8)   # exactly -att dB at f (closed form)
    assert np.all(20 * np.log10(g[1:]) <= -att + 1e-9)                 # and below it above f
    np.testing.assert_allclose(abs(response(r, 1e-6 * f)[0, 0, 0]), 1.0, atol=1e-6)   # unit DC gain


def test_series_is_the_product_of_the_transfer_functions():
    from linflex import lead_lag, low_pass, notch

    parts = [notch(5.0, 20.0, 2.0), low_pass(30.0, 0.5), lead_lag(1.0, 4.0, 2.0)]
    w = np.logspace(-1, 2, 13)
    expected = np.prod([response(p, w)[:, 0, 0] for p in parts], axis=0)
    np.testing.assert_allclose(response(series(*parts), w)[:, 0, 0], expected, rtol=1e-10)
    with pytest.raises(ModelError, match=r"systems\[1\] has 1 inputs but systems\[0\] has 2 outputs"):
        series(LinearSystem(-np.eye(2), np.eye(2), np.eye(2)), parts[0])
    with pytest.raises(ModelError, match="dt = 0.1 s but systems"):
        series(parts[0], parts[1].with_(dt=0.1))


@settings(**FAST)
@given(q1=st.floats(1e-3, 1e3), q2=st.floats(0.0, 1e3), r=st.floats(1e-3, 1e3))
def test_lqr_double_integrator_closed_form(q1, q2, r):
    # Reference: for x'' = u with Q = diag(q1, q2), R = r the Riccati solution gives
    # K = [sqrt(q1/r), sqrt(q2/r + 2 sqrt(q1/r))] (closed form, e.g. Anderson and Moore).
    d = lqr(LinearSystem([[0, 1], [0, 0]], [[0], [1]]), [q1, q2], r)
    k1 = np.sqrt(q1 / r)
    np.testing.assert_allclose(d.K, [[k1, np.sqrt(q2 / r + 2 * k1)]], rtol=1e-7)
    assert d.residual < 1e-10 and d.inputs == ("u0",)


def test_lqg_closed_loop_is_regulator_and_estimator_poles():
    # Reference: the separation principle: the closed loop's poles are eig(A - B K) and eig(A - L C).
    plant = as_linear_system(flexible_plant())
    design = lqg(plant, np.ones(plant.n_states), 1e-2, 1.0, 1e-4)
    loop = Loop(plant, design.controller, sensors=plant.outputs, actuators=plant.inputs)
    closed = transfer_function(loop, "closed_loop")
    got = np.sort_complex(np.linalg.eigvals(closed.A))
    want = np.sort_complex(np.concatenate([design.regulator.closed_loop_poles, design.estimator_poles]))
    np.testing.assert_allclose(got, want, rtol=1e-6, atol=1e-8)
    assert design.controller.inputs == plant.outputs and design.controller.outputs == plant.inputs


def rigid_pd_loop(w, J=50.0, z=0.7):
    plant = LinearSystem([[0, 1], [0, 0]], [[0], [1 / J]], [[1, 0], [0, 1]], inputs=["torque"], outputs=["angle", "rate"])
    g = pid_from_bandwidth([J], w, z)
    return Loop(plant, LinearSystem(np.zeros((0, 0)), np.zeros((0, 2)), np.zeros((1, 0)), [[g.kp[0], g.kd[0]]]),
                sensors=["angle", "rate"], actuators=["torque"])


def test_tune_finds_the_largest_bandwidth_of_a_delay_requirement():
    # Reference (closed form): the PD loop (2 z w s + w^2) / s^2 crosses over at
    # wc = w sqrt(2 z^2 + sqrt(4 z^4 + 1)) with PM = atan(2 z wc / w); its delay margin PM / wc
    # falls as 1 / w, so the largest bandwidth with a delay margin d is PM / (d wc / w).
    z, d = 0.7, 0.2
    ratio = np.sqrt(2 * z**2 + np.sqrt(4 * z**4 + 1))
    pm = np.arctan(2 * z * ratio)
    w_max = pm / (d * ratio)
    result = tune(rigid_pd_loop, (0.05, 20.0), {"delay_margin_s": d, "phase_margin_deg": 30.0}, xtol=1e-7)
    np.testing.assert_allclose(result.x[0], w_max, rtol=1e-6)
    assert result.feasible and result.active.quantity == "delay_margin_s"
    np.testing.assert_allclose(result.active.value, d, rtol=1e-5)


def test_tune_reports_an_upper_bound_and_infeasible_requirements():
    free = tune(rigid_pd_loop, (0.05, 1.0), Requirements(delay_margin_s=0.2))
    assert free.x[0] == 1.0 and free.active is None
    with pytest.raises(ConvergenceError, match="no parameters within the bounds pass"):
        tune(rigid_pd_loop, (0.05, 1.0), {"phase_margin_deg": 89.0})
    with pytest.raises(ModelError, match="need the closed loop's sensitivities"):
        tune(rigid_pd_loop, (0.05, 1.0), {"sensitivity_peak_db": 6.0})
    with pytest.raises(ModelError, match="several parameters need an objective"):
        tune(lambda x: rigid_pd_loop(x[0]), [(0.05, 1.0), (0.1, 1.0)], {"phase_margin_deg": 30.0})


@settings(max_examples=20, deadline=None)
@given(J=st.floats(0.1, 1e4), w=st.floats(0.01, 10.0))
def test_pid_from_bandwidth_takes_the_plant_itself(J, w):
    """A plant ``1 / (J s^2)`` given where the inertia is expected: the gains are those of its
    inertia (closed form ``kp = J w^2``, ``kd = 2 z w J``), through rigid_inertia."""
    g = pid_from_bandwidth(LinearSystem([[0.0, 1.0], [0.0, 0.0]], [[0.0], [1.0 / J]], [[1.0, 0.0]]), w)
    np.testing.assert_allclose(g.kp, [J * w * w], rtol=1e-9)
    np.testing.assert_allclose(g.kd, [2 * 0.7 * w * J], rtol=1e-9)


def test_pid_from_bandwidth_names_what_it_takes():
    with pytest.raises(ModelError, match="inertia must be a number per axis"):
        pid_from_bandwidth("J", 1.0)


def test_lqr_of_a_static_plant_says_why():
    with pytest.raises(ModelError, match="0 states"):
        lqr(LinearSystem(np.zeros((0, 0)), np.zeros((0, 1)), np.zeros((1, 0)), [[3.0]]), 1.0, 1.0)

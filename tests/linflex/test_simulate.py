"""simulate: conservation laws, agreement between integrators, inputs, named results."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from linflex import (
    Actuator,
    Body,
    Joint,
    MethodUnavailableError,
    ModelError,
    NonlinearModel,
    Scene,
    ShapeError,
    TimeResponse,
    Wheel,
    compile_model,
    simulate,
)

from .test_compile import closed_form_double_pendulum, double_pendulum

INERTIA = [[10.0, 0.5, 0.2], [0.5, 8.0, 0.1], [0.2, 0.1, 6.0]]


def free_gyrostat():
    """A torque-free body with a free-spinning wheel (torque mode, no torque): conservative."""
    return Scene("gyrostat", effects=["wheel_gyroscopics"], bodies=[Body("sc", 100.0, INERTIA)],
                 joints=[Joint("att", "spherical", "sc", u0=[0.1, 0.05, 0.2])],
                 wheels=[Wheel("rw", "sc", 0.05, axis=[1, 1, 0], transverse_inertia=0.03, mode="torque", speed=50.0)],
                 actuators=[Actuator("motor", "wheel_torque", wheel="rw")])


@pytest.mark.parametrize("method", ["cvodes", "idas"])
def test_torque_free_gyrostat_conserves_energy_and_momentum(method):
    model = compile_model(free_gyrostat())
    r = simulate(model, np.linspace(0, 100, 501), method=method, rtol=1e-13, atol=1e-14)
    E, H = r.energy, r.momentum
    # Exact invariants of the torque-free gyrostat: 1e-9 relative over 100 s (issue 3).
    assert np.max(np.abs(E - E[0])) / E[0] < 1e-9
    assert np.max(np.linalg.norm(H - H[0], axis=1)) / np.linalg.norm(H[0]) < 1e-9
    assert r.quaternion_drift < 1e-9
    np.testing.assert_allclose(np.linalg.norm(r.x[-1, :4]), 1.0, rtol=1e-12)


def test_integrators_agree_on_double_pendulum():
    model = compile_model(double_pendulum())
    x0 = np.array([1.0, -0.5, 0.0, 0.3])
    t = np.linspace(0, 5, 51)
    runs = {m: simulate(model, t, x0, method=m, rtol=1e-11, atol=1e-12)
            for m in ("cvodes", "cvodes-adams", "idas", "scipy-DOP853")}
    # Independent integrators at tight tolerances: 1e-6 absolute over 5 s of chaotic-ish motion.
    np.testing.assert_allclose(runs["cvodes"].x, runs["scipy-DOP853"].x, atol=1e-6)
    np.testing.assert_allclose(runs["idas"].x, runs["scipy-DOP853"].x, atol=1e-6)
    np.testing.assert_allclose(runs["cvodes-adams"].x, runs["scipy-DOP853"].x, atol=1e-6)
    E = runs["cvodes"].energy
    assert np.max(np.abs(E - E[0])) / np.abs(E[0]) < 1e-8  # conservative: energy constant


def test_simulation_of_numpy_closed_form_matches_compiled_model():
    # The closed-form equations (reference notes 1.3) as a numpy model, integrated with scipy.
    ref = NonlinearModel(lambda x, u, t: closed_form_double_pendulum(x), states=4)
    model = compile_model(double_pendulum())
    t = np.linspace(0, 3, 31)
    x0 = np.array([0.4, 0.2, -0.1, 0.0])
    a = simulate(ref, t, x0, method="scipy-DOP853", rtol=1e-11, atol=1e-12)
    b = simulate(model, t, x0, method="cvodes", rtol=1e-11, atol=1e-12)
    np.testing.assert_allclose(b.x, a.x, atol=1e-7)
    with pytest.raises(MethodUnavailableError, match="needs a CasADi model"):
        simulate(ref, t, x0, method="cvodes")


def test_gyrostat_reorientation_major_to_minor_axis():
    # Spinning at 5 rpm about the major axis x; a wheel on the minor axis z spun up to the
    # total angular momentum H over 200 s (the dual-spin turn, Banerjee's reorientation
    # manoeuvre): the body's minor axis ends near the angular momentum vector.
    W = 5 * 2 * np.pi / 60
    I = (1000.0, 800.0, 600.0)
    scene = Scene("turn", effects=["wheel_gyroscopics"], bodies=[Body("sc", 500.0, I)],
                  joints=[Joint("att", "spherical", "sc", u0=[W, 0.002, 0.0])],
                  wheels=[Wheel("wz", "sc", 1.0, axis=[0, 0, 1], transverse_inertia=0.5, mode="torque")],
                  actuators=[Actuator("mz", "wheel_torque", wheel="wz")])
    model = compile_model(scene)
    H0, T = I[0] * W, 200.0
    t = np.linspace(0, 300, 601)
    r = simulate(model, t, inputs={"mz": lambda s: H0 / T if s < T else 0.0}, rtol=1e-10, atol=1e-12)
    H = r.momentum
    h = H / np.linalg.norm(H, axis=1)[:, None]
    z_N = np.array([Rotation.from_quat(np.r_[q[1:], q[0]]).as_matrix()[:, 2] for q in r.x[:, :4]])
    angle = np.degrees(np.arccos(np.clip(np.sum(z_N * h, axis=1), -1, 1)))
    assert angle[0] == pytest.approx(90.0, abs=1e-9)  # starts about the major axis
    # Ends within the residual nutation cone (about 18 deg without a damper) of the minor axis.
    assert np.max(angle[t > 220]) < 25.0
    # Internal motor torque: angular momentum conserved (1e-7 relative at rtol 1e-10).
    assert np.max(np.linalg.norm(H - H[0], axis=1)) / np.linalg.norm(H[0]) < 1e-7
    np.testing.assert_allclose(r["wz.speed"][-1], H0 / 1.0, rtol=1e-3)


def test_inputs_as_array_mapping_and_callable_agree():
    model = compile_model(free_gyrostat())
    t = np.linspace(0, 2, 21)
    u = np.where(t < 1, 0.01, -0.02)
    a = simulate(model, t, inputs=u[:, None], rtol=1e-10, atol=1e-12)
    b = simulate(model, t, inputs={"motor": u}, rtol=1e-10, atol=1e-12)
    c = simulate(model, t, inputs=lambda s: [0.01 if s < 1 - 1e-12 else -0.02], rtol=1e-10, atol=1e-12)
    # Same zero-order-hold samples: identical runs.
    np.testing.assert_array_equal(a.x, b.x)
    np.testing.assert_allclose(c.x, a.x, atol=1e-12)
    # The recorded input is the sample held on [t_k, t_k+1).
    np.testing.assert_array_equal(a["motor"], u)
    # Internal motor torque: the angular momentum stays constant through the input jump
    # (1e-8 relative at rtol 1e-10).
    H = a.momentum
    assert np.max(np.linalg.norm(H - H[0], axis=1)) / np.linalg.norm(H[0]) < 1e-8
    with pytest.raises(ShapeError, match=r"inputs has shape \(3,\)"):
        simulate(model, t, inputs=[1.0, 2.0, 3.0])
    with pytest.raises(ModelError, match="unknown signal 'motr'"):
        simulate(model, t, inputs={"motr": 1.0})


def test_time_response_named_access_and_csv(tmp_path):
    model = compile_model(double_pendulum())
    r = simulate(model, np.linspace(0, 1, 11), [0.1, 0.0, 0.0, 0.0], method="scipy-RK45", rtol=1e-9, atol=1e-11)
    assert isinstance(r, TimeResponse)
    assert r.data.shape == (11, 4) and r.signal_names == model.states
    np.testing.assert_array_equal(r["j1.angle"], r.x[:, 0])
    with pytest.raises(ModelError, match="did you mean 'j1.angle'"):
        r["j1.angel"]
    with pytest.raises(ValueError):
        r.x[0, 0] = 1.0  # read-only
    path = tmp_path / "out.csv"
    r.to_csv(path, ["j1.angle"])
    data = np.loadtxt(path, delimiter=",", skiprows=1)
    np.testing.assert_allclose(data[:, 1], r["j1.angle"], rtol=1e-15)
    # Small-angle pendulum: energy of the conservative system constant to the tolerance.
    assert np.ptp(r.energy) < 1e-7


def test_bad_arguments():
    model = compile_model(double_pendulum())
    with pytest.raises(ShapeError, match="strictly increasing"):
        simulate(model, [0.0, 1.0, 1.0])
    with pytest.raises(ShapeError, match="x0 has shape"):
        simulate(model, [0.0, 1.0], [1.0, 2.0])
    with pytest.raises(MethodUnavailableError, match="unknown"):
        simulate(model, [0.0, 1.0], method="euler")
    with pytest.raises(ModelError, match="rtol must be a finite positive number"):
        simulate(model, [0.0, 1.0], rtol=-1.0)


def test_progress_bar_on_request(capsys):
    model = compile_model(double_pendulum())
    simulate(model, np.linspace(0, 1, 11), [0.1, 0, 0, 0], progress=True)
    assert "100%" in capsys.readouterr().err
    simulate(model, np.linspace(0, 1, 11), [0.1, 0, 0, 0])
    assert capsys.readouterr().err == ""  # not a terminal under pytest: off by default


def _linear_model(A):
    import casadi as ca

    x = ca.SX.sym("x", A.shape[0])
    return NonlinearModel.from_casadi(ca.mtimes(ca.DM(A), x), x, ca.SX.sym("u", 0),
                                      states=[f"x{k}" for k in range(A.shape[0])])


@pytest.mark.parametrize("stiff", [True, False])
def test_auto_method_picks_bdf_for_stiff_and_adams_for_oscillatory_models(stiff):
    # Closed form: x(t) = expm(A t) x0. The stiff model has a mode decaying at 1e4 1/s beside
    # one at 1 1/s (ratio 1e4 > STIFFNESS_RATIO); the oscillatory one undamped modes at 1 and
    # 300 rad/s (lightly damped modes set the pace: not stiff).
    from scipy.linalg import expm

    A = np.diag([-1.0, -1e4]) if stiff else np.array(
        [[0, 1, 0, 0], [-1, 0, 0, 0], [0, 0, 0, 1], [0, 0, -9e4, 0]], dtype=float)
    A = A + np.triu(np.full_like(A, 0.01), 1) * stiff  # couple the stiff pair a little
    x0 = np.ones(A.shape[0])
    t = np.linspace(0.0, 2.0, 21)
    r = simulate(_linear_model(A), t, x0, rtol=1e-10, atol=1e-12)
    assert r.method == ("cvodes" if stiff else "cvodes-adams")
    exact = np.array([expm(A * tk) @ x0 for tk in t])
    # rtol 1e-10 over 2 s (600 radians of the fast oscillation): the global error stays well
    # inside 1e-7 of each state's amplitude.
    scale = np.max(np.abs(exact), axis=0)
    assert np.max(np.abs(r.x - exact) / scale) < 1e-7


def test_auto_method_on_numpy_models_is_lsoda():
    decay = NonlinearModel(lambda x, u, t: -x, states=["x"])
    r = simulate(decay, np.linspace(0, 1, 3), [1.0], rtol=1e-10, atol=1e-12)
    assert r.method == "scipy-LSODA"
    assert abs(r.x[-1, 0] - np.exp(-1.0)) < 1e-8  # closed form e^-t, rtol 1e-10


@pytest.mark.parametrize("method", ["cvodes", "cvodes-adams", "idas"])
def test_sundials_counts_add_up_over_the_pieces_of_a_run(method):
    # The counts CVODES / IDAS report for a run are the sums over the pieces it is integrated in:
    # a run in two chunks counts exactly what its two halves count as runs of their own.
    model = compile_model(double_pendulum())
    x0, t = np.array([1.0, -0.5, 0.0, 0.3]), np.linspace(0, 4, 41)
    whole = simulate(model, t, x0, method=method, rtol=1e-9, atol=1e-10, chunks=2)
    first = simulate(model, t[:21], x0, method=method, rtol=1e-9, atol=1e-10)
    second = simulate(model, t[20:], first.x[-1], method=method, rtol=1e-9, atol=1e-10)
    for name in ("n_steps", "n_rejected", "n_evaluations", "n_linearizations"):
        assert getattr(whole, name) == getattr(first, name) + getattr(second, name), name
    assert whole.n_evaluations >= whole.n_steps > 40  # at least one evaluation a step
    # Adams with functional iteration takes no Jacobian; BDF's Newton iteration takes some.
    assert (whole.n_linearizations == 0) == (method == "cvodes-adams")
    assert "n_steps" in repr(whole)


def test_scipy_counts_are_the_calls_of_the_right_hand_side():
    # solve_ivp reports its evaluations of f (counted here by the model itself) and no steps.
    calls = []

    def f(x, u, t):
        calls.append(t)
        return closed_form_double_pendulum(x)

    model = NonlinearModel(f, states=4)
    t = np.linspace(0, 2, 21)
    r = simulate(model, t, [0.4, 0.2, -0.1, 0.0], method="scipy-RK45", rtol=1e-8, atol=1e-10)
    assert r.n_evaluations == len(calls) > 0  # the model has no outputs: every call is the integrator's
    assert r.n_steps is None and r.n_rejected is None and r.n_linearizations == 0

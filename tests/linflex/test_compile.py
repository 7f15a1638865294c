"""compile_model: Kane's equations against closed forms (double pendulum, gravity gradient, spin)."""

from __future__ import annotations

import numpy as np
import pytest

from linflex import (
    Body,
    Frame,
    Joint,
    Model,
    ModelError,
    NonlinearModel,
    Orbit,
    Scene,
    Wheel,
    compile_model,
)

G, L, MASS = 9.81, 1.3, 0.7


def double_pendulum(**kw) -> Scene:
    # Two point masses on massless rods hanging along -z, hinges about +y (Banerjee 2016, Eq. 1.21).
    return Scene(
        "double_pendulum", effects=["gravity"],
        bodies=[Body("b1", MASS, [0, 0, 0], com=[0, 0, -L]), Body("b2", MASS, [0, 0, 0], com=[0, 0, -L])],
        joints=[Joint("j1", "revolute", "b1", axis=[0, 1, 0]),
                Joint("j2", "revolute", "b2", parent="b1", axis=[0, 1, 0], parent_point=[0, 0, -L])],
        environment={"gravity": [0, 0, -G]}, **kw)


def closed_form_double_pendulum(x):
    """Reference notes section 1.3 (Banerjee Eq. 1.21) with u1 = q1', u2 = q1' + q2'."""
    q1, q2, r1, r2 = x
    u1, u2 = r1, r1 + r2
    M = MASS * L**2 * np.array([[2, np.cos(q2)], [np.cos(q2), 1]])
    rhs = MASS * L**2 * np.sin(q2) * np.array([u2**2, -(u1**2)]) - np.array(
        [2 * MASS * G * L * np.sin(q1), MASS * G * L * np.sin(q1 + q2)])
    du1, du2 = np.linalg.solve(M, rhs)
    return np.array([r1, r2, du1, du2 - du1])  # relative rates: q2'' = u2' - u1'


def central_jacobian(model: NonlinearModel, x, u=None, h=1e-6):
    """Independent reference: central differences computed here with numpy."""
    u = np.zeros(model.n_inputs) if u is None else u
    f = lambda z: model.evaluate(z, u)[0]  # noqa: E731
    return np.column_stack([(f(x + h * e) - f(x - h * e)) / (2 * h) for e in np.eye(x.size)])


def test_double_pendulum_equals_closed_form_at_random_states():
    model = compile_model(double_pendulum())
    assert isinstance(model, Model) and isinstance(model, NonlinearModel)
    assert model.states == ("j1.angle", "j2.angle", "j1.rate", "j2.rate")
    rng = np.random.default_rng(1)
    for _ in range(5):
        x = rng.uniform(-2, 2, 4)
        # Same equations, different algebra: agreement to round-off (1e-12 relative).
        np.testing.assert_allclose(model.evaluate(x)[0], closed_form_double_pendulum(x), rtol=1e-12, atol=1e-12)


def test_double_pendulum_linear_frequencies():
    model = compile_model(double_pendulum())
    A = central_jacobian(model, np.zeros(4))
    w2 = np.sort(-np.linalg.eigvals(A[2:, :2]).real)
    # omega^2 = (2 -+ sqrt 2) g / l (reference notes 1.3); central differences of a smooth f: 1e-7.
    np.testing.assert_allclose(w2, (2 + np.array([-1, 1]) * np.sqrt(2)) * G / L, rtol=1e-7)


def test_double_pendulum_autodiff_matches_central_difference():
    import casadi as ca

    model = compile_model(double_pendulum())
    f, _ = model.casadi_functions()
    x = ca.MX.sym("x", 4)
    jac = ca.Function("J", [x], [ca.jacobian(f(x, ca.MX(0, 1), ca.MX(0, 1), 0), x)])
    xop = np.array([0.3, -0.2, 0.1, 0.4])
    # Exact Jacobian vs central differences (truncation ~h^2 * f''' ~ 1e-9).
    np.testing.assert_allclose(np.asarray(jac(xop)), central_jacobian(model, xop), rtol=1e-7, atol=1e-8)


def test_mx_and_sx_formulations_agree():
    sx = compile_model(double_pendulum(), symbolic="SX")
    mx = compile_model(double_pendulum(), symbolic="MX")
    x = np.array([0.5, -1.0, 0.3, 0.2])
    # Same equations, symbolic vs numeric solve: round-off level.
    np.testing.assert_allclose(mx.evaluate(x)[0], sx.evaluate(x)[0], rtol=1e-12, atol=1e-13)
    with pytest.raises(ModelError, match="symbolic"):
        compile_model(double_pendulum(), symbolic="dense")


def gg_scene(I, joint="spherical", **kw) -> Scene:
    return Scene("gg", effects=["gravity_gradient"], bodies=[Body("sc", 500.0, I)],
                 joints=[Joint("att", joint, "sc")], frame=Frame("lvlh"), orbit=Orbit(radius=7.0e6), **kw)


@pytest.mark.parametrize(
    "I",
    [
        (100.0, 120.0, 50.0),  # Lagrange region Iy > Ix > Iz: stable
        (100.0, 80.0, 50.0),   # Ix > Iy > Iz: roll/yaw unstable
        (60.0, 120.0, 100.0),  # Iz > Ix: pitch unstable
        (1200.0, 1000.0, 300.0),
    ],
)
def test_gravity_gradient_lvlh_frequencies(I):
    Ix, Iy, Iz = I
    model = compile_model(gg_scene(I))
    n = model.scene.orbit.mean_motion
    xdot, _ = model.evaluate(model.x0)
    # Nadir pointing is an equilibrium of the LVLH scene (exact, up to round-off of n^2 terms).
    assert np.max(np.abs(xdot)) < 1e-18
    A = central_jacobian(model, model.x0, h=1e-7) / n
    # Closed forms (Hughes, Spacecraft Attitude Dynamics, 2004, section 9.3; Kaplan 1976):
    # pitch s^2 = -3 (Ix - Iz)/Iy n^2; roll/yaw s^4 + (1 + 3 k1 + k1 k3) s^2 + 4 k1 k3 = 0
    # with k1 = (Iy - Iz)/Ix, k3 = (Iy - Ix)/Iz (s in units of n).
    k1, k3 = (Iy - Iz) / Ix, (Iy - Ix) / Iz
    s2 = np.roots([1, 1 + 3 * k1 + k1 * k3, 4 * k1 * k3])
    expected = np.concatenate([np.sqrt(s2.astype(complex)), -np.sqrt(s2.astype(complex)),
                               np.sqrt(np.array([-3 * (Ix - Iz) / Iy], complex)),
                               -np.sqrt(np.array([-3 * (Ix - Iz) / Iy], complex))])
    ev = np.linalg.eigvals(A)
    ev = ev[np.argsort(np.abs(ev))][1:]  # drop the quaternion-norm eigenvalue at 0
    # Central differences in units of n: 1e-6 absolute.
    for e in expected:
        assert np.min(np.abs(ev - e)) < 1e-6, (e, ev)


def test_gravity_gradient_free_joint_gives_hill_equations():
    model = compile_model(gg_scene((100.0, 120.0, 50.0), joint="free"))
    n = model.scene.orbit.mean_motion
    A = central_jacobian(model, model.x0, h=1e-4)
    # Clohessy-Wiltshire / Hill equations in LVLH (x along-track, y = -orbit normal, z nadir;
    # Fehse, Automated Rendezvous and Docking of Spacecraft, 2003, Eq. 3.22):
    # x'' = 2 n z', y'' = -n^2 y, z'' = 3 n^2 z - 2 n x'. Positions are rows 0..2, rates 7..9.
    acc = A[7:10][:, [0, 1, 2, 7, 8, 9]] / n**2
    expected = np.array([[0, 0, 0, 0, 0, 2 / n], [0, -1, 0, 0, 0, 0], [0, 0, 3, -2 / n, 0, 0]])
    np.testing.assert_allclose(acc, expected, rtol=1e-6, atol=1e-6)


def test_steady_spin_eigenvalues_with_wheel():
    # Torque-free gyrostat spinning at W about z, seen in a frame spinning with it, with a wheel
    # along z at constant relative speed Om. Linearizing Euler's equations
    # I w' + w x (I w + J Om z) = 0 about w = W z gives the nutation eigenvalues
    # lambda^2 = -(Hs - Ix W)(Hs - Iy W) / (Ix Iy), Hs = Iz_c W + J Om, Iz_c = Iz + J
    # (Hughes, Spacecraft Attitude Dynamics, 2004, section 3.5, derived again here).
    Ix, Iy, Iz, J, W, Om = 10.0, 12.0, 8.0, 0.2, 0.3, 40.0
    scene = Scene("spin", effects=["wheel_gyroscopics"], bodies=[Body("sc", 50.0, (Ix, Iy, Iz))],
                  joints=[Joint("att", "spherical", "sc")],
                  wheels=[Wheel("w", "sc", J, axis=[0, 0, 1], speed=Om)],
                  frame=Frame("spin", rate=W, axis=[0, 0, 1]))
    model = compile_model(scene)
    np.testing.assert_allclose(model.x0[4:], [0, 0, W], atol=1e-15)  # zero rate relative to the frame
    assert np.max(np.abs(model.evaluate(model.x0)[0])) < 1e-14  # steady spin is an equilibrium
    ev = np.linalg.eigvals(central_jacobian(model, model.x0))
    Hs = (Iz + J) * W + J * Om
    wn = np.sqrt((Hs - Ix * W) * (Hs - Iy * W) / (Ix * Iy))
    # Central differences of a smooth f: 1e-7 absolute on the eigenvalue.
    assert np.min(np.abs(ev - 1j * wn)) < 1e-7, (ev, wn)
    assert np.min(np.abs(ev + 1j * wn)) < 1e-7, (ev, wn)
    # The attitude relative to the spinning frame adds +-i W (kinematics of the frame rotation).
    assert np.min(np.abs(ev - 1j * W)) < 1e-7


def test_invalid_scene_rejected_by_compile():
    bad = Scene("bad", bodies=[Body("hub", -1.0, (1, 1, 1))], joints=[Joint("j", "free", "hubb")])
    with pytest.raises(ModelError) as err:
        compile_model(bad)
    text = str(err.value)
    assert "bodies[0].mass" in text and "joints[0].child" in text and "did you mean 'hub'" in text


@pytest.mark.parametrize("method", ["autodiff", "perturbation"])
@pytest.mark.parametrize("I", [(100.0, 120.0, 50.0), (100.0, 80.0, 50.0), (60.0, 120.0, 100.0)])
def test_gravity_gradient_with_linflex_linearize(method, I):
    lz = pytest.importorskip("linflex.linearize")
    from linflex import OperatingPoint

    Ix, Iy, Iz = I
    model = compile_model(gg_scene(I))
    n = model.scene.orbit.mean_motion
    lin = lz.linearize(model, OperatingPoint(model.x0), method=method)
    ev = np.linalg.eigvals(np.asarray(lin.sys.A)) / n
    k1, k3 = (Iy - Iz) / Ix, (Iy - Ix) / Iz
    s2 = np.concatenate([np.roots([1, 1 + 3 * k1 + k1 * k3, 4 * k1 * k3]), [-3 * (Ix - Iz) / Iy]]).astype(complex)
    # Same closed forms as above (Hughes 2004, 9.3); autodiff is exact, perturbation ~1e-6 digits.
    for e in np.concatenate([np.sqrt(s2), -np.sqrt(s2)]):
        assert np.min(np.abs(ev - e)) < 1e-5, (method, e, ev)


@pytest.mark.parametrize("t", [0.0, 0.7, 2.1])
def test_prescribed_spinning_table_bar(t):
    # Banerjee 2016, Eq. 1.76 (reference notes 3.3): a massless rod of length L with end mass m,
    # torsion spring k at radius R on a table turning at the prescribed angle A sin(W t):
    # u1' = -k/(m L^2) q1 - (R/L) w^2 sin q1 - [1 + (R/L) cos q1] w'.
    m, L, R, k, A, W = 2.0, 0.8, 0.8, 2.0 * 0.8**2, 1.5, 1.3
    scene = Scene("table", effects=["joint_springs"],
                  bodies=[Body("table", 10.0, (1, 1, 1)), Body("bar", m, (0, 0, 0), com=[L, 0, 0])],
                  joints=[Joint("spin", "revolute", "table", prescribed={"profile": "sine", "amplitude": A, "frequency": W}),
                          Joint("hinge", "revolute", "bar", parent="table", parent_point=[R, 0, 0], stiffness=k)])
    model = compile_model(scene)
    assert model.states == ("hinge.angle", "hinge.rate")
    q1, u1 = 0.4, -0.3
    w, wdot = A * W * np.cos(W * t), -A * W**2 * np.sin(W * t)
    expected = -k / (m * L**2) * q1 - (R / L) * w**2 * np.sin(q1) - (1 + (R / L) * np.cos(q1)) * wdot
    np.testing.assert_allclose(model.evaluate([q1, u1], t=t)[0], [u1, expected], rtol=1e-12, atol=1e-14)


def test_spinning_table_linear_stiffness():
    # Reference notes 3.3 numbers: k/(m L^2) = 1, R/L = 1, w = 2 -> correct stiffness 5
    # (the prematurely linearized model would give -3). Constant spin: a ramp profile.
    scene = Scene("table", effects=["joint_springs"],
                  bodies=[Body("table", 10.0, (1, 1, 1)), Body("bar", 1.0, (0, 0, 0), com=[1.0, 0, 0])],
                  joints=[Joint("spin", "revolute", "table", prescribed={"profile": "ramp", "rate": 2.0}),
                          Joint("hinge", "revolute", "bar", parent="table", parent_point=[1.0, 0, 0], stiffness=1.0)])
    A = central_jacobian(compile_model(scene), np.zeros(2))
    np.testing.assert_allclose(A, [[0, 1], [-5.0, 0]], atol=1e-8)  # central differences: 1e-8


def test_locked_elbow_is_a_compound_pendulum():
    beta = 0.3
    scene = double_pendulum().replace(joints=(
        Joint("j1", "revolute", "b1", axis=[0, 1, 0]),
        Joint("j2", "revolute", "b2", parent="b1", axis=[0, 1, 0], parent_point=[0, 0, -L], locked=True, q0=beta)))
    model = compile_model(scene)
    assert model.states == ("j1.angle", "j1.rate")
    th = 0.5
    # Masses at L e(th) and L e(th) + L e(th + beta):
    # I_O th'' = -m g L (2 sin th + sin(th + beta)), I_O = m L^2 + m L^2 (2 + 2 cos beta).
    I_O = MASS * L**2 * (1 + 2 + 2 * np.cos(beta))
    expected = -MASS * G * L * (2 * np.sin(th) + np.sin(th + beta)) / I_O
    np.testing.assert_allclose(model.evaluate([th, 0.0])[0], [0.0, expected], rtol=1e-12, atol=1e-15)


def test_prismatic_spring_and_initial_state():
    scene = Scene("slider", effects=["joint_springs"], bodies=[Body("cart", 3.0, (1, 1, 1))],
                  joints=[Joint("rail", "prismatic", "cart", axis=[1, 1, 0], stiffness=12.0, damping=0.6, q0=0.2, u0=-0.1)])
    model = compile_model(scene)
    assert model.states == ("rail.position", "rail.rate")
    np.testing.assert_array_equal(model.x0, [0.2, -0.1])
    # m s'' = -k s - c s' along the unit axis.
    np.testing.assert_allclose(model.evaluate(model.x0)[0], [-0.1, (-12.0 * 0.2 + 0.6 * 0.1) / 3.0], rtol=1e-14)


def test_point_sensors_hand():
    from scipy.spatial.transform import Rotation

    from linflex import Sensor

    I = np.diag([3.0, 4.0, 5.0])
    p = np.array([0.3, -0.2, 0.5])
    scene = Scene("s", bodies=[Body("sc", 7.0, (3.0, 4.0, 5.0))], joints=[Joint("j", "free", "sc")],
                  sensors=[Sensor("pos", "position", body="sc", point=p.tolist()),
                           Sensor("vel", "velocity", body="sc", point=p.tolist()),
                           Sensor("acc", "acceleration", body="sc", point=p.tolist()),
                           Sensor("gyro", "rate", body="sc"),
                           Sensor("att", "attitude", body="sc")])
    model = compile_model(scene)
    r, v = np.array([1.0, 2.0, 3.0]), np.array([0.1, 0.2, -0.3])
    q = np.array([0.9, 0.1, -0.3, 0.2])
    q /= np.linalg.norm(q)
    w = np.array([0.4, -0.2, 0.3])
    y = model.evaluate(np.concatenate([r, q, v, w]))[1]
    C = Rotation.from_quat(np.r_[q[1:], q[0]]).as_matrix()
    alpha = np.linalg.solve(I, -np.cross(w, I @ w))  # torque-free Euler equations
    # Rigid-body kinematics of a body point (body-axis rates, inertial frame).
    np.testing.assert_allclose(y[0:3], r + C @ p, rtol=1e-14)
    np.testing.assert_allclose(y[3:6], v + C @ np.cross(w, p), rtol=1e-14)
    np.testing.assert_allclose(y[6:9], np.cross(alpha, p) + np.cross(w, np.cross(w, p)), rtol=1e-12)
    np.testing.assert_allclose(y[9:12], w, rtol=1e-15)
    np.testing.assert_allclose(y[12:15], 0.5 * np.array([C[2, 1] - C[1, 2], C[0, 2] - C[2, 0], C[1, 0] - C[0, 1]]), rtol=1e-14)


def chain_scene(n_links: int) -> Scene:
    bodies = [Body(f"b{i}", 1.0 + 0.1 * i, (0.01, 0.02, 0.015), com=[0, 0, -0.5]) for i in range(n_links)]
    joints = [Joint(f"j{i}", "revolute", f"b{i}", parent="ground" if i == 0 else f"b{i - 1}",
                    axis=[0, 1, 0] if i % 2 else [1, 0, 0], parent_point=[0, 0, 0] if i == 0 else [0, 0, -1.0],
                    stiffness=10.0, damping=0.1) for i in range(n_links)]
    return Scene("chain", effects=["gravity", "joint_springs"], bodies=bodies, joints=joints)


def test_long_chain_mx_solve_matches_symbolic_solve():
    scene = chain_scene(14)  # "auto" keeps the mass-matrix products and the solve numeric (MX)
    mx = compile_model(scene)
    sx = compile_model(scene, symbolic="SX")
    x = np.random.default_rng(3).normal(size=28) * 0.3
    assert mx.graph_size < sx.graph_size  # the O(n^3) symbolic expansion is avoided
    # Same equations, numeric vs symbolic elimination: round-off (1e-10 relative to the largest).
    a, b = mx.evaluate(x)[0], sx.evaluate(x)[0]
    np.testing.assert_allclose(a, b, rtol=1e-9, atol=1e-10 * np.max(np.abs(b)))
    E = mx.energy(x, 0.0)
    assert np.isfinite(float(E))


@pytest.mark.parametrize("symbolic", ["SX", "MX"])
def test_exposed_parameters_equal_recompiled_scene(symbolic):
    scene = Scene("p", effects=["joint_springs", "gravity"],
                  bodies=[Body("arm", 2.0, [[0.3, 0.01, 0.0], [0.01, 0.4, 0.02], [0.0, 0.02, 0.2]], com=[0.5, 0, 0]),
                          Body("tip", 0.5, (0.01, 0.01, 0.01), com=[0.2, 0, 0])],
                  joints=[Joint("h", "revolute", "arm", axis=[0, 0, 1], stiffness=3.0, damping=0.1),
                          Joint("e", "revolute", "tip", parent="arm", parent_point=[1.0, 0, 0], axis=[0, 1, 0], stiffness=1.0)])
    model = compile_model(scene, params=["arm.mass", "arm.Izz", "arm.Ixy", "h.stiffness"], symbolic=symbolic)
    assert model.params == ("arm.mass", "arm.Izz", "arm.Ixy", "h.stiffness")
    np.testing.assert_array_equal(model.param_values, [2.0, 0.2, 0.01, 3.0])
    assert model.f.n_in() == 4  # f(x, u, p, t)
    changed = scene.replace(
        bodies=(Body("arm", 2.5, [[0.3, 0.03, 0.0], [0.03, 0.4, 0.02], [0.0, 0.02, 0.35]], com=[0.5, 0, 0]), scene.bodies[1]),
        joints=(Joint("h", "revolute", "arm", axis=[0, 0, 1], stiffness=7.0, damping=0.1), scene.joints[1]))
    reference = compile_model(changed, symbolic=symbolic)
    x = np.array([0.3, -0.4, 0.5, 0.2])
    # Parameters substituted at run time vs numbers compiled in: round-off.
    np.testing.assert_allclose(model.evaluate(x, params=[2.5, 0.35, 0.03, 7.0])[0], reference.evaluate(x)[0], rtol=1e-12)
    swapped = model.with_params(**{"arm.mass": 2.5, "arm.Izz": 0.35, "arm.Ixy": 0.03, "h.stiffness": 7.0})
    np.testing.assert_allclose(swapped.evaluate(x)[0], reference.evaluate(x)[0], rtol=1e-12)
    np.testing.assert_allclose(float(swapped.energy(x, swapped.param_values, 0.0)), float(reference.energy(x, 0.0)), rtol=1e-12)
    with pytest.raises(ModelError, match="did you mean 'arm.mass'"):
        compile_model(scene, params=["arm.mas"])


def test_simulate_model_with_parameters():
    from linflex import simulate

    scene = double_pendulum()
    model = compile_model(scene, params=["b1.mass", "b2.mass"])
    plain = compile_model(scene)
    t = np.linspace(0, 2, 11)
    a = simulate(model, t, [0.3, 0.1, 0, 0], rtol=1e-10, atol=1e-12)
    b = simulate(plain, t, [0.3, 0.1, 0, 0], rtol=1e-10, atol=1e-12)
    # Same equations, parameters at their nominal values: agreement to the integrator tolerance.
    np.testing.assert_allclose(a.x, b.x, atol=1e-9)
    np.testing.assert_allclose(a.energy, b.energy, rtol=1e-9)


def test_free_joint_with_locked_translations():
    # Locking x and z of a free joint in LVLH with gravity gradient: y stays free (Hill's
    # out-of-plane oscillator y'' = -n^2 y) and the attitude dynamics are the spherical joint's.
    scene = gg_scene((100.0, 120.0, 50.0), joint="free").replace(
        joints=(Joint("att", "free", "sc", locked=["x", "z"], q0=[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0]),))
    model = compile_model(scene)
    assert model.states == ("att.y", "att.qw", "att.qx", "att.qy", "att.qz", "att.vy", "att.wx", "att.wy", "att.wz")
    n = scene.orbit.mean_motion
    x = model.x0.copy()
    x[0] = 10.0
    xdot = model.evaluate(x)[0]
    np.testing.assert_allclose(xdot[5], -(n**2) * 10.0, rtol=1e-10)
    sph = compile_model(gg_scene((100.0, 120.0, 50.0)))
    q = np.array([0.99, 0.05, -0.1, 0.03])
    q /= np.linalg.norm(q)
    w = np.array([1e-3, -2e-3, 3e-4])
    # Same attitude equations as the spherical joint (the body's mass centre at the origin).
    np.testing.assert_allclose(model.evaluate(np.r_[0.0, q, 0.0, w])[0][[1, 2, 3, 4, 6, 7, 8]],
                               sph.evaluate(np.r_[q, w])[0], rtol=1e-12, atol=1e-20)
    bad = scene.replace(joints=(Joint("att", "free", "sc", locked=["x", "pitch"]),))
    assert "joints[0].locked[1]: unknown coordinate 'pitch'; a free joint can lock its translations 'x', 'y', 'z'" in bad.problems()


@pytest.mark.parametrize("method", ["autodiff", "central"])
def test_linearize_through_numeric_solve_matches_central_differences(method):
    # A free joint (6 speeds) compiles with the numeric (MX) solve; linflex.linearize must
    # differentiate through it. Reference: the central differences of this file (1e-6 relative).
    lz = pytest.importorskip("linflex.linearize")
    from linflex import OperatingPoint

    model = compile_model(gg_scene((100.0, 120.0, 50.0), joint="free"))
    assert model.n_speeds == 6 and model.graph_size > 0
    lin = lz.linearize(model, OperatingPoint(model.x0), method=method)
    ref = central_jacobian(model, model.x0, h=1e-4)
    A = np.asarray(lin.sys.A)
    np.testing.assert_allclose(A, ref, atol=1e-6 * np.max(np.abs(ref)))


def test_power_balance_of_a_100_state_chain():
    # Kane's equations at order 100 checked by the power balance dE/dt = grad(E) . f(x) =
    # -sum c_i u_i^2 (joint dampers are the only non-conservative forces; u_i are relative rates).
    import casadi as ca

    n_links, c = 50, 0.3
    scene = chain_scene(n_links).replace(joints=tuple(
        Joint(j.name, j.type, j.child, parent=j.parent, axis=j.axis, parent_point=j.parent_point,
              stiffness=40.0, damping=c) for j in chain_scene(n_links).joints))
    model = compile_model(scene)
    assert model.n_states == 100
    x = ca.MX.sym("x", 100)
    grad, xdot = ca.gradient(model.energy(x, 0.0), x), model.f(x, ca.MX(0, 1), 0.0)
    power = ca.Function("P", [x], [ca.dot(grad, xdot), ca.dot(ca.fabs(grad), ca.fabs(xdot))])
    rng = np.random.default_rng(5)
    for _ in range(3):
        z = np.concatenate([rng.normal(size=n_links) * 0.2, rng.normal(size=n_links)])
        expected = -c * np.sum(z[n_links:] ** 2)
        value, scale = (float(v) for v in power(z))
        # The sum cancels terms of size `scale` (spring, gravity and inertia power): round-off of
        # a 100-state elimination, 1e-14 of that scale (measured ~1e-16), and 1e-6 of the result.
        assert abs(value - expected) < 1e-14 * scale, (value, expected, scale)
        assert value == pytest.approx(expected, rel=1e-6)


def test_lightly_damped_joint_eigenvalues():
    # Damping ratio 1e-4: a rod on a revolute joint with spring k and damper c,
    # s = -zeta w0 +- i w0 sqrt(1 - zeta^2), w0 = sqrt(k / J), zeta = c / (2 sqrt(k J)).
    J, k, zeta = 2.0, 50.0, 1e-4
    c = 2 * zeta * np.sqrt(k * J)
    scene = Scene("rod", effects=["joint_springs"], bodies=[Body("rod", 1.0, (1.0, J, 1.0))],
                  joints=[Joint("h", "revolute", "rod", axis=[0, 1, 0], stiffness=k, damping=c)])
    A = central_jacobian(compile_model(scene), np.zeros(2))
    w0 = np.sqrt(k / J)
    ev = np.linalg.eigvals(A)
    ev = ev[np.argsort(ev.imag)]
    expected = np.array([-zeta * w0 - 1j * w0 * np.sqrt(1 - zeta**2), -zeta * w0 + 1j * w0 * np.sqrt(1 - zeta**2)])
    # The real part is 5e-4: resolved to 1e-9 absolute (central differences of a linear f are exact).
    np.testing.assert_allclose(ev.real, expected.real, atol=1e-9)
    np.testing.assert_allclose(ev.imag, expected.imag, rtol=1e-12)


def test_with_params_shares_the_construction_data_and_the_equations():
    model = compile_model(double_pendulum(), params=["b1.mass"])
    swapped = model.with_params(**{"b1.mass": 2.0})
    # One frozen record and one graph cache, shared: nothing is re-listed, copied or compiled.
    assert swapped.compiled is model.compiled and swapped.equations is model.equations
    assert swapped.param_values.tolist() == [2.0] and model.param_values.tolist() == [MASS]
    assert swapped.x0 is model.x0 and not swapped.x0.flags.writeable
    with pytest.raises(AttributeError):
        swapped.compiled = None  # frozen


def test_a_pickled_model_carries_its_equations_without_compiling(monkeypatch):
    import pickle

    from linflex import OperatingPoint, load_scene
    from linflex.compiler import _compile
    from linflex.linearize import linearize

    model = compile_model(load_scene("examples/four_bar.toml"))
    data = pickle.dumps(model)

    def no_compiling(*args, **kwargs):
        raise AssertionError("an unpickled model compiled its scene again")

    monkeypatch.setattr(_compile, "compile_model", no_compiling)
    back = pickle.loads(data)
    assert not back.x0.flags.writeable and np.array_equal(back.x0, model.x0)
    assert back.compiled.n_speeds == model.n_speeds and back.effects == model.effects
    op = OperatingPoint(model.x0, np.zeros(model.n_inputs))
    a = linearize(model, op, method="kane", allow_non_equilibrium=True).sys
    b = linearize(back, op, method="kane", allow_non_equilibrium=True).sys
    # The same graphs (serialized by CasADi, symbols shared) evaluated the same way: bit for bit.
    np.testing.assert_array_equal(b.A, a.A)
    np.testing.assert_array_equal(b.B, a.B)
    assert pickle.loads(pickle.dumps(back)).equations is not None  # and again, from the packed graphs

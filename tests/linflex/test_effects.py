"""Each built-in effect against a hand calculation; an omitted effect is absent from the graph."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from linflex import (
    Actuator,
    Body,
    Controller,
    Effect,
    Frame,
    Joint,
    ModelError,
    Orbit,
    Pendulum,
    Scene,
    Sensor,
    Spring,
    Surface,
    Wheel,
    compile_model,
    register_effect,
    registered_effects,
)

MASS = 12.0
INERTIA = np.array([[3.0, 0.1, -0.2], [0.1, 4.0, 0.3], [-0.2, 0.3, 5.0]])
MU = 3.986004418e14
R0 = 7.0e6


def free_body(effects, **kw) -> Scene:
    return Scene("b", effects=effects, bodies=[Body("sc", MASS, INERTIA)], joints=[Joint("j", "free", "sc")], **kw)


def split_free(model, x):
    """(translational acceleration, angular acceleration) of a free joint (states x..qz, v, w)."""
    xdot = model.evaluate(x)[0]
    return xdot[7:10], xdot[10:13]


def state(q=(1.0, 0.0, 0.0, 0.0), r=(0.0, 0.0, 0.0), v=(0.0, 0.0, 0.0), w=(0.0, 0.0, 0.0)):
    return np.concatenate([r, q, v, w])


def dcm(q):
    """Child-to-parent rotation matrix of a scalar-first quaternion (scipy, independent)."""
    return Rotation.from_quat([q[1], q[2], q[3], q[0]]).as_matrix()


def unit_quat(seed):
    q = np.random.default_rng(seed).normal(size=4)
    return q / np.linalg.norm(q)


def instructions(model) -> int:
    return model.graph_size


def assert_same_results(model_a, model_b, x):
    # Zero strength vs omitted: the same numbers up to round-off (a few ulps).
    np.testing.assert_allclose(model_a.evaluate(x)[0], model_b.evaluate(x)[0], rtol=1e-13, atol=1e-15)


# -- gravity ---------------------------------------------------------------------------------


def test_uniform_gravity_hand_and_omitted():
    g = np.array([0.3, -1.0, -9.0])
    with_g = compile_model(free_body(["gravity"], environment={"gravity": g.tolist()}))
    x = state(q=unit_quat(1), w=(0.0, 0.0, 0.0))
    a, alpha = split_free(with_g, x)
    np.testing.assert_allclose(a, g, rtol=1e-14)  # F = m g on the mass centre: a = g exactly
    np.testing.assert_allclose(alpha, 0, atol=1e-15)
    without = compile_model(free_body([]))
    zero = compile_model(free_body(["gravity"], environment={"gravity": [0.0, 0.0, 0.0]}))
    assert instructions(without) < instructions(with_g)
    assert_same_results(without, zero, state(q=unit_quat(2), v=(1, 2, 3), w=(0.1, -0.2, 0.3)))


def test_central_gravity_hand():
    scene = free_body(["central_gravity"], frame=Frame("lvlh"), orbit=Orbit(radius=R0))
    model = compile_model(scene)
    n = scene.orbit.mean_motion
    dz = 250.0
    a, _ = split_free(model, state(r=(0.0, 0.0, dz)))
    # Radial offset toward the Earth in LVLH: z'' = mu/(r0 - dz)^2 - mu/r0^2 + n^2 dz (free-falling
    # origin, centrifugal term of the frame rotation); exact up to round-off of mu/r0^2 ~ 8 m/s^2.
    expected = MU / (R0 - dz) ** 2 - MU / R0**2 + n**2 * dz
    np.testing.assert_allclose(a, [0.0, 0.0, expected], atol=1e-13)
    omitted = compile_model(scene.replace(effects=()))
    assert instructions(omitted) < instructions(model)
    np.testing.assert_allclose(split_free(omitted, state(r=(0.0, 0.0, dz)))[0], [0, 0, n**2 * dz], rtol=1e-12)


def test_gravity_gradient_torque_hand():
    scene = Scene("gg", effects=["gravity_gradient"], bodies=[Body("sc", MASS, INERTIA)],
                  joints=[Joint("att", "spherical", "sc")], frame=Frame("lvlh"), orbit=Orbit(radius=R0))
    model = compile_model(scene)
    q, w = unit_quat(3), np.array([1e-3, -2e-3, 5e-4])
    xdot = model.evaluate(np.concatenate([q, w]))[0]
    R_B = dcm(q).T @ np.array([0.0, 0.0, -R0])
    T = 3 * MU / R0**5 * np.cross(R_B, INERTIA @ R_B)  # Wertz 1978, Eq. 17-56 (first order)
    expected = np.linalg.solve(INERTIA, T - np.cross(w, INERTIA @ w))
    np.testing.assert_allclose(xdot[4:], expected, rtol=1e-12, atol=1e-20)
    omitted = compile_model(scene.replace(effects=()))
    assert instructions(omitted) < instructions(model)
    np.testing.assert_allclose(omitted.evaluate(np.concatenate([q, w]))[0][4:],
                               np.linalg.solve(INERTIA, -np.cross(w, INERTIA @ w)), rtol=1e-12, atol=1e-20)


# -- surfaces ----------------------------------------------------------------------------------


@pytest.mark.parametrize("rho", [0.0, 0.6])
def test_solar_pressure_flat_plate_hand(rho):
    sun = np.array([1.0, 2.0, 2.0]) / 3.0
    normal, point, area, P = np.array([0.0, 0.6, 0.8]), np.array([0.5, -0.2, 1.0]), 7.0, 4.56e-6
    scene = free_body(["solar_pressure"], environment={"sun_direction": sun.tolist(), "solar_pressure": P},
                      surfaces=[Surface("panel", "sc", area, normal=normal.tolist(), point=point.tolist(), reflectivity=rho)])
    model = compile_model(scene)
    q = unit_quat(4)
    C = dcm(q)
    n_F = C @ normal
    c = n_F @ sun
    assert c > 0  # lit for this attitude (checked, so the hand formula below applies)
    F = -P * area * c * ((1 - rho) * sun + 2 * rho * c * n_F)  # Wertz 1978, Eq. 17-12
    a, alpha = split_free(model, state(q=q))
    np.testing.assert_allclose(a, F / MASS, rtol=1e-12)
    np.testing.assert_allclose(alpha, np.linalg.solve(INERTIA, np.cross(point, C.T @ F)), rtol=1e-12)
    # The dark side gets nothing.
    q_dark = np.array([0.0, 1.0, 0.0, 0.0])  # 180 deg about x: n_F = (0, -0.6, -0.8), n.s < 0
    assert dcm(q_dark) @ normal @ sun < 0
    np.testing.assert_allclose(split_free(model, state(q=q_dark))[0], 0, atol=1e-20)
    zero = compile_model(scene.replace(environment={"sun_direction": sun.tolist(), "solar_pressure": 0.0}))
    omitted = compile_model(scene.replace(effects=()))
    assert instructions(omitted) < instructions(model)
    assert_same_results(omitted, zero, state(q=q, w=(0.1, 0.2, 0.3)))


def test_aerodynamic_drag_flat_plate_hand():
    env = {"density": 4e-12, "reference_altitude": 500e3, "scale_height": 60e3}
    scene = free_body(["aerodynamic_drag"], frame=Frame("lvlh"), orbit=Orbit(radius=R0), environment=env,
                      surfaces=[Surface("ram", "sc", 2.0, normal=[1, 0, 0], point=[0, 0.3, 0], drag_coefficient=2.2)])
    model = compile_model(scene)
    n = scene.orbit.mean_motion
    v = n * R0  # at rest in LVLH: inertial velocity is the orbital velocity along x
    rho = 4e-12 * np.exp(-((R0 - 6378137.0) - 500e3) / 60e3)
    F = np.array([-0.5 * rho * 2.2 * 2.0 * v**2, 0.0, 0.0])  # flat plate facing the flow
    a, alpha = split_free(model, state())
    np.testing.assert_allclose(a, F / MASS, rtol=1e-12)
    np.testing.assert_allclose(alpha, np.linalg.solve(INERTIA, np.cross([0, 0.3, 0], F)), rtol=1e-12)
    zero = compile_model(scene.replace(environment={**env, "density": 0.0}))
    omitted = compile_model(scene.replace(effects=()))
    assert instructions(omitted) < instructions(model)
    assert_same_results(omitted, zero, state(q=unit_quat(5), v=(0.1, 0, 0), w=(1e-3, 0, 0)))


# -- internal degrees of freedom -------------------------------------------------------------------


def wheel_scene(effects, speed=30.0, mode="constant"):
    return Scene("w", effects=effects, bodies=[Body("sc", MASS, INERTIA)], joints=[Joint("att", "spherical", "sc")],
                 wheels=[Wheel("rw", "sc", 0.04, axis=[0, 1, 1], transverse_inertia=0.02, speed=speed, mode=mode)])


def test_wheel_gyroscopics_hand_and_omitted():
    model = compile_model(wheel_scene(["wheel_gyroscopics"]))
    a = np.array([0.0, 1.0, 1.0]) / np.sqrt(2)
    I_c = INERTIA + 0.02 * (np.eye(3) - np.outer(a, a)) + 0.04 * np.outer(a, a)  # composite inertia
    w = np.array([0.1, -0.05, 0.2])
    x = np.concatenate([unit_quat(6), w])
    # Gyrostat: I_c w' = -w x (I_c w + J Om a) (Hughes 2004, Eq. 3.5.4).
    expected = np.linalg.solve(I_c, -np.cross(w, I_c @ w + 0.04 * 30.0 * a))
    np.testing.assert_allclose(model.evaluate(x)[0][4:], expected, rtol=1e-12)
    omitted = compile_model(wheel_scene([]))
    zero = compile_model(wheel_scene(["wheel_gyroscopics"], speed=0.0))
    assert instructions(omitted) < instructions(model)
    assert_same_results(omitted, zero, x)


def test_wheel_torque_mode_hand():
    scene = wheel_scene(["wheel_gyroscopics"], speed=10.0, mode="torque").replace(
        actuators=(Actuator("motor", "wheel_torque", wheel="rw"),),
        sensors=(Sensor("tach", "wheel_speed", wheel="rw"),))
    model = compile_model(scene)
    assert model.states[-1] == "rw.speed" and model.inputs == ("motor",)
    assert model.outputs == ("tach", "motor.command")
    a = np.array([0.0, 1.0, 1.0]) / np.sqrt(2)
    I_c = INERTIA + 0.02 * (np.eye(3) - np.outer(a, a)) + 0.04 * np.outer(a, a)
    x = np.concatenate([[1.0, 0, 0, 0], [0.0, 0.0, 0.0], [10.0]])
    tau = 0.05
    xdot, y = model.evaluate(x, [tau])
    # At rest: [I_c, J a; J a^T, J] [w'; Om'] = [0; tau] (body + rotor; Hughes 2004, 3.5).
    K = np.block([[I_c, 0.04 * a[:, None]], [0.04 * a[None, :], np.array([[0.04]])]])
    np.testing.assert_allclose(xdot[4:], np.linalg.solve(K, [0, 0, 0, tau]), rtol=1e-12)
    np.testing.assert_allclose(y, [10.0, tau], rtol=1e-15)


def fixed_base(effects, **kw):
    return Scene("fb", effects=effects, bodies=[Body("base", 100.0, (10, 10, 10))],
                 joints=[Joint("weld", "fixed", "base")], **kw)


def test_slosh_pendulum_hand_and_omitted():
    g, L, m, c = 9.81, 0.4, 3.0, 0.2
    scene = fixed_base(["slosh", "gravity"], environment={"gravity": [0, 0, -g]},
                       pendulums=[Pendulum("fuel", "base", m, L, point=[0, 0, 0.1], direction=[0, 0, -1], damping=c)])
    model = compile_model(scene)
    assert model.states == ("fuel.theta1", "fuel.theta2", "fuel.rate1", "fuel.rate2")
    th, rate = 0.3, 0.7
    xdot = model.evaluate([th, 0.0, rate, 0.0])[0]
    # Planar motion of the spherical pendulum: m L^2 th'' = -m g L sin(th) - c th'.
    np.testing.assert_allclose(xdot[2:], [(-m * g * L * np.sin(th) - c * rate) / (m * L**2), 0.0], rtol=1e-12, atol=1e-14)
    # Linear frequency g/L in both directions (small-angle pendulum).
    omitted = fixed_base(["gravity"], environment={"gravity": [0, 0, -g]}, pendulums=scene.pendulums)
    with pytest.raises(ModelError, match="no degrees of freedom"):
        compile_model(omitted)  # without slosh the bob is welded to the fixed base


def test_nutation_damper_hand():
    k, c, m = 40.0, 1.5, 0.5
    scene = fixed_base(["dampers"], springs=[Spring("nd", "base", m, k, c, point=[0.3, 0, 0], axis=[0, 1, 0])])
    model = compile_model(scene)
    s, v = 0.02, -0.1
    xdot = model.evaluate([s, v])[0]
    np.testing.assert_allclose(xdot, [v, (-k * s - c * v) / m], rtol=1e-13)  # m s'' = -k s - c s'
    free = Scene("d", effects=["dampers"], bodies=[Body("sc", MASS, INERTIA)], joints=[Joint("att", "spherical", "sc")],
                 springs=[Spring("nd", "sc", m, k, c, point=[0.3, 0, 0], axis=[0, 1, 0])])
    assert compile_model(free).n_speeds == 4
    assert compile_model(free.replace(effects=())).n_speeds == 3  # omitted: the mass is welded


def test_joint_springs_hand_and_omitted():
    Jy = 2.0 + 5.0 * 0.5**2  # rod inertia about the hinge: own + m d^2 (parallel axis)
    scene = Scene("rod", effects=["joint_springs"], bodies=[Body("rod", 5.0, (1.0, 2.0, 1.0), com=[0.5, 0, 0])],
                  joints=[Joint("h", "revolute", "rod", axis=[0, 1, 0], stiffness=30.0, damping=0.4, rest=0.1)])
    model = compile_model(scene)
    th, rate = 0.5, -0.3
    xdot = model.evaluate([th, rate])[0]
    np.testing.assert_allclose(xdot, [rate, (-30.0 * (th - 0.1) - 0.4 * rate) / Jy], rtol=1e-13)
    omitted = compile_model(scene.replace(effects=()))
    zero = compile_model(scene.replace(joints=(Joint("h", "revolute", "rod", axis=[0, 1, 0]),)))
    assert instructions(omitted) < instructions(model)
    assert_same_results(omitted, zero, np.array([th, rate]))


def test_thrusters_hand_and_omitted():
    scene = free_body(["thrusters"], actuators=[Actuator("thr", "thruster", body="sc", point=[0, 1.0, 0], axis=[1, 0, 0])])
    model = compile_model(scene)
    assert model.inputs == ("thr",)
    q = unit_quat(7)
    xdot = model.evaluate(state(q=q), [2.0])[0]
    F_B = np.array([2.0, 0, 0])
    np.testing.assert_allclose(xdot[7:10], dcm(q) @ F_B / MASS, rtol=1e-12)
    np.testing.assert_allclose(xdot[10:], np.linalg.solve(INERTIA, np.cross([0, 1.0, 0], F_B)), rtol=1e-12)
    omitted = compile_model(scene.replace(effects=()))
    assert omitted.inputs == ()  # no thruster input without the effect


def pd_scene(effects, kp=4.0, kd=9.0):
    return Scene("pd", effects=effects, bodies=[Body("sc", MASS, (3.0, 4.0, 5.0))], joints=[Joint("att", "spherical", "sc")],
                 sensors=[Sensor("roll", "attitude", body="sc", axis=[1, 0, 0]), Sensor("p", "rate", body="sc", axis=[1, 0, 0])],
                 actuators=[Actuator("tx", "torque", body="sc", axis=[1, 0, 0])],
                 controllers=[Controller("pd", "pid", inputs=["roll"], outputs=["tx"], kp=kp, kd=kd, rate_inputs=["p"],
                                         reference=[0.05])])


def test_control_pid_hand_and_omitted():
    model = compile_model(pd_scene(["control"]))
    phi, p = 0.2, 0.1
    x = np.array([np.cos(phi / 2), np.sin(phi / 2), 0, 0, p, 0, 0])
    xdot, y = model.evaluate(x, [0.01])
    # Attitude sensor: sin(phi) for a rotation phi about x; command = u_ext + kp (ref - y) - kd p.
    tx = 0.01 + 4.0 * (0.05 - np.sin(phi)) - 9.0 * p
    np.testing.assert_allclose(xdot[4:], [tx / 3.0, 0, 0], rtol=1e-13, atol=1e-16)
    np.testing.assert_allclose(y, [np.sin(phi), p, tx], rtol=1e-13)
    omitted = compile_model(pd_scene([]))
    zero = compile_model(pd_scene(["control"], kp=0.0, kd=0.0).replace(
        controllers=(Controller("pd", "pid", inputs=["roll"], outputs=["tx"], kp=0.0),)))
    assert instructions(omitted) < instructions(model)
    np.testing.assert_allclose(omitted.evaluate(x, [0.01])[0], zero.evaluate(x, [0.01])[0], rtol=1e-14, atol=1e-16)


def test_state_space_and_transfer_function_controllers_hand():
    # A first-order lag C(s) = 2 / (s + 3) as a transfer function and as a state space.
    tf = pd_scene(["control"]).replace(controllers=(Controller("lag", "transfer_function", inputs=["roll"], outputs=["tx"],
                                                               num=[2.0], den=[1.0, 3.0]),))
    ss = tf.replace(controllers=(Controller("lag", "state_space", inputs=["roll"], outputs=["tx"],
                                            A=[[-3.0]], B=[[1.0]], C=[[2.0]], D=[[0.0]]),))
    mt, ms = compile_model(tf), compile_model(ss)
    assert mt.states[-1] == "lag.x0" and ms.states[-1] == "lag.x0"
    phi = 0.1
    x = np.array([np.cos(phi / 2), np.sin(phi / 2), 0, 0, 0, 0, 0, 0.5])
    xd = ms.evaluate(x)[0]
    # xc' = -3 xc + (0 - sin phi); tx = 2 xc.
    np.testing.assert_allclose(xd[-1], -3 * 0.5 - np.sin(phi), rtol=1e-14)
    np.testing.assert_allclose(xd[4], 2 * 0.5 / 3.0, rtol=1e-14)
    # The transfer function is realized by scipy.signal.tf2ss: for 2/(s + 3) that is the same
    # (A, B, C, D) = (-3, 1, 2, 0), so both models agree to round-off at any state.
    for xc in (0.0, 0.5, -1.0):
        z = np.r_[x[:7], xc]
        np.testing.assert_allclose(mt.evaluate(z)[0], ms.evaluate(z)[0], rtol=1e-14, atol=1e-16)


def test_register_custom_effect():
    class Bias(Effect):
        name = "test_bias_torque"

        def loads(self, b, scene):
            b.add_torque("sc", np.array([0.0, 0.0, 0.5]))

    register_effect(Bias(), replace=True)
    assert "test_bias_torque" in registered_effects()
    model = compile_model(free_body(["test_bias_torque"]))
    alpha = split_free(model, state())[1]
    np.testing.assert_allclose(alpha, np.linalg.solve(INERTIA, [0, 0, 0.5]), rtol=1e-13)
    with pytest.raises(ModelError, match="already registered"):
        register_effect(Bias())
    with pytest.raises(ModelError, match="identifier"):
        register_effect(type("E", (Effect,), {"name": "bad name"})())


def test_named_disturbances_are_inputs_without_outputs():
    from linflex import Disturbance

    scene = pd_scene(["control"]).replace(disturbances=(
        Disturbance("gust", "force", body="sc", point=[0, 0, 1.0], axis=[0, 1, 0]),
        Disturbance("bias", "torque", body="sc")))
    model = compile_model(scene)
    assert model.inputs == ("tx", "gust", "bias.x", "bias.y", "bias.z")
    assert model.outputs == ("roll", "p", "tx.command")
    x = np.array([1.0, 0, 0, 0, 0, 0, 0])
    xdot, y = model.evaluate(x, [0.0, 2.0, 0.1, 0.2, 0.3])
    # At rest with the reference 0.05: PD command 4 * 0.05 = 0.2 about x; force 2 N along y at
    # z = 1 m gives a torque (0, 0, 1) x (0, 2, 0) = (-2, 0, 0); the bias adds (0.1, 0.2, 0.3).
    T = np.array([0.2 - 2.0 + 0.1, 0.2, 0.3])
    np.testing.assert_allclose(xdot[4:], T / np.array([3.0, 4.0, 5.0]), rtol=1e-13)
    np.testing.assert_allclose(y[2], 0.2, rtol=1e-14)  # the disturbance is not in the command
    bad = scene.replace(disturbances=(Disturbance("d", "pressure", body="sx"),))
    problems = bad.problems()
    assert "disturbances[0].type: unknown disturbance type 'pressure'; known: torque, force" in problems
    assert "disturbances[0].body: unknown body 'sx' (did you mean 'sc'?)" in problems


def test_central_gravity_with_gradient_counts_the_force_once():
    orbit = dict(frame=Frame("lvlh"), orbit=Orbit(radius=R0))
    both = compile_model(free_body(["central_gravity", "gravity_gradient"], **orbit))
    central = compile_model(free_body(["central_gravity"], **orbit))
    gradient = compile_model(free_body(["gravity_gradient"], **orbit))
    n = np.sqrt(MU / R0**3)
    x = state(q=unit_quat(9), r=(30.0, -20.0, 50.0), w=(0.0, -n, 0.0))
    # With central gravity the gradient effect adds only torques: forces as central gravity alone.
    np.testing.assert_allclose(split_free(both, x)[0], split_free(central, x)[0], rtol=1e-12)
    # Alone, its first-order tidal force agrees with the exact central field to O(r / r0) ~ 1e-5.
    exact = split_free(central, x)[0]
    np.testing.assert_allclose(split_free(gradient, x)[0], exact, atol=1e-4 * np.max(np.abs(exact)))
    np.testing.assert_allclose(split_free(both, x)[1], split_free(gradient, x)[1], rtol=1e-12)

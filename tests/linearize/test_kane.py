"""Kane's direct linearization (method="kane"): closed forms, premature linearization, autodiff."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from linflex import (
    Body,
    Frame,
    Joint,
    MethodUnavailableError,
    ModalData,
    ModelError,
    NonlinearModel,
    OperatingPoint,
    Orbit,
    Scene,
    Sensor,
    ShapeError,
    Wheel,
    compile_model,
    load_scene,
    simulate,
)
from linflex.linearize import linearize, linearize_along

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


def table_bar(m=1.0, L=1.0, R=1.0, k=1.0, spin=2.0) -> Scene:
    # Reference notes 3.3 (Banerjee 2016, Figs. 1.5-1.6): a massless rod of length L with end
    # mass m, torsion spring k at radius R on a table turning at the constant rate `spin`.
    return Scene("table", effects=["joint_springs"],
                 bodies=[Body("table", 10.0, (1, 1, 1)), Body("bar", m, (0, 0, 0), com=[L, 0, 0])],
                 joints=[Joint("spin", "revolute", "table", prescribed={"profile": "ramp", "rate": spin}),
                         Joint("hinge", "revolute", "bar", parent="table", parent_point=[R, 0, 0], stiffness=k)])


def flexible_table_bar(m=1.0, L=1.0, R=1.0, k=1.0, spin=2.0, geometric=True) -> Scene:
    # The same bar as a one-mode flexible body clamped to the table at the hinge: the tip mass
    # moves L q along y (linear modal kinematics, i.e. prematurely linearized), modal mass m L^2
    # and stiffness k. Its geometric stiffness per unit inertia-load factor (reference notes 5.4):
    # the tip's axial inertia load is -m (A_1 + L A_4), a bar load T gives Phi^T K_g Phi = T L
    # (Cook's bar, Eq. 1.81), so S^(1) = -m L and S^(4) = -m L^2.
    S = np.zeros((12, 1, 1))
    S[0], S[3] = -m * L, -m * L**2
    data = ModalData(positions=[[L, 0, 0]], masses=[m], inertias=np.zeros((1, 3, 3)),
                     translations=[[[0.0], [L], [0.0]]], rotations=[[[0.0], [0.0], [1.0]]],
                     frequencies=[np.sqrt(k / (m * L**2))], damping=[0.0], geometric_stiffness=S)
    return Scene("flexible_table", effects=["geometric_stiffness"] if geometric else [],
                 bodies=[Body("table", 10.0, (1, 1, 1)), Body("bar", 0.0, type="flexible", modal_data=data)],
                 joints=[Joint("spin", "revolute", "table", prescribed={"profile": "ramp", "rate": spin}),
                         Joint("clamp", "fixed", "bar", parent="table", parent_point=[R, 0, 0])])


def kane(model, x=None, **kw):
    x = model.x0 if x is None else x
    return linearize(model, OperatingPoint(x, np.zeros(model.n_inputs)), method="kane", **kw)


def assert_same_as_autodiff(model, x=None, rtol=1e-10):
    x = model.x0 if x is None else np.asarray(x, float)
    op = OperatingPoint(x, np.zeros(model.n_inputs))
    direct = linearize(model, op, method="kane", allow_non_equilibrium=True)
    exact = linearize(model, op, method="autodiff", allow_non_equilibrium=True)
    for name in "ABCD":
        ours, ref = getattr(direct.sys, name), getattr(exact.sys, name)
        scale = max(np.max(np.abs(ref)) if ref.size else 0.0, 1e-300)
        assert np.max(np.abs(ours - ref), initial=0.0) <= rtol * scale, (name, np.max(np.abs(ours - ref)) / scale)
    np.testing.assert_allclose(direct.residual, exact.residual, rtol=1e-12, atol=1e-14)
    return direct


def test_spinning_table_bar_direct_and_premature():
    # Reference notes 3.3 numbers: k/(m L^2) = 1, R/L = 1, omega = 2 -> Kane's direct
    # linearization gives the stiffness k + m R L omega^2 = 5 (Eq. 1.75), premature linearization
    # k - m L^2 omega^2 = -3 (Eq. 1.78). Exact arithmetic on small numbers: 1e-13.
    model = compile_model(table_bar())
    direct, premature = kane(model), kane(model, premature=True)
    np.testing.assert_allclose(direct.second_order.M, [[1.0]], rtol=1e-13)
    np.testing.assert_allclose(direct.second_order.K, [[5.0]], rtol=1e-13)
    np.testing.assert_allclose(premature.second_order.K, [[-3.0]], rtol=1e-13)
    # By origin: the spring, and the centrifugal stiffness of the inertia forces.
    assert set(direct.stiffness) == {"joint_springs", "inertia"}
    np.testing.assert_allclose(direct.stiffness["joint_springs"], [[1.0]], rtol=1e-13)
    np.testing.assert_allclose(direct.stiffness["inertia"], [[4.0]], rtol=1e-13)
    np.testing.assert_allclose(premature.stiffness["inertia"], [[-4.0]], rtol=1e-13)
    np.testing.assert_allclose(direct.sys.A, [[0, 1], [-5, 0]], atol=1e-13)
    assert direct.method == "kane" and direct.settings["premature"] is False
    assert premature.settings["premature"] is True
    assert_same_as_autodiff(model)


@pytest.mark.parametrize("m, L, R, k, spin", [(1.0, 1.0, 1.0, 1.0, 2.0), (2.0, 0.8, 1.7, 3.0, 0.7)])
def test_geometric_stiffness_makes_the_premature_model_correct(m, L, R, k, spin):
    # The flexible bar is prematurely linearized by construction (modal kinematics); without
    # geometric stiffness it softens (Eq. 1.78), with it it equals the rigid bar's direct
    # linearization (Eq. 1.84 = Eq. 1.75), whether Kane's partials are linearized or not.
    rigid = kane(compile_model(table_bar(m, L, R, k, spin))).second_order
    correct = k + m * R * L * spin**2
    assert rigid.K[0, 0] == pytest.approx(correct, rel=1e-13)
    soft = compile_model(flexible_table_bar(m, L, R, k, spin, geometric=False))
    for premature in (False, True):
        assert kane(soft, premature=premature).second_order.K[0, 0] == pytest.approx(k - m * L**2 * spin**2, rel=1e-12)
    stiff = compile_model(flexible_table_bar(m, L, R, k, spin))
    for premature in (False, True):
        lin = kane(stiff, premature=premature)
        np.testing.assert_allclose(lin.second_order.K, rigid.K, rtol=1e-12)
        np.testing.assert_allclose(lin.second_order.M, rigid.M, rtol=1e-12)
        # Eq. 1.83: the geometric stiffness is m omega^2 (R + L) L.
        assert lin.stiffness["geometric_stiffness"][0, 0] == pytest.approx(m * spin**2 * (R + L) * L, rel=1e-12)
    assert_same_as_autodiff(stiff)


def three_link_chain(m, L, r, k, w) -> Scene:
    # Reference notes 3.4 (Banerjee 2016, Eqs. 8.1-8.3): rod OA of length r on a table spinning
    # at w, rods AB and BC of length L with masses m at B and C, springs k at A and B.
    return Scene("chain", effects=["joint_springs"],
                 bodies=[Body("table", 10.0, (1, 1, 1)), Body("AB", m, (0, 0, 0), com=[L, 0, 0]),
                         Body("BC", m, (0, 0, 0), com=[L, 0, 0])],
                 joints=[Joint("spin", "revolute", "table", prescribed={"profile": "ramp", "rate": w}),
                         Joint("A", "revolute", "AB", parent="table", parent_point=[r, 0, 0], stiffness=k),
                         Joint("B", "revolute", "BC", parent="AB", parent_point=[L, 0, 0], stiffness=k)])


def test_three_link_chain_inter_body_loads():
    # Reference notes 3.4 (Banerjee 2016, Eqs. 8.1-8.3): rod OA of length r on a table spinning
    # at omega, rods AB and BC of length L with masses m at B and C, springs k at A and B.
    m, L, r, k, w = 1.0, 1.0, 0.5, 10.0, 2.0
    scene = three_link_chain(m, L, r, k, w)
    model = compile_model(scene)
    direct, premature = kane(model), kane(model, premature=True)
    M = m * L**2 * np.array([[5.0, 2.0], [2.0, 1.0]])
    K = np.array([[k + 3 * m * w**2 * r * L, m * w**2 * r * L], [m * w**2 * r * L, k + m * w**2 * L * (r + L)]])
    Ki = np.array([[k - 5 * m * w**2 * L**2, -2 * m * w**2 * L**2], [-2 * m * w**2 * L**2, k - m * w**2 * L**2]])
    np.testing.assert_allclose(direct.second_order.M, M, rtol=1e-13)
    np.testing.assert_allclose(direct.second_order.K, K, rtol=1e-13)
    np.testing.assert_allclose(premature.second_order.K, Ki, rtol=1e-13)
    # The reference notes' numbers (section 14, test 3): 2.9634, 85.0366; premature -2.2843, 54.2843.
    w2 = np.sort(np.linalg.eigvals(np.linalg.solve(M, direct.second_order.K)).real)
    np.testing.assert_allclose(w2, [2.9634, 85.0366], atol=5e-5)
    w2p = np.sort(np.linalg.eigvals(np.linalg.solve(M, premature.second_order.K)).real)
    np.testing.assert_allclose(w2p, [-2.2843, 54.2843], atol=5e-5)


def test_double_pendulum_equals_autodiff_and_closed_form():
    model = compile_model(load_scene(EXAMPLES / "double_pendulum.toml"))
    lin = assert_same_as_autodiff(model, np.zeros(4))
    # Reference notes 1.3: omega^2 = (2 -+ sqrt 2) g / l for equal masses and lengths.
    so = lin.second_order
    w2 = np.sort(np.linalg.eigvals(np.linalg.solve(so.M, so.K)).real)
    scene = model.scene
    g, length = -scene.environment.gravity[2], -scene.bodies[0].com[2]
    np.testing.assert_allclose(w2, (2 + np.array([-1, 1]) * np.sqrt(2)) * g / length, rtol=1e-12)
    # Joint angles and rates: the second-order form's first-order form is sys itself.
    np.testing.assert_allclose(so.to_state_space().A, lin.sys.A, rtol=1e-13, atol=1e-13)
    # Off equilibrium (a swinging state): still equal to autodiff, affine term included.
    assert_same_as_autodiff(model, [0.4, -0.7, 1.1, 0.3])


@pytest.mark.parametrize("name", ["gyrostat", "attitude_control", "satellite_lvlh", "spacecraft_arrays"])
def test_examples_equal_autodiff(name):
    # Every effect of the shipped scenes (wheels, slosh, dampers, control, gravity gradient,
    # flexible arrays with geometric stiffness): same A, B, C, D to 1e-10 relative.
    model = compile_model(load_scene(EXAMPLES / f"{name}.toml"))
    lin = assert_same_as_autodiff(model)
    so = lin.second_order
    for parts, total in ((lin.stiffness, so.K), (lin.damping, so.D)):
        np.testing.assert_allclose(sum(parts.values()), total, rtol=1e-14, atol=1e-14 * np.max(np.abs(total)))
    # The second-order form has the eigenvalues of sys, less a zero per quaternion (its norm)
    # and plus a zero per integral of a speed (a torque-mode wheel's angle).
    ev = np.linalg.eigvals(lin.sys.A)
    ev2 = np.linalg.eigvals(so.to_state_space().A)
    n_quat = len(model.quaternions)
    n_int = sum(d.endswith(".integral") for d in so.dofs)
    assert ev2.size == ev.size - n_quat + n_int - (model.n_states - model.n_coordinates - model.n_speeds)
    scale = np.max(np.abs(ev))
    big = ev2[np.abs(ev2) > 1e-6 * scale]
    for e in big:  # every non-zero eigenvalue of the second-order form is one of sys
        # Same equations in other coordinates: round-off of two eigenvalue solves (rigid-body
        # clusters near zero excluded above); measured <= 1.4e-15 of the largest eigenvalue.
        assert np.min(np.abs(ev - e)) <= 1e-12 * scale, (e, name)


def spin_scene(Ix=10.0, Iy=12.0, Iz=8.0, J=0.2, W=0.3, Om=40.0) -> Scene:
    return Scene("spin", effects=["wheel_gyroscopics"], bodies=[Body("sc", 50.0, (Ix, Iy, Iz))],
                 joints=[Joint("att", "spherical", "sc")], wheels=[Wheel("w", "sc", J, axis=[0, 0, 1], speed=Om)],
                 frame=Frame("spin", rate=W, axis=[0, 0, 1]))


def test_torque_free_spin_closed_form():
    # Gyrostat spinning at W about z in a frame spinning with it (Hughes, Spacecraft Attitude
    # Dynamics, 2004, 3.5): nutation lambda^2 = -(Hs - Ix W)(Hs - Iy W)/(Ix Iy), Hs = Iz W + J
    # (W + Om), and +-i W from the attitude relative to the spinning frame.
    Ix, Iy, Iz, J, W, Om = 10.0, 12.0, 8.0, 0.2, 0.3, 40.0
    model = compile_model(spin_scene(Ix, Iy, Iz, J, W, Om))
    lin = assert_same_as_autodiff(model)
    Hs = (Iz + J) * W + J * Om
    wn = np.sqrt((Hs - Ix * W) * (Hs - Iy * W) / (Ix * Iy))
    so = lin.second_order
    assert so.dofs == ("att.rx", "att.ry", "att.rz")
    ev = np.linalg.eigvals(so.to_state_space().A)
    # Exact linear algebra on O(1) numbers: 1e-12.
    for e in (1j * wn, -1j * wn, 1j * W, -1j * W):
        assert np.min(np.abs(ev - e)) < 1e-12, (e, ev)
    # Conservative: the damping (inertia forces plus the kinematics of the small rotation in
    # the spinning frame) is gyroscopic, skew-symmetric; K symmetric; M is the inertia.
    assert set(lin.damping) == {"inertia", "kinematics"}
    np.testing.assert_allclose(so.D, -so.D.T, atol=1e-14)
    np.testing.assert_allclose(so.K, so.K.T, atol=1e-14)
    np.testing.assert_allclose(so.M, np.diag([Ix, Iy, Iz + J]), rtol=1e-14)


@pytest.mark.parametrize("I", [(100.0, 120.0, 50.0), (100.0, 80.0, 50.0), (60.0, 120.0, 100.0)])
def test_gravity_gradient_closed_form(I):
    # Nadir-pointing satellite in LVLH (Hughes 2004, 9.3): pitch s^2 = -3 (Ix - Iz)/Iy n^2;
    # roll/yaw s^4 + (1 + 3 k1 + k1 k3) s^2 + 4 k1 k3 = 0 in units of n.
    Ix, Iy, Iz = I
    scene = Scene("gg", effects=["gravity_gradient"], bodies=[Body("sc", 500.0, I)],
                  joints=[Joint("att", "spherical", "sc")], frame=Frame("lvlh"), orbit=Orbit(radius=7.0e6))
    model = compile_model(scene)
    n = scene.orbit.mean_motion
    lin = assert_same_as_autodiff(model)
    so = lin.second_order
    ev = np.linalg.eigvals(so.to_state_space().A) / n
    k1, k3 = (Iy - Iz) / Ix, (Iy - Ix) / Iz
    s2 = np.concatenate([np.roots([1, 1 + 3 * k1 + k1 * k3, 4 * k1 * k3]), [-3 * (Ix - Iz) / Iy]]).astype(complex)
    for e in np.concatenate([np.sqrt(s2), -np.sqrt(s2)]):
        assert np.min(np.abs(ev - e)) < 1e-9, (e, ev)  # exact Jacobians, eigenvalues in units of n
    # The gravity-gradient stiffness is its own entry: pitch 3 n^2 (Ix - Iz) (Hughes 2004, 9.3).
    assert lin.stiffness["gravity_gradient"][1, 1] == pytest.approx(3 * n**2 * (Ix - Iz), rel=1e-9)


def test_order_n_parameters_and_acceleration_outputs():
    # A free body on an orbit (quaternion + translation), an accelerometer (outputs through u'),
    # exposed parameters, and the order-n formulation: all still equal to autodiff.
    scene = Scene("gg", effects=["gravity_gradient", "joint_springs"],
                  bodies=[Body("sc", 500.0, (100.0, 120.0, 50.0)), Body("boom", 20.0, (5.0, 1.0, 5.0), com=[0, 2, 0])],
                  joints=[Joint("att", "free", "sc"),
                          Joint("hinge", "revolute", "boom", parent="sc", axis=[1, 0, 0], stiffness=3.0, damping=0.1)],
                  sensors=[Sensor("acc", "acceleration", "boom", point=[0, 4, 0])],
                  frame=Frame("lvlh"), orbit=Orbit(radius=7.0e6))
    for formulation in ("dense", "order-n"):
        model = compile_model(scene, params=["boom.mass", "hinge.stiffness"], formulation=formulation)
        x = model.x0.copy()
        x[model.states.index("hinge.angle")] = 0.2
        x[model.states.index("att.wx")] = 1e-3
        lin = assert_same_as_autodiff(model, x)
        assert lin.second_order.dofs[:6] == ("att.x", "att.y", "att.z", "att.rx", "att.ry", "att.rz")


def test_linearize_along_with_kane():
    # A pendulum's swing: Kane's direct linearization at every instant equals autodiff.
    model = compile_model(load_scene(EXAMPLES / "double_pendulum.toml"))
    nominal = simulate(model, np.linspace(0.0, 1.0, 5), x0=[0.5, -0.2, 0.0, 0.0])
    direct = linearize_along(model, nominal, method="kane")
    exact = linearize_along(model, nominal, method="autodiff")
    for a, b in zip(direct.linearizations, exact.linearizations):
        np.testing.assert_allclose(a.sys.A, b.sys.A, rtol=1e-10, atol=1e-10 * np.max(np.abs(b.sys.A)))


def test_kane_errors():
    pend = NonlinearModel(lambda x, u, t: np.array([x[1], -np.sin(x[0])]), states=["a", "w"])
    with pytest.raises(MethodUnavailableError, match="compiled scene"):
        linearize(pend, OperatingPoint([0.0, 0.0]), method="kane")
    model = compile_model(table_bar())
    with pytest.raises(ModelError, match="premature=True applies to method 'kane' only"):
        linearize(model, OperatingPoint(model.x0), method="autodiff", premature=True)
    exact = linearize(model, OperatingPoint(model.x0), method="autodiff")
    assert exact.second_order is None and exact.stiffness is None and exact.damping is None


def node_wheel_scene() -> Scene:
    # A torque-mode wheel spinning at a node of a clamped beam with geometric stiffness, in a
    # spinning frame: node rotation, gyroscopics and the beam's motion-induced stiffness at once.
    from linflex import Actuator, Beam, beam_modal_data

    data = beam_modal_data(Beam((0, 0, 0), (4.0, 0, 0), EA=2.8e7, EIy=1.4e3, EIz=2.8e3, GJ=1e3, mass_per_length=1.2,
                                elements=8), 4)
    wheel = Wheel(name="rw", body="beam", node="0.end", spin_inertia=0.05, transverse_inertia=0.03, mass=2.0,
                  axis=(0, 0, 1), mode="torque", speed=30.0)
    return Scene("node_wheel", effects=["wheel_gyroscopics", "geometric_stiffness"],
                 bodies=[Body("beam", 0.0, type="flexible", modal_data=data)],
                 joints=[Joint("clamp", "fixed", "beam")], wheels=[wheel],
                 actuators=[Actuator("motor", "wheel_torque", wheel="rw")],
                 sensors=[Sensor("tach", "wheel_speed", wheel="rw")], frame=Frame("spin", rate=0.8, axis=[0, 0, 1]))


def surfaces_scene() -> Scene:
    # A free body on an orbit with central gravity, drag, solar pressure and a thruster.
    from linflex import Actuator, Surface

    env = {"density": 4e-12, "reference_altitude": 500e3, "scale_height": 60e3, "sun_direction": [1.0, 2.0, 2.0],
           "solar_pressure": 4.56e-6}
    return Scene("surfaces", effects=["central_gravity", "aerodynamic_drag", "solar_pressure", "thrusters"],
                 bodies=[Body("sc", 12.0, [[3.0, 0.1, -0.2], [0.1, 4.0, 0.3], [-0.2, 0.3, 5.0]])],
                 joints=[Joint("j", "free", "sc")], frame=Frame("lvlh"), orbit=Orbit(radius=6.9e6), environment=env,
                 surfaces=[Surface("ram", "sc", 2.0, normal=[0.6, 0.8, 0], point=[0, 0.3, 0.1], drag_coefficient=2.2,
                                   reflectivity=0.3)],
                 actuators=[Actuator("jet", "thruster", body="sc", point=[0.2, 0.5, 0], axis=[0, 0, 1])])


@pytest.mark.parametrize("make", [node_wheel_scene, surfaces_scene])
def test_more_effects_equal_autodiff_off_equilibrium(make):
    # Every effect at a random state off equilibrium (the affine term kept): still the same
    # Jacobians as autodiff, to 1e-10 relative.
    model = compile_model(make())
    rng = np.random.default_rng(3)
    x = np.array(model.x0, float)
    moving = [k for k, name in enumerate(model.states) if not name.endswith(".qw")]
    x[moving] += rng.normal(scale=0.05, size=len(moving))
    for q in model.quaternions:
        x[q:q + 4] /= np.linalg.norm(x[q:q + 4])
    assert_same_as_autodiff(model, x)


def test_stiffness_shares_name_what_makes_each_mode_stiff():
    from linflex.linearize import stiffness_shares

    # The three-link chain (reference notes 3.4): the shares of each mode sum to its omega^2
    # (2.9634 and 85.0366 [rad^2/s^2]), the springs' and the centrifugal field's parts are the
    # Rayleigh quotients of their matrices.
    m, L, r, k, w = 1.0, 1.0, 0.5, 10.0, 2.0
    scene = three_link_chain(m, L, r, k, w)
    shares = stiffness_shares(kane(compile_model(scene)))
    np.testing.assert_allclose(shares.squared, [2.9634, 85.0366], atol=5e-5)
    np.testing.assert_allclose(sum(shares.shares.values()), shares.squared, rtol=1e-12)
    M = m * L**2 * np.array([[5.0, 2.0], [2.0, 1.0]])
    phi = shares.shapes
    np.testing.assert_allclose(phi.T @ M @ phi, np.eye(2), atol=1e-12)
    np.testing.assert_allclose(shares.shares["joint_springs"], k * np.sum(phi**2, axis=0), rtol=1e-12)
    assert np.all(shares.shares["inertia"] > 0)  # the spin stiffens both modes
    with pytest.raises(ModelError, match="method='kane'"):
        stiffness_shares(linearize(compile_model(scene), method="autodiff"))


def test_loop_joints_equal_autodiff():
    # Closed loops (the four-bar with a motor preload, the closed truss, a spatial loop on
    # spherical joints): the multipliers are unknowns beside u', the constraint forces one more
    # origin; A, B, C, D (the multiplier outputs included) equal autodiff's.
    from tests.linflex.test_loops import four_bar_scene, truss_scene

    for scene in (load_scene(EXAMPLES / "four_bar.toml"), four_bar_scene(tau=0.3), truss_scene()):
        model = compile_model(scene)
        x = np.array(model.x0, float)
        lin = assert_same_as_autodiff(model, x)
        assert "constraints" in lin.stiffness
        so = lin.second_order
        np.testing.assert_allclose(sum(lin.stiffness.values()), so.K, rtol=1e-12, atol=1e-12 * np.max(np.abs(so.K)))
        # Off the equilibrium too (velocities consistent with the constraints are not needed:
        # the compiled equations and Kane's are the same functions of any state).
        assert_same_as_autodiff(model, x + 1e-3 * np.random.default_rng(0).normal(size=x.size))
    # Onto the four-bar's one independent coordinate: the same one mode (4.45 rad/s).
    from linflex.linearize import constrained_linearization

    four_bar = compile_model(load_scene(EXAMPLES / "four_bar.toml"))
    keep = ["crank_hinge.angle", "crank_hinge.rate"]
    direct = constrained_linearization(four_bar, independent=keep, method="kane")
    exact = constrained_linearization(four_bar, independent=keep, method="autodiff")
    np.testing.assert_allclose(direct.sys.A, exact.sys.A, rtol=1e-10, atol=1e-12 * np.max(np.abs(exact.sys.A)))


def test_kane_equations_api_closed_forms_and_linearize():
    # KaneEquations.linearization (arrays in, arrays out) is what method="kane" reports: the
    # table bar's closed forms (reference notes 3.3: M = m L^2 = 1, K = k + m R L omega^2 = 5
    # direct, k - m L^2 omega^2 = -3 premature; Eqs. 1.75, 1.78) to 1e-13, and the same
    # M, D, K, B, stiffness and damping as linearize(..., method="kane") to 1e-12.
    model = compile_model(table_bar())
    eq = model.equations
    for premature, K in ((False, 5.0), (True, -3.0)):
        api = eq.linearization(model.x0, np.zeros(model.n_inputs), model.param_values, 0.0, premature=premature)
        np.testing.assert_allclose(api.second_order.M, [[1.0]], rtol=1e-13)
        np.testing.assert_allclose(api.second_order.K, [[K]], rtol=1e-13)
        assert api.A.shape == (model.n_states, model.n_states) and not api.A.flags.writeable
        with pytest.raises(TypeError):
            api.stiffness["inertia"] = np.zeros((1, 1))
    with pytest.raises(ShapeError, match=r"x has shape \(1,\) but shape \(2,\) was expected"):
        eq.linearization([0.0], np.zeros(0), model.param_values, 0.0)
    for name in ("spacecraft_arrays", "gyrostat"):
        model = compile_model(load_scene(EXAMPLES / f"{name}.toml"))
        op = OperatingPoint(model.x0, np.zeros(model.n_inputs))
        for premature in (False, True):
            api = model.equations.linearization(op.x, op.u, model.param_values, op.t, premature=premature)
            lin = linearize(model, op, method="kane", premature=premature, allow_non_equilibrium=True)
            so = lin.second_order
            for mine, theirs in ((api.second_order.M, so.M), (api.second_order.D, so.D), (api.second_order.K, so.K),
                                 (api.second_order.B, so.B), (api.A, lin.sys.A), (api.C, lin.sys.C)):
                np.testing.assert_allclose(mine, theirs, rtol=1e-12, atol=1e-12 * np.max(np.abs(theirs), initial=1.0))
            assert api.second_order.dofs == so.dofs and set(api.stiffness) == set(lin.stiffness)
            for o in api.stiffness:
                np.testing.assert_allclose(api.stiffness[o], lin.stiffness[o], rtol=1e-12,
                                           atol=1e-12 * np.max(np.abs(so.K)))
            for o in api.damping:
                np.testing.assert_allclose(api.damping[o], lin.damping[o], rtol=1e-12,
                                           atol=1e-12 * np.max(np.abs(so.D), initial=1.0))
        # Independent: the first-order Jacobians equal autodiff's (to 1e-10 relative).
        assert_same_as_autodiff(model)


def test_kane_functions_are_cached_on_the_equations_not_the_module():
    # The CasADi functions are built once per equations object and flag: a second call reports
    # no setup time; another compiled model builds its own.
    first, second = compile_model(table_bar()), compile_model(table_bar())
    args = (first.x0, np.zeros(0), first.param_values, 0.0)
    assert first.equations.linearization(*args).setup_seconds > 0
    assert first.equations.linearization(*args).setup_seconds == 0.0
    assert first.equations.linearization(*args, premature=True).setup_seconds > 0
    assert kane(first).setup_seconds == 0.0
    assert kane(second).setup_seconds > 0
    import linflex.linearize._autodiff as autodiff_module
    import linflex.linearize._direct as direct_module

    assert not hasattr(direct_module, "_CACHE") and not hasattr(autodiff_module, "_CACHE")

"""compile_model(formulation="order-n") against the dense formulation, and its refusals.

The reference is the dense Kane formulation of the same scene (reference notes section 8.11:
the recursion must reproduce the dense equations at round-off level). Both solve
``M u' = rhs``; the difference is bounded by the conditioning of ``M``, which grows with the
chain length (segments of a rigid-segment beam, tip half segment).
"""

from __future__ import annotations

import dataclasses

import casadi as ca
import numpy as np
import pytest

from linflex import (
    Actuator,
    Body,
    Controller,
    Disturbance,
    Effect,
    Frame,
    Joint,
    ModelError,
    Orbit,
    Pendulum,
    Scene,
    Sensor,
    Spring,
    Wheel,
    compile_model,
    register_effect,
    rigid_segment_beam,
    simulate,
)
from linflex.dynamics._kane import MassElement


def spring_chain(n: int, *, effects=("joint_springs", "gravity"), damping=0.02, **kw) -> Scene:
    bodies, joints = rigid_segment_beam("beam", length=0.25 * n, EI=20.0, mass_per_length=1.5, segments=n,
                                        damping=damping, bending_axis=(0.0, 1.0, 0.0))
    return Scene(f"chain{n}", bodies=list(bodies), joints=list(joints), effects=list(effects), **kw)


def branched_tree() -> Scene:
    """A hub on a prismatic rail carrying two revolute arms (one with a fixed tip mass, one with
    a two-link sub-chain) and a prescribed body: every kind of supported joint."""
    inertia = [[0.3, 0.01, 0.02], [0.01, 0.4, 0.03], [0.02, 0.03, 0.5]]
    bodies = [Body("hub", 5.0, inertia, com=[0.1, 0.0, 0.05]),
              Body("arm1", 1.0, [0.01, 0.2, 0.2], com=[0.5, 0.0, 0.0]),
              Body("tip1", 0.3, [1e-3, 1e-3, 1e-3], com=[0.05, 0.02, 0.0]),
              Body("arm2", 1.2, [0.1, 0.3, 0.25], com=[0.0, 0.6, 0.1]),
              Body("arm2b", 0.7, [0.01, 0.1, 0.1], com=[0.0, 0.4, 0.0]),
              Body("arm2c", 0.4, [0.01, 0.05, 0.05], com=[0.2, 0.1, 0.0]),
              Body("spinner", 0.5, [0.02, 0.02, 0.03], com=[0.0, 0.05, 0.0]),
              Body("locked", 0.2, [1e-3, 2e-3, 3e-3], com=[0.0, 0.0, 0.1])]
    joints = [Joint("rail", "prismatic", "hub", axis=[1, 0.2, 0], stiffness=3.0, damping=0.1),
              Joint("shoulder1", "revolute", "arm1", parent="hub", axis=[0, 0, 1], parent_point=[0.3, 0, 0],
                    child_point=[0.05, 0.0, 0.01], stiffness=2.0, damping=0.05, rest=0.2),
              Joint("weld", "fixed", "tip1", parent="arm1", parent_point=[1.0, 0, 0]),
              Joint("shoulder2", "revolute", "arm2", parent="hub", axis=[1, 1, 0], parent_point=[0, 0.3, 0],
                    stiffness=1.5),
              Joint("elbow2", "revolute", "arm2b", parent="arm2", axis=[0, 0.3, 1], parent_point=[0, 1.2, 0.1],
                    stiffness=0.8, damping=0.01),
              Joint("slide2", "prismatic", "arm2c", parent="arm2b", axis=[0, 1, 0], parent_point=[0, 0.8, 0],
                    stiffness=4.0),
              Joint("drive", "revolute", "spinner", parent="hub", axis=[0, 0, 1], parent_point=[0, -0.2, 0],
                    prescribed={"profile": "sine", "offset": 0.1, "amplitude": 0.3, "frequency": 2.0, "phase": 0.0}),
              Joint("stop", "revolute", "locked", parent="arm2", axis=[1, 0, 0], parent_point=[0, 0.5, 0],
                    locked=True, q0=0.4)]
    return Scene("tree", bodies=bodies, joints=joints, effects=["joint_springs", "gravity"],
                 actuators=[Actuator("motor", "torque", body="arm2b", axis=[0, 0.3, 1]),
                            Actuator("push", "force", body="arm1", point=[0.8, 0, 0], axis=[0, 1, 0])],
                 disturbances=[Disturbance("kick", "torque", body="hub")],
                 sensors=[Sensor("tip_pos", "position", body="tip1", point=[0.1, 0, 0]),
                          Sensor("arm_rate", "rate", body="arm2c"),
                          Sensor("tip_acc", "acceleration", body="arm2c", point=[0.1, 0.2, 0])])


def random_points(model, rng, count=3, scale=1.0):
    """Random states (angles and positions within +-0.6, rates within +-1.5), inputs and times."""
    for _ in range(count):
        x = np.concatenate([rng.uniform(-0.6, 0.6, model.n_coordinates) * scale,
                            rng.uniform(-1.5, 1.5, model.n_states - model.n_coordinates)])
        yield x, rng.normal(size=model.n_inputs), rng.uniform(0, 3)


def relative_difference(a, b):
    a, b = np.asarray(a, float).ravel(), np.asarray(b, float).ravel()
    return np.linalg.norm(a - b) / np.linalg.norm(a)


@pytest.mark.parametrize("n", [2, 5, 10, 20, 50])
def test_chain_matches_dense(n):
    scene = spring_chain(n)
    dense, order_n = compile_model(scene), compile_model(scene, formulation="order-n")
    assert order_n.states == dense.states and order_n.inputs == dense.inputs
    assert np.array_equal(order_n.x0, dense.x0)
    rng = np.random.default_rng(n)
    # Round-off of two solves of M u' = rhs, bounded by cond(M) eps: cond(M) is ~7e5 at 20
    # bodies (measured difference <= 1e-11) and ~2e7 at 50, where the dense result itself is
    # up to 1.5e-10 from an extended-precision solve of its own M and rhs (order-n: 4e-10).
    tol = 1e-10 if n <= 20 else 1e-9
    for x, u, t in random_points(dense, rng):
        assert relative_difference(dense.f(x, u, t), order_n.f(x, u, t)) < tol


def test_branched_tree_matches_dense_with_inputs_and_outputs():
    scene = branched_tree()
    dense, order_n = compile_model(scene), compile_model(scene, formulation="order-n")
    assert (order_n.states, order_n.inputs, order_n.outputs) == (dense.states, dense.inputs, dense.outputs)
    assert len(dense.inputs) == 5 and "tip_acc.x" in dense.outputs
    rng = np.random.default_rng(7)
    for x, u, t in random_points(dense, rng, count=5):
        # Round-off; the outputs include an acceleration sensor (they need u').
        assert relative_difference(dense.f(x, u, t), order_n.f(x, u, t)) < 1e-12
        assert relative_difference(dense.h(x, u, t), order_n.h(x, u, t)) < 1e-12


def test_rotating_frame_and_exposed_parameters_match_dense():
    # Centrifugal and Coriolis terms of a spinning scene frame; parameters stay symbolic.
    scene = spring_chain(4, frame=Frame("spin", rate=0.7, axis=[0, 0, 1]))
    params = ["beam_seg1.mass", "beam_seg2.Iyy", "beam_joint0.stiffness"]
    dense = compile_model(scene, params=params)
    order_n = compile_model(scene, params=params, formulation="order-n")
    p = dense.param_values * np.array([1.3, 0.8, 1.1])
    rng = np.random.default_rng(3)
    for x, u, t in random_points(dense, rng):
        assert relative_difference(dense.f(x, u, p, t), order_n.f(x, u, p, t)) < 1e-12  # round-off


def test_orbiting_chain_with_controller_and_thruster_matches_dense():
    # Orbit gravity and gradient, a thruster and a controller state: load-only effects and
    # auxiliary states enter exactly as in the dense formulation.
    scene = spring_chain(5, effects=("joint_springs", "central_gravity", "gravity_gradient", "thrusters", "control"),
                         frame=Frame("lvlh"), orbit=Orbit(radius=7.0e6),
                         sensors=[Sensor("bend", "attitude", body="beam_seg4", axis=[0, 1, 0])],
                         actuators=[Actuator("jet", "thruster", body="beam_seg4", point=[0.1, 0, 0], axis=[0, 0, 1])],
                         controllers=[Controller("lag", "transfer_function", inputs=["bend"], outputs=["jet"],
                                                 num=[2.0], den=[1.0, 3.0])])
    dense, order_n = compile_model(scene), compile_model(scene, formulation="order-n")
    assert order_n.states == dense.states and order_n.states[-1] == "lag.x0"
    rng = np.random.default_rng(11)
    for x, u, t in random_points(dense, rng):
        assert relative_difference(dense.f(x, u, t), order_n.f(x, u, t)) < 1e-12  # round-off
        assert relative_difference(dense.h(x, u, t), order_n.h(x, u, t)) < 1e-12


def free_floating(locked=False, effects=("joint_springs", "gravity")) -> Scene:
    """A free-flying hub with a revolute arm, a ball joint and a forearm (offset child points)."""
    bodies = [Body("hub", 10.0, [[1.0, 0.1, 0], [0.1, 1.2, 0.05], [0, 0.05, 1.5]], com=[0.1, 0, 0.02]),
              Body("arm", 1.0, [0.1, 0.1, 0.02], com=[0.5, 0, 0]),
              Body("ball", 0.5, [0.02, 0.03, 0.04], com=[0.1, 0.1, 0.2]),
              Body("fore", 0.4, [0.01, 0.02, 0.02], com=[0.2, 0, 0])]
    joints = [Joint("float", "free", "hub", locked=(["y"] if locked else False), parent_point=[0.1, 0.2, 0.3],
                    child_point=[0.05, -0.1, 0.02]),
              Joint("hinge", "revolute", "arm", parent="hub", axis=[0, 0, 1], parent_point=[1, 0, 0], stiffness=2.0),
              Joint("sph", "spherical", "ball", parent="arm", parent_point=[1, 0, 0], child_point=[0.02, 0.01, -0.03]),
              Joint("hinge2", "revolute", "fore", parent="ball", axis=[0, 1, 0], parent_point=[0.3, 0, 0],
                    stiffness=1.0)]
    return Scene("floating", bodies=bodies, joints=joints, effects=list(effects))


@pytest.mark.parametrize("locked", [False, True])
def test_free_and_spherical_joints_match_dense(locked):
    # Reference notes 8.11: repeat with the root as a free 6-degree-of-freedom body.
    scene = free_floating(locked)
    dense, order_n = compile_model(scene), compile_model(scene, formulation="order-n")
    assert order_n.states == dense.states and order_n.quaternions == dense.quaternions
    rng = np.random.default_rng(5)
    for x, u, t in random_points(dense, rng):
        assert relative_difference(dense.f(x, u, t), order_n.f(x, u, t)) < 1e-12  # round-off


def test_free_floating_simulation_conserves_energy_and_momentum():
    # No external load: energy and angular momentum (about the origin, inertial axes) constant.
    model = compile_model(free_floating(effects=("joint_springs",)), formulation="order-n")
    x0 = np.array(model.x0)
    x0[model.states.index("hinge.angle")] = 0.4
    x0[model.states.index("sph.wx")] = 0.8
    x0[model.states.index("float.wz")] = 0.3
    x0[model.states.index("float.vx")] = 0.1
    r = simulate(model, np.linspace(0.0, 5.0, 101), x0, rtol=1e-10, atol=1e-12)
    assert np.ptp(r.energy) < 1e-7 * np.max(np.abs(r.energy))  # integrator tolerance 1e-10
    H = r.momentum
    assert np.max(np.ptp(H, axis=0)) < 1e-7 * np.max(np.linalg.norm(H, axis=1))


def test_constant_speed_wheels_match_dense():
    # Spinning rotors on a free-flying hub and on an arm: gyroscopic coupling, no extra speeds.
    scene = free_floating(effects=("joint_springs", "wheel_gyroscopics"))
    scene = scene.replace(wheels=(Wheel("rw1", "hub", spin_inertia=0.05, transverse_inertia=0.02, mass=1.0,
                                        point=[0.2, 0.1, 0], axis=[1, 1, 0], speed=200.0),
                                  Wheel("rw2", "arm", spin_inertia=0.01, axis=[0, 0, 1], speed=-150.0)))
    dense, order_n = compile_model(scene), compile_model(scene, formulation="order-n")
    rng = np.random.default_rng(4)
    for x, u, t in random_points(dense, rng):
        assert relative_difference(dense.f(x, u, t), order_n.f(x, u, t)) < 1e-12  # round-off


def test_order_n_graph_grows_linearly():
    # The recursion's graph size per body is constant; the dense partial velocities are O(n^2).
    sizes = {n: compile_model(spring_chain(n), formulation="order-n").graph_size for n in (20, 40, 80)}
    per_body = [(sizes[40] - sizes[20]) / 20, (sizes[80] - sizes[40]) / 40]
    assert abs(per_body[1] - per_body[0]) < 0.05 * per_body[0]  # linear: constant increment


def test_spring_chain_simulation_conserves_energy():
    # Undamped spring chain under gravity: conservative, energy constant to the tolerances.
    model = compile_model(spring_chain(8, damping=0.0), formulation="order-n")
    x0 = np.array(model.x0)
    x0[: model.n_coordinates] = np.linspace(0.3, -0.2, model.n_coordinates)
    r = simulate(model, np.linspace(0.0, 2.0, 201), x0, rtol=1e-10, atol=1e-12)
    E = r.energy
    assert np.ptp(E) < 1e-6 * np.max(np.abs(E))  # rtol 1e-10 over ~100 oscillation periods of the stiffest joint
    # Not trivially at rest: the kinetic energy takes a sizeable share.
    assert np.ptp(r.x[:, model.n_coordinates]) > 0.1


def test_unknown_formulation_is_refused():
    with pytest.raises(ModelError, match="formulation must be one of 'dense', 'order-n', got 'sparse'"):
        compile_model(spring_chain(2), formulation="sparse")


class _Slider(Effect):
    """A custom effect (not built in): a point mass sliding along the hub's x axis, its own
    coordinate and speed."""

    name = "order_n_test_slider"

    def structure(self, b, scene):
        q, u = b.add_coordinates(["slider.s"], ["slider.v"])
        b.set_kinematics(q, u)
        frame = b.frames["hub"]
        b.add_element(MassElement("slider", 0.5, None, frame.r + frame.C @ ca.vertcat(q[0], 0, 0), frame.C, frame.w,
                                  body="hub"))


def test_refusals_name_what_is_not_supported():
    # Parts of effects that are not built in: order-n cannot know how they move on their body.
    register_effect(_Slider(), replace=True)
    scene = Scene("custom", bodies=[Body("hub", 10.0, [1.0, 1.0, 1.0]), Body("arm", 1.0, [0.1, 0.1, 0.1])],
                  joints=[Joint("pin", "revolute", "hub"),
                          Joint("hinge", "revolute", "arm", parent="hub", axis=[0, 0, 1])],
                  effects=["order_n_test_slider"])
    with pytest.raises(ModelError, match=r"element 'slider': a part moving relative to its body(.|\n)*"
                                         r"speeds \['slider.v'\]"):
        compile_model(scene, formulation="order-n")
    # The dense formulation still compiles it.
    assert compile_model(scene).n_speeds == 3


def flexible_chain(n: int, *, geometric=False, damping=0.01) -> Scene:
    """n flexible links (a 1 m beam, 2 modes each) on revolute springs about y, a rigid tip body
    on the last one; each link's child hangs on its frame (the beam's clamped end) 1 m out."""
    from linflex import Beam, beam_modal_data

    data = beam_modal_data(Beam((0, 0, 0), (1.0, 0, 0), EA=1e6, EIy=30.0, EIz=50.0, GJ=40.0, mass_per_length=1.0,
                                torsional_inertia_per_length=1e-3, elements=4), 2, damping=damping)
    bodies = [Body(f"link{k}", 0.2, [0.01, 0.01, 0.01], com=[0.1, 0, 0], type="flexible", modal_data=data)
              for k in range(n)]
    bodies.append(Body("tip", 0.5, [0.02, 0.03, 0.04], com=[0.05, 0.01, 0]))
    joints = [Joint(f"j{k}", "revolute", f"link{k}", parent="ground" if k == 0 else f"link{k - 1}",
                    axis=[0, 1, 0.2], parent_point=[0, 0, 0] if k == 0 else [1.0, 0, 0], stiffness=5.0, damping=damping)
              for k in range(n)]
    joints.append(Joint("weld", "fixed", "tip", parent=f"link{n - 1}", parent_point=[1.0, 0, 0]))
    effects = ["joint_springs", "gravity"] + (["geometric_stiffness"] if geometric else [])
    return Scene(f"flex{n}", bodies=bodies, joints=joints, effects=effects)


@pytest.mark.parametrize("n", [2, 5, 10])
def test_flexible_chain_matches_dense(n):
    scene = flexible_chain(n)
    dense, order_n = compile_model(scene), compile_model(scene, formulation="order-n")
    assert order_n.states == dense.states and "link0.eta1_rate" in dense.states
    rng = np.random.default_rng(20 + n)
    for x, u, t in random_points(dense, rng):
        # Round-off of two solves of M u' = rhs (cond(M) grows with n).
        assert relative_difference(dense.f(x, u, t), order_n.f(x, u, t)) < 1e-10


def test_flexible_chain_simulation_conserves_energy():
    # Undamped flexible links on springs under gravity: conservative (elastic energy included).
    model = compile_model(flexible_chain(3, damping=0.0), formulation="order-n")
    x0 = np.array(model.x0)
    x0[model.states.index("j0.angle")] = 0.5
    x0[model.states.index("j2.angle")] = -0.4
    x0[model.states.index("link1.eta0")] = 0.01
    r = simulate(model, np.linspace(0.0, 2.0, 101), x0, rtol=1e-10, atol=1e-12)
    assert np.ptp(r.energy) < 1e-6 * np.max(np.abs(r.energy))  # integrator tolerance 1e-10
    assert np.ptp(r.x[:, model.states.index("link1.eta0")]) > 1e-3  # the modes move


def test_flexible_chain_graph_grows_linearly():
    sizes = {n: compile_model(flexible_chain(n), formulation="order-n").graph_size for n in (5, 10, 20)}
    per_body = [(sizes[10] - sizes[5]) / 5, (sizes[20] - sizes[10]) / 10]
    assert abs(per_body[1] - per_body[0]) < 0.1 * per_body[0]  # linear: constant increment


def test_flexible_chain_with_geometric_stiffness_matches_dense():
    # The geometric stiffness adds acceleration terms to the modal rows only: M unsymmetric.
    scene = flexible_chain(3, geometric=True)
    dense, order_n = compile_model(scene), compile_model(scene, formulation="order-n")
    rng = np.random.default_rng(9)
    for x, u, t in random_points(dense, rng):
        assert relative_difference(dense.f(x, u, t), order_n.f(x, u, t)) < 1e-10  # round-off


# -- parts with speeds of their own: torque-mode wheels, wheels at nodes, slosh, dampers ---------


def test_torque_mode_wheels_match_dense_with_inputs_and_outputs():
    # Wheels with a speed state on the free-flying hub and on the arm (a sub-body with one
    # speed each), a motor torque on one, its speed sensor and an acceleration sensor.
    scene = free_floating(effects=("joint_springs", "wheel_gyroscopics", "gravity"))
    scene = scene.replace(wheels=(Wheel("rw1", "hub", spin_inertia=0.05, transverse_inertia=0.02, mass=1.0,
                                        point=[0.2, 0.1, 0], axis=[1, 1, 0], mode="torque", speed=100.0),
                                  Wheel("rw2", "arm", spin_inertia=0.01, transverse_inertia=0.004, axis=[0, 0.2, 1],
                                        mode="torque"),
                                  Wheel("cw", "fore", spin_inertia=0.01, axis=[0, 1, 0], speed=50.0)),
                          actuators=[Actuator("motor", "wheel_torque", wheel="rw2")],
                          sensors=[Sensor("rw2_speed", "wheel_speed", wheel="rw2"),
                                   Sensor("acc", "acceleration", body="arm", point=[0.5, 0.1, 0])])
    dense, order_n = compile_model(scene), compile_model(scene, formulation="order-n")
    assert order_n.states == dense.states and "rw1.speed" in dense.states and "rw2.speed" in dense.states
    rng = np.random.default_rng(31)
    for x, u, t in random_points(dense, rng):
        assert relative_difference(dense.f(x, u, t), order_n.f(x, u, t)) < 1e-12  # round-off
        assert relative_difference(dense.h(x, u, t), order_n.h(x, u, t)) < 1e-12


@pytest.mark.parametrize("geometric", [False, True])
@pytest.mark.parametrize("gyroscopics", [False, True])
def test_wheels_at_nodes_match_dense(geometric, gyroscopics):
    # Wheels at the tips of flexible links (node frame: translation Phi q and the exact rotation
    # of KaneBuilder.node_frame): sub-bodies of the link's frame and modes; one torque-mode, one
    # at a constant rate (locked to the node without wheel_gyroscopics), one on a link's frame.
    scene = flexible_chain(3, geometric=geometric)
    scene = scene.replace(
        effects=list(scene.effects) + (["wheel_gyroscopics"] if gyroscopics else []),
        wheels=(Wheel("rw", "link1", node="0.end", spin_inertia=0.05, transverse_inertia=0.03, mass=0.7,
                      axis=(0, 1, 1), mode="torque" if gyroscopics else "constant", speed=30.0),
                Wheel("cw", "link2", node="0.end", spin_inertia=0.02, transverse_inertia=0.01, mass=0.3,
                      axis=(1, 0, 0), speed=50.0),
                Wheel("fw", "link0", spin_inertia=0.02, transverse_inertia=0.01, mass=0.3, point=[0.3, 0, 0],
                      axis=(1, 0, 1), mode="torque" if gyroscopics else "constant")))
    dense, order_n = compile_model(scene), compile_model(scene, formulation="order-n")
    assert order_n.states == dense.states and ("rw.speed" in dense.states) == gyroscopics
    rng = np.random.default_rng(41)
    for x, u, t in random_points(dense, rng, scale=0.2):  # modal coordinates: node rotations ~0.1 rad
        assert relative_difference(dense.f(x, u, t), order_n.f(x, u, t)) < 1e-10  # round-off (measured <= 1.2e-14)


def test_slosh_pendulums_match_dense():
    # Spherical pendulums (two speeds each: a 2x2 solve) on the free-flying hub and on the
    # ball-jointed body, with hinge damping and gravity, in a spinning scene frame.
    scene = free_floating(effects=("joint_springs", "slosh", "gravity"))
    scene = scene.replace(frame=Frame("spin", rate=0.5, axis=[0, 1, 1]), pendulums=(Pendulum("fuel", "hub", mass=1.5, length=0.3, point=[0.1, 0.2, 0.0],
                                              direction=[0, 0.3, -1], damping=0.05),
                                     Pendulum("tank", "ball", mass=0.4, length=0.1, point=[0.05, 0, 0.1],
                                              direction=[1, 0, 0])))
    dense, order_n = compile_model(scene), compile_model(scene, formulation="order-n")
    assert order_n.states == dense.states and "fuel.rate2" in dense.states
    rng = np.random.default_rng(51)
    for x, u, t in random_points(dense, rng):
        assert relative_difference(dense.f(x, u, t), order_n.f(x, u, t)) < 1e-12  # round-off


def test_dampers_match_dense():
    # Nutation dampers (a point mass on a spring along a body axis) on the hub and the forearm.
    scene = free_floating(effects=("joint_springs", "dampers", "gravity"))
    scene = scene.replace(springs=(Spring("nd1", "hub", mass=0.3, stiffness=20.0, damping=0.5, point=[0.4, 0, 0.1],
                                          axis=[0, 1, 1]),
                                   Spring("nd2", "fore", mass=0.1, stiffness=5.0, point=[0.1, 0.05, 0],
                                          axis=[0, 0, 1])))
    dense, order_n = compile_model(scene), compile_model(scene, formulation="order-n")
    assert order_n.states == dense.states and "nd2.speed" in dense.states
    rng = np.random.default_rng(61)
    for x, u, t in random_points(dense, rng):
        assert relative_difference(dense.f(x, u, t), order_n.f(x, u, t)) < 1e-12  # round-off


def mixed_chain(n: int = 3, *, damping=0.01, geometric=False) -> Scene:
    """flexible_chain with every kind of part: wheels (torque-mode and constant, at nodes and on
    frames), slosh pendulums and dampers on the links and on the rigid tip, a wheel motor."""
    scene = flexible_chain(n, damping=damping, geometric=geometric)
    wheels = [Wheel(f"nw{k}", f"link{k}", node="0.end", spin_inertia=0.02, transverse_inertia=0.01, mass=0.3,
                    axis=(1, 0.5 * k, 0), mode="torque" if k % 2 == 0 else "constant", speed=20.0)
              for k in range(n)]
    wheels.append(Wheel("tw", "tip", spin_inertia=0.01, transverse_inertia=0.005, mass=0.2, point=[0.05, 0, 0],
                        axis=(0, 0, 1), mode="torque", speed=-40.0))
    pendulums = [Pendulum("fuel", "link0", mass=0.3, length=0.1, point=[0.2, 0, 0], damping=0.01 * damping),
                 Pendulum("tipfuel", "tip", mass=0.2, length=0.05, point=[0.1, 0, 0], direction=[0, 1, 0])]
    springs = [Spring("nd", f"link{n - 1}", mass=0.1, stiffness=30.0, damping=damping, point=[0.5, 0, 0],
                      axis=[0, 0, 1]),
               Spring("tipnd", "tip", mass=0.05, stiffness=10.0, point=[0.0, 0.1, 0], axis=[1, 0, 0])]
    return scene.replace(effects=list(scene.effects) + ["wheel_gyroscopics", "slosh", "dampers"],
                         wheels=tuple(wheels), pendulums=tuple(pendulums), springs=tuple(springs),
                         actuators=[Actuator("motor", "wheel_torque", wheel="tw")])


@pytest.mark.parametrize("geometric", [False, True])
def test_mixed_chain_with_all_parts_matches_dense(geometric):
    scene = mixed_chain(3, geometric=geometric)
    dense, order_n = compile_model(scene), compile_model(scene, formulation="order-n")
    assert order_n.states == dense.states
    rng = np.random.default_rng(71)
    for x, u, t in random_points(dense, rng, scale=0.2):
        assert relative_difference(dense.f(x, u, t), order_n.f(x, u, t)) < 1e-10  # round-off (measured <= 4e-14)


def test_mixed_chain_simulation_conserves_energy():
    # Undamped, no motor torque, every wheel free-spinning (a wheel held at a constant rate is
    # driven by a motor that does work): the order-n model with every kind of part conserves
    # the mechanical energy.
    scene = mixed_chain(2, damping=0.0)
    scene = scene.replace(wheels=tuple(dataclasses.replace(w, mode="torque") for w in scene.wheels))
    model = compile_model(scene, formulation="order-n")
    x0 = np.array(model.x0)
    x0[model.states.index("j0.angle")] = 0.4
    x0[model.states.index("fuel.theta1")] = 0.3
    x0[model.states.index("nd.position")] = 0.02
    x0[model.states.index("link1.eta0_rate")] = 0.3
    r = simulate(model, np.linspace(0.0, 1.0, 51), x0, rtol=1e-10, atol=1e-12)
    # rtol 1e-10 (measured drift 1.2e-9 relative)
    assert np.ptp(r.energy) < 1e-7 * np.max(np.abs(r.energy))
    assert np.ptp(r["nw0.speed"]) > 1e-3  # the node wheel's speed is driven by the structure


def test_parts_graph_grows_linearly():
    # A torque-mode wheel and a damper on every body: each part costs a fixed number of
    # operations, so the increment per body stays constant (no dense solve over the part speeds).
    def scene(n):
        base = spring_chain(n, effects=("joint_springs", "gravity", "wheel_gyroscopics", "dampers"))
        wheels = [Wheel(f"rw{k}", b.name, spin_inertia=0.01, transverse_inertia=0.005, axis=(1, 0, 1), mode="torque")
                  for k, b in enumerate(base.bodies)]
        springs = [Spring(f"nd{k}", b.name, mass=0.05, stiffness=10.0, damping=0.1, axis=(0, 0, 1))
                   for k, b in enumerate(base.bodies)]
        return base.replace(wheels=tuple(wheels), springs=tuple(springs))

    sizes = {n: compile_model(scene(n), formulation="order-n").graph_size for n in (10, 20, 40)}
    per_body = [(sizes[20] - sizes[10]) / 10, (sizes[40] - sizes[20]) / 20]
    assert abs(per_body[1] - per_body[0]) < 0.05 * per_body[0]  # linear: constant increment

"""Closed kinematic loops: loop joints with multipliers, consistent x0, stabilization, linearization.

References are hand derivations in the comments, each computed independently in numpy here:
the four-bar's position analysis (circle intersection), its velocity ratios (loop-closure
equation) and statics (two-force coupler), and the pin-jointed truss's assembled stiffness.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg

from linflex import (
    Actuator,
    Body,
    Joint,
    LoopJoint,
    ModelError,
    OperatingPoint,
    Scene,
    compile_model,
    load_scene,
    simulate,
)
from linflex.linearize import constrained_linearization

# -- the four-bar mechanism -------------------------------------------------------------------
#
#            C  (pin: revolute loop joint, coupler tip = rocker tip)
#           / \
#     b   /     \  c
#       /         \
#     B             O4 = (d, 0)         a = |O2 B| crank, b = |B C| coupler, c = |O4 C| rocker
#    /  a
#  O2 = (0, 0)
#
# Crank-rocker (Grashof: a + b <= c + d). The crank hinge has a torsional spring k; a motor
# torque tau acts on the rocker about z. Thin rods: mass centre at mid-length, I_G = m L^2 / 12.

A_, B_, C_, D_ = 0.4, 1.2, 0.9, 1.0
M2, M3, M4 = 0.5, 1.5, 1.0
K_SPRING = 5.0
TH2 = np.deg2rad(60.0)


def rod(name: str, mass: float, length: float) -> Body:
    return Body(name, mass, [1e-4, mass * length**2 / 12, mass * length**2 / 12], com=[length / 2, 0, 0])


def four_bar_positions(th2: float) -> tuple[np.ndarray, np.ndarray, float, float]:
    """Hand position analysis: C is the intersection of the circles (B, b) and (O4, c) on the
    open branch (left of the line B -> O4); returns B, C and the coupler and rocker angles."""
    B = A_ * np.array([np.cos(th2), np.sin(th2)])
    O4 = np.array([D_, 0.0])
    dist = np.linalg.norm(O4 - B)
    along = (dist**2 + B_**2 - C_**2) / (2 * dist)
    e = (O4 - B) / dist
    C = B + along * e + np.sqrt(B_**2 - along**2) * np.array([-e[1], e[0]])
    return B, C, float(np.arctan2(*(C - B)[::-1])), float(np.arctan2(*(C - O4)[::-1]))


def four_bar_ratios(th2: float) -> tuple[float, float]:
    """Velocity ratios th3'/th2', th4'/th2' from the loop-closure equation
    a e^{i th2} + b e^{i th3} = d + c e^{i th4}, differentiated and projected on e^{-i th4} and
    e^{-i th3}: th3' = a sin(th4 - th2) / (b sin(th3 - th4)) th2',
    th4' = a sin(th2 - th3) / (c sin(th4 - th3)) th2'."""
    _, _, th3, th4 = four_bar_positions(th2)
    return (A_ * np.sin(th4 - th2) / (B_ * np.sin(th3 - th4)),
            A_ * np.sin(th2 - th3) / (C_ * np.sin(th4 - th3)))


def cross2(u, v) -> float:
    return float(u[0] * v[1] - u[1] * v[0])


def pin_force(tau: float) -> np.ndarray:
    """Hand statics: the coupler carries no load between its pins, so it is a two-force member
    with the force f e along e = (C - B)/b; on the rocker (-f e at C) the moments about O4
    balance the motor: tau - f [(C - O4) x e]_z = 0. Returns the force on the coupler at C."""
    B, C, _, _ = four_bar_positions(TH2)
    e = (C - B) / B_
    f = tau / cross2(C - np.array([D_, 0.0]), e)
    return f * e


def spring_rest(tau: float) -> float:
    """Crank statics: the coupler pushes the crank at B with +f e (the opposite of its own
    force there, -f e); -k (th2 - rest) + [B x f e]_z = 0."""
    B, _, _, _ = four_bar_positions(TH2)
    return TH2 - cross2(B, pin_force(tau)) / K_SPRING


def four_bar_scene(*, tau: float = 0.0, dq=(0.0, 0.0, 0.0), u0=None, **loop) -> Scene:
    _, _, th3, th4 = four_bar_positions(TH2)
    return Scene(
        "four_bar", effects=["joint_springs"],
        bodies=[rod("crank", M2, A_), rod("coupler", M3, B_), rod("rocker", M4, C_)],
        joints=[Joint("crank_hinge", "revolute", "crank", q0=TH2 + dq[0], u0=u0, stiffness=K_SPRING,
                      rest=spring_rest(tau)),
                Joint("coupler_hinge", "revolute", "coupler", parent="crank", parent_point=[A_, 0, 0],
                      q0=th3 - TH2 + dq[1]),
                Joint("rocker_hinge", "revolute", "rocker", parent_point=[D_, 0, 0], q0=th4 + dq[2])],
        loop_joints=[LoopJoint("pin", "revolute", "coupler", "rocker", point_a=[B_, 0, 0], point_b=[C_, 0, 0],
                               **loop)],
        actuators=[Actuator("motor", "torque", body="rocker", axis=[0, 0, 1])])


def test_x0_closes_the_loop_from_rough_coordinates():
    # Initial angles off by up to 0.05 rad and a crank rate of 1 rad/s that the others ignore:
    # compile_model's Newton solve and speed projection close the loop to 1e-12 (CLOSURE_TOL).
    model = compile_model(four_bar_scene(dq=(0.03, -0.05, 0.04), u0=1.0))
    phi, phidot = model.constraints.residual(model.x0)
    assert np.max(np.abs(phi)) < 1e-12  # [m]
    assert np.max(np.abs(phidot)) < 1e-12  # [m/s]
    assert np.any(model.x0[3:] != 0)
    # Planar loop closed by a revolute joint: 5 rows, the x and y rows independent.
    assert model.constraints.rows == ("pin.x", "pin.y", "pin.z", "pin.r1", "pin.r2")
    assert model.constraints.independent_rows == (0, 1)
    # The hand position analysis at the crank angle Newton arrived at (1e-9: round-off of the
    # circle intersection).
    _, _, th3, th4 = four_bar_positions(model.x0[0])
    x = dict(zip(model.states, model.x0))
    assert x["coupler_hinge.angle"] == pytest.approx(th3 - model.x0[0], abs=1e-9)
    assert x["rocker_hinge.angle"] == pytest.approx(th4, abs=1e-9)


@pytest.mark.parametrize("symbolic", ["SX", "MX"])
def test_multipliers_equal_hand_statics(symbolic):
    # At the equilibrium the spring rest was chosen for, the state derivative vanishes and the
    # pin force equals the two-force-member statics (pin_force); round-off level: 1e-10 N.
    tau = 0.8
    model = compile_model(four_bar_scene(tau=tau), symbolic=symbolic)
    xdot, y = model.evaluate(model.x0, [tau])
    assert np.max(np.abs(xdot)) < 1e-11
    out = dict(zip(model.outputs, y))
    expected = pin_force(tau)
    assert out["pin.force.x"] == pytest.approx(expected[0], abs=1e-10)
    assert out["pin.force.y"] == pytest.approx(expected[1], abs=1e-10)
    # The dependent rows (out of plane) carry nothing.
    for name in ("pin.force.z", "pin.torque.x", "pin.torque.y", "pin.torque.z"):
        assert out[name] == 0.0


def test_linearized_frequency_equals_hand_derivation():
    # One degree of freedom, the crank angle th2. Kinetic energy 1/2 M_eff th2'^2 with
    #   M_eff = I_O2 + m3 |v_G3|^2 + I_G3 r3^2 + I_O4 r4^2   (per unit th2', r3, r4 the ratios),
    #   v_G3 = i a e^{i th2} + i (b/2) r3 e^{i th3},  I_O = m L^2 / 3, I_G = m L^2 / 12;
    # potential 1/2 k (th2 - rest)^2 - tau th4(th2) (the motor's work), so about the equilibrium
    #   K_eff = k - tau d(r4)/d(th2)   and   omega^2 = K_eff / M_eff.
    # d(r4)/d(th2) by central differences of the hand ratios (step 1e-4: error ~1e-8).
    tau = 0.8
    model = compile_model(four_bar_scene(tau=tau))
    r3, r4 = four_bar_ratios(TH2)
    _, _, th3, _ = four_bar_positions(TH2)
    v_G3 = 1j * A_ * np.exp(1j * TH2) + 1j * B_ / 2 * r3 * np.exp(1j * th3)
    M_eff = M2 * A_**2 / 3 + M3 * abs(v_G3) ** 2 + M3 * B_**2 / 12 * r3**2 + M4 * C_**2 / 3 * r4**2
    h = 1e-4
    K_eff = K_SPRING - tau * (four_bar_ratios(TH2 + h)[1] - four_bar_ratios(TH2 - h)[1]) / (2 * h)
    omega = np.sqrt(K_eff / M_eff)

    lin = constrained_linearization(model, OperatingPoint(model.x0, [tau]))
    eig = np.linalg.eigvals(lin.sys.A)
    assert lin.sys.n_states == 2
    assert np.abs(eig) == pytest.approx([omega, omega], rel=1e-7)  # finite-difference K_eff
    assert np.max(np.abs(eig.real)) < 1e-10  # undamped
    assert lin.invariance_residual < 1e-12 and lin.constraint_residual < 1e-12
    # The full linearization has the same pair plus the stabilization's: the constraint error
    # obeys e'' + 20 e' + 100 e = 0 for the 2 independent rows, a double root at -10 each.
    full = np.sort_complex(np.linalg.eigvals(lin.full.sys.A))
    assert np.sum(np.abs(full + 10.0) < 1e-5) == 4  # defective double roots: ~sqrt(eps) spread
    # Another choice of independent coordinates: the same eigenvalues (round-off).
    by_crank = constrained_linearization(model, OperatingPoint(model.x0, [tau]),
                                         independent=["crank_hinge.angle", "crank_hinge.rate"])
    assert by_crank.independent == ("crank_hinge.angle", "crank_hinge.rate")
    assert np.sort(np.abs(np.linalg.eigvals(by_crank.sys.A))) == pytest.approx([omega, omega], rel=1e-7)
    # In crank coordinates the motor enters as tau r4 per unit crank inertia: B = [0, r4 / M_eff].
    assert by_crank.sys.B[:, 0] == pytest.approx([0.0, r4 / M_eff], rel=1e-9, abs=1e-12)


def test_constraint_residual_stays_below_1e9_over_100s():
    # Free swing (no motor torque) from 0.3 rad off the spring's rest with 1 rad/s on the crank
    # (the coupler and rocker hinges close the loop); CVODES at rtol 1e-12, atol 1e-14 and the
    # default Baumgarte gains (kd, kp) = (20, 100). Measured: |phi| <= 9e-12 m, |phi'| <= 5e-11
    # m/s (at rtol 1e-10: 4e-10 and 2e-9; without stabilization, (0, 0), at rtol 1e-12: 3e-7 m).
    model = compile_model(four_bar_scene(dq=(0.3, 0.0, 0.0), u0=1.0, solve_for=["coupler_hinge", "rocker_hinge"]))
    assert model.x0[0] == TH2 + 0.3 and model.x0[3] == 1.0  # the crank keeps its q0 and u0
    r = simulate(model, np.linspace(0.0, 100.0, 2001), rtol=1e-12, atol=1e-14)
    worst = max(max(np.max(np.abs(phi)), np.max(np.abs(phidot)))
                for phi, phidot in (model.constraints.residual(x) for x in r.x))
    assert worst < 1e-9  # [m], [m/s]: the requirement
    # Ideal joints do no work: energy is conserved to the integrator's accuracy.
    assert np.ptp(r.energy) / r.energy[0] < 1e-7
    # The motion is large (it is no small vibration about a point).
    assert np.ptp(r["crank_hinge.angle"]) > 0.5


# -- a closed truss ---------------------------------------------------------------------------
#
#            N3 (1, 1.5)
#           /  \                 Three telescoping bars (prismatic joints with axial springs
#     k31  /    \  k23           k12, k23, k31) pinned at the nodes (free revolute joints); node
#         /      \               N1 is pinned to the ground and has a torsional spring k_r on bar
#       N1 ------ N2 (2, 0)      1-2. The tree runs N1 -> N2 -> N3 -> back to N1, where a ball
#           k12                  loop joint closes it. Node masses M; each bar's mass m_b sits
#                                 at its inboard node (N1, N2, N3), the bar end at N1 is at rest.

NODES = np.array([[0.0, 0.0], [2.0, 0.0], [1.0, 1.5]])
K_BAR = {(0, 1): 400.0, (1, 2): 300.0, (2, 0): 500.0}
K_TORSION, M_NODE, M_BAR = 20.0, 2.0, 0.5


def truss_scene() -> Scene:
    def angle(i, j):
        v = NODES[j] - NODES[i]
        return float(np.arctan2(v[1], v[0]))

    def length(i, j):
        return float(np.linalg.norm(NODES[j] - NODES[i]))

    def point(name, mass):
        return Body(name, mass, [0.0, 0.0, 0.0])

    x = [1.0, 0.0, 0.0]
    a12, a23, a31 = angle(0, 1), angle(1, 2), angle(2, 0)
    return Scene(
        "truss", effects=["joint_springs"],
        bodies=[point("bar12", M_BAR), point("node2", M_NODE), point("bar23", M_BAR), point("node3", M_NODE),
                point("bar31", M_BAR), point("end31", 0.1)],
        joints=[Joint("r1", "revolute", "bar12", q0=a12, stiffness=K_TORSION, rest=a12),
                Joint("s12", "prismatic", "node2", parent="bar12", axis=x, parent_point=[length(0, 1), 0, 0],
                      stiffness=K_BAR[(0, 1)]),
                Joint("r2", "revolute", "bar23", parent="node2", q0=a23 - a12),
                Joint("s23", "prismatic", "node3", parent="bar23", axis=x, parent_point=[length(1, 2), 0, 0],
                      stiffness=K_BAR[(1, 2)]),
                Joint("r3", "revolute", "bar31", parent="node3", q0=a31 - a23),
                Joint("s31", "prismatic", "end31", parent="bar31", axis=x, parent_point=[length(2, 0), 0, 0],
                      stiffness=K_BAR[(2, 0)])],
        loop_joints=[LoopJoint("closure", "ball", "end31", "ground")])


def test_closed_truss_frequencies_equal_assembled_stiffness():
    # Independent reference: the truss stiffness of the free nodal displacements (x2, y2, x3, y3),
    #   K = sum_bars k (B e)(B e)^T + k_r / L12^2 (n12)(n12)^T   (n12 normal to bar 1-2 at N2),
    # with nodal masses M + m_b (the bar pinned at a free node moves with it); omega^2 = eig(K, M).
    K = np.zeros((4, 4))
    for (i, j), k in K_BAR.items():
        e = (NODES[j] - NODES[i]) / np.linalg.norm(NODES[j] - NODES[i])
        b = np.zeros(6)
        b[2 * i:2 * i + 2], b[2 * j:2 * j + 2] = -e, e
        K += k * np.outer(b[2:], b[2:])
    L12 = np.linalg.norm(NODES[1] - NODES[0])
    n12 = np.array([0.0, 1.0, 0.0, 0.0]) / L12  # bar 1-2 lies along x
    K += K_TORSION * np.outer(n12, n12)
    omega = np.sqrt(scipy.linalg.eigvalsh(K, np.eye(4) * (M_NODE + M_BAR)))

    model = compile_model(truss_scene())  # 6 speeds: the MX (numeric solve) branch
    assert model.constraints.independent_rows == (0, 1)  # the ball's z row is empty (planar)
    lin = constrained_linearization(model)
    assert lin.sys.n_states == 8 and len(lin.dependent) == 4
    eig = np.linalg.eigvals(lin.sys.A)
    assert np.sort(np.abs(eig))[::2] == pytest.approx(omega, rel=1e-9)  # round-off of two solves
    assert np.max(np.abs(eig.real)) < 1e-9
    assert lin.invariance_residual < 1e-12
    # At rest the truss carries no load.
    xdot, y = model.evaluate(model.x0)
    assert np.max(np.abs(xdot)) < 1e-12 and np.max(np.abs(y)) < 1e-12


def test_weld_makes_a_double_pendulum_one_rigid_pendulum():
    # Two rods of length l hanging from a hinge, the elbow welded at its straight position: one
    # rigid pendulum, omega^2 = g (m1 l/2 + m2 3l/2) / (m1 l^2/3 + m2 (l^2/12 + (3l/2)^2)).
    # The weld's translation rows are satisfied by the elbow hinge already and its rotations about
    # x and z by the parallel hinges: 1 of its 6 rows is independent.
    g, l, m1, m2 = 9.81, 0.8, 1.2, 0.7
    link = dict(inertia=[m1 * l**2 / 12, m1 * l**2 / 12, 1e-4], com=[0, 0, -l / 2])
    scene = Scene("welded", effects=["gravity"],
                  bodies=[Body("upper", m1, **link), Body("lower", m2, [m2 * l**2 / 12, m2 * l**2 / 12, 1e-4],
                                                          com=[0, 0, -l / 2])],
                  joints=[Joint("shoulder", "revolute", "upper", axis=[0, 1, 0]),
                          Joint("elbow", "revolute", "lower", parent="upper", parent_point=[0, 0, -l],
                                axis=[0, 1, 0])],
                  loop_joints=[LoopJoint("weld", "weld", "lower", "upper", point_b=[0, 0, -l])])
    model = compile_model(scene)
    assert len(model.constraints.independent_rows) == 1
    lin = constrained_linearization(model)
    omega = np.sqrt(g * (m1 * l / 2 + m2 * 1.5 * l) / (m1 * l**2 / 3 + m2 * (l**2 / 12 + (1.5 * l) ** 2)))
    assert np.abs(np.linalg.eigvals(lin.sys.A)) == pytest.approx([omega, omega], rel=1e-10)


def test_spatial_loop_with_quaternions():
    # Two rods hang from spherical joints at O = (0, 0, 0) and P = (0.5, 0, 0); a ball loop joint
    # ties their tips together at (0, 0, -1). Three degrees of freedom: the triangle swings about
    # the line O P (x axis) and each rod spins freely about its own pivot-tip line u_i. The spins
    # have no stiffness, so in the swing mode they follow with zero momentum about u_i: with the
    # pivot inertia J_i = I_c + m (|c|^2 U3 - c c^T) (parallel axes, c = mid-rod),
    #   I_eff = sum_i e^T J_i e - (e^T J_i u_i)^2 / (u_i^T J_i u_i),   e = x,
    # and both mass centres sit 0.5 m below the axis: omega^2 = g (m_a + m_b) 0.5 / I_eff.
    g, masses = 9.81, (1.0, 0.6)
    tips = (np.array([0.0, 0.0, -1.0]), np.array([-0.5, 0.0, -1.0]))  # pivot to tip, body axes

    def inertia(m, d):  # a thin rod plus 1e-3 kg m^2 so that its spin has inertia
        u = d / np.linalg.norm(d)
        return m * (d @ d) / 12 * (np.eye(3) - np.outer(u, u)) + 1e-3 * np.eye(3)

    def scene(q0_a):
        return Scene("vee", effects=["gravity"],
                     bodies=[Body(n, m, inertia(m, d).tolist(), com=(d / 2).tolist())
                             for n, m, d in zip("ab", masses, tips)],
                     joints=[Joint("sa", "spherical", "a", q0=q0_a),
                             Joint("sb", "spherical", "b", parent_point=[0.5, 0, 0])],
                     loop_joints=[LoopJoint("tip", "ball", "a", "b", point_a=tips[0].tolist(),
                                            point_b=tips[1].tolist())])

    # Rod a turned 0.1 rad about x: Newton turns rod b (its quaternion) to meet it; the
    # quaternions stay unit and the loop closes to 1e-12.
    model = compile_model(scene([np.cos(0.05), np.sin(0.05), 0.0, 0.0]))
    phi, phidot = model.constraints.residual(model.x0)
    assert max(np.max(np.abs(phi)), np.max(np.abs(phidot))) < 1e-12
    for k in model.quaternions:
        assert np.linalg.norm(model.x0[k:k + 4]) == pytest.approx(1.0, abs=1e-15)
    r = simulate(model, np.linspace(0.0, 10.0, 201), rtol=1e-12, atol=1e-14)
    worst = max(max(np.max(np.abs(a)), np.max(np.abs(b))) for a, b in map(model.constraints.residual, r.x))
    assert worst < 1e-9  # measured 1.4e-12
    assert np.ptp(r.energy) / np.max(np.abs(r.energy)) < 1e-9  # measured 2e-12

    e = np.array([1.0, 0.0, 0.0])
    I_eff = 0.0
    for m, d in zip(masses, tips):
        c, u = d / 2, d / np.linalg.norm(d)
        J = inertia(m, d) + m * (c @ c * np.eye(3) - np.outer(c, c))
        I_eff += e @ J @ e - (e @ J @ u) ** 2 / (u @ J @ u)
    omega = np.sqrt(g * sum(masses) * 0.5 / I_eff)
    lin = constrained_linearization(compile_model(scene(None)))
    eig = np.linalg.eigvals(lin.sys.A)
    swing = eig[np.abs(eig) > 1e-3]  # the others: the free spins and the quaternion norms, at 0
    assert np.abs(swing) == pytest.approx([omega, omega], rel=1e-9)
    assert lin.invariance_residual < 1e-12


def test_flexible_beam_pinned_at_a_node():
    # A cantilever (16 elements, 8 clamped-free modes) whose tip node is pinned to the ground by a
    # ball loop joint: a clamped-pinned beam. Independent reference: the Ritz problem in the kept
    # mass-normalized modes, K = diag(omega_k^2), M = I, restricted to the null space of the tip's
    # modal translations Phi_tip (rank 2: the kept modes do not stretch the beam). Beam theory
    # (clamped-pinned, Euler-Bernoulli: 3.9266^2 sqrt(EI / (m L^4))) within the truncation, 0.5 %.
    from linflex import Beam, beam_modal_data

    length, EI, mass = 2.0, 50.0, 1.5
    data = beam_modal_data(Beam((0, 0, 0), (length, 0, 0), EA=1e6, EIy=EI, EIz=2 * EI, GJ=1e3,
                                mass_per_length=mass, elements=16), 8)
    scene = Scene("pinned", bodies=[Body("beam", 0.0, type="flexible", modal_data=data)],
                  joints=[Joint("clamp", "fixed", "beam")],
                  loop_joints=[LoopJoint("pin", "ball", "beam", "ground", node_a="0.end", point_b=[length, 0, 0])])
    lin = constrained_linearization(compile_model(scene))
    omega = np.sort(np.abs(np.linalg.eigvals(lin.sys.A)))[::2]
    _, tip, _ = data.node("0.end")
    N = scipy.linalg.null_space(tip, rcond=1e-9)
    reference = np.sqrt(scipy.linalg.eigvalsh(N.T @ np.diag(data.frequencies**2) @ N, N.T @ N))
    assert omega == pytest.approx(reference, rel=1e-9)
    assert omega[0] == pytest.approx(3.9266**2 * np.sqrt(EI / (mass * length**4)), rel=5e-3)
    assert omega[1] == pytest.approx(3.9266**2 * np.sqrt(2 * EI / (mass * length**4)), rel=5e-3)
    # Nodes belong to flexible bodies.
    bad = scene.replace(loop_joints=(LoopJoint("pin", "ball", "beam", "ground", node_a="0.ned", node_b="tip"),))
    with pytest.raises(ModelError) as err:
        bad.validate()
    assert "loop_joints[0].node_a: unknown node '0.ned' of 'beam'" in str(err.value)
    assert "loop_joints[0].node_b: the ground has no nodes" in str(err.value)


def test_dense_sx_and_mx_agree_off_equilibrium():
    # The same constrained equations expanded symbolically (SX) or solved numerically (MX):
    # equal state derivatives and multipliers at a moving, loaded state (round-off, 1e-12).
    scene = four_bar_scene(tau=0.8, dq=(0.2, 0.0, 0.0), u0=0.7, solve_for=["coupler_hinge", "rocker_hinge"])
    sx, mx = compile_model(scene, symbolic="SX"), compile_model(scene, symbolic="MX")
    assert np.array_equal(sx.x0, mx.x0)
    (f_sx, y_sx), (f_mx, y_mx) = sx.evaluate(sx.x0, [0.3]), mx.evaluate(mx.x0, [0.3])
    assert f_mx == pytest.approx(f_sx, abs=1e-12)
    assert y_mx == pytest.approx(y_sx, abs=1e-12)
    assert np.max(np.abs(f_sx[3:])) > 0.1  # it does accelerate


# -- errors and vocabulary ------------------------------------------------------------------


def test_bad_loop_joints_are_reported_together_with_paths():
    scene = four_bar_scene().replace(loop_joints=(
        LoopJoint("a", "hinge", "coupler", "rocker"),
        LoopJoint("b", "ball", "coupler", "rockr", axis_b=[0, 0, 1]),
        LoopJoint("c", "ball", "crank", "crank", point_a=[1, 2]),
        LoopJoint("d", "revolute", "crank", axis=[0, 0, 0], baumgarte=[-1.0, 4.0]),
        LoopJoint("crank", "ball", "crank"),
    ))
    with pytest.raises(ModelError) as err:
        scene.validate()
    message = str(err.value)
    for expected in ("loop_joints[0].type: unknown loop joint type 'hinge'",
                     "loop_joints[1].body_b: unknown body 'rockr' (did you mean 'rocker'?)",
                     "loop_joints[1].axis_b: only revolute loop joints take a hinge axis",
                     "loop_joints[2]: joins 'crank' to itself",
                     "loop_joints[2].point_a: expected a 3-vector",
                     "loop_joints[3].axis: must not be the zero vector",
                     "loop_joints[3].baumgarte: gains must not be negative",
                     "loop_joints[4].name: name 'crank' is already used by bodies[0]"):
        assert expected in message
    assert "7 problem(s)" in message or "8 problem(s)" in message


def test_loop_that_cannot_close_is_refused():
    # A rocker of 5 m cannot meet the coupler's tip (no farther than a + b + d = 2.6 m from O4):
    # Newton fails, with the joint's name and the residual in the message.
    scene = four_bar_scene().replace(
        loop_joints=(LoopJoint("pin", "revolute", "coupler", "rocker", point_a=[B_, 0, 0], point_b=[5.0, 0, 0]),))
    with pytest.raises(ModelError, match=r"loop_joints \(pin\): the initial coordinates do not close the loop"):
        compile_model(scene)


def test_order_n_with_loop_joints_equals_dense():
    # The recursion solves M^-1 [rhs, A^T] column by column (Banerjee Eq. 8.81): the same state
    # derivative and multiplier outputs as the dense solve, at and off the consistent state,
    # on the four-bar (revolute loop, redundant rows dropped) and the closed truss (ball loop).
    rng = np.random.default_rng(11)
    for scene in (four_bar_scene(tau=0.3), truss_scene()):
        dense, order_n = compile_model(scene), compile_model(scene, formulation="order-n")
        assert order_n.states == dense.states and order_n.outputs == dense.outputs
        np.testing.assert_allclose(order_n.x0, dense.x0, rtol=0, atol=1e-14)
        for x in (dense.x0, dense.x0 + 1e-2 * rng.normal(size=dense.n_states)):
            u = rng.normal(size=dense.n_inputs)
            fd, yd = dense.evaluate(x, u)
            fo, yo = order_n.evaluate(x, u)
            # Round-off of two solves of the same saddle-point system: 1e-11 relative.
            np.testing.assert_allclose(fo, fd, rtol=0, atol=1e-11 * np.max(np.abs(fd)))
            np.testing.assert_allclose(yo, yd, rtol=0, atol=1e-11 * np.max(np.abs(yd)))


def test_unconstrained_models_and_bad_points_are_refused():
    model = compile_model(four_bar_scene().replace(loop_joints=()))
    assert model.constraints is None
    with pytest.raises(ModelError, match="no loop constraints"):
        constrained_linearization(model)
    closed = compile_model(four_bar_scene())
    x = np.array(closed.x0)
    x[0] += 0.01
    with pytest.raises(ModelError, match="violates the loop constraints"):
        constrained_linearization(closed, OperatingPoint(x, [0.0]))
    with pytest.raises(ModelError, match="leave 1 coordinates and 1 speeds free"):
        constrained_linearization(closed, independent=["crank_hinge.angle"])


def test_loop_joints_round_trip_through_toml(tmp_path):
    scene = four_bar_scene(baumgarte=(4.0, 4.0))
    scene.save(tmp_path / "four_bar.toml")
    assert "[[loop_joints]]" in (tmp_path / "four_bar.toml").read_text()
    assert load_scene(tmp_path / "four_bar.toml") == scene
    assert Scene.from_dict(scene.to_dict()) == scene
